//! Tests of the AVX-512 lane pieces: weights and digits, row and window bounds.

use super::bicubic::{CubicSplit16, CubicWindow16};
use super::lanes::{Digits16, bilinear_u8_16, weights_u8_16};
use super::rows::Rows16;
use std::arch::x86_64::*;

fn lanes(f: impl Fn(i32) -> i32) -> __m512i {
    let v: [i32; 16] = std::array::from_fn(|j| f(j as i32));
    // SAFETY: sixteen i32 are one 512-bit vector.
    unsafe { std::mem::transmute::<[i32; 16], __m512i>(v) }
}

/// The sixteen-lane u8 weights are `bilinear_weights_u8`'s, and their byte digits add back
/// up to them (d2 2^16 + d1 2^8 + d0, d0 and d1 signed), at fractions including 0, 1/2 and
/// 1; the blend of taps (0, 1, 255, 128) by digits and by products is `bilinear_u8`'s.
#[test]
fn u8_weights_and_their_digits_are_the_scalar_ones() {
    if !crate::cpu::avx512_vbmi_vnni() {
        eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
        return;
    }
    let fracs = |s: u32| -> [f32; 16] {
        std::array::from_fn(|j| match (j as u32 + s) % 7 {
            0 => 0.0,
            1 => 1.0,
            2 => 0.5,
            k => {
                let h = (j as u32).wrapping_mul(2_654_435_761) ^ (s * 97 + k);
                (h % 1_000_003) as f32 / 1_000_003.0
            }
        })
    };
    let bytes = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [u8; 64]>(v) };
    let words = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [i32; 16]>(v) };
    let taps = [0u8, 1, 255, 128];
    for s in 0..50 {
        let (fx, fy) = (fracs(s), fracs(s + 3));
        // SAFETY: the CPU has AVX-512 F, BW, VBMI and VNNI (checked above).
        let (w, d, by_digits, by_products) = unsafe {
            let f = (_mm512_loadu_ps(fx.as_ptr()), _mm512_loadu_ps(fy.as_ptr()));
            let v = _mm512_set1_epi32(i32::from_le_bytes(taps));
            (
                weights_u8_16(f).map(words),
                Digits16::new(f).0.map(bytes),
                words(bilinear_u8_16::<true>(v, f)),
                words(bilinear_u8_16::<false>(v, f)),
            )
        };
        for l in 0..16 {
            let scalar = crate::raster::bilinear_weights_u8((fx[l], fy[l]));
            for (j, &want) in scalar.iter().enumerate() {
                assert_eq!(w[j][l], want, "lane {l} weight {j}");
                let digit = |k: usize| i32::from(d[k][4 * l + j] as i8);
                let back = (digit(2) << 16) + (digit(1) << 8) + digit(0);
                assert_eq!(back, want, "lane {l} weight {j}: digits");
                assert!((0..=64).contains(&digit(2)), "lane {l} weight {j}");
            }
            let want = i32::from(crate::raster::bilinear_u8(taps, (fx[l], fy[l])));
            assert_eq!((by_digits[l], by_products[l]), (want, want), "lane {l}");
        }
    }
}

/// The window stays inside its rows and the image: it starts early where 32 columns from
/// the first would pass the row's end, covers every column, and refuses three rows or a
/// span of 32 columns or more.
#[test]
fn rows_stay_inside_the_image() {
    if !crate::cpu::avx512_vbmi_vnni() {
        eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
        return;
    }
    let size = (40, 10);
    // SAFETY: the CPU has AVX-512 (checked above).
    let of = |ix, iy| unsafe { Rows16::of::<1>(ix, iy, [0, 0], size, (32, 2)) };
    let rows = of(lanes(|j| 20 + j), lanes(|j| 5 + j / 8)).expect("two rows, 16 columns");
    assert_eq!(
        (rows.row_start(0), rows.row_start(1)),
        (5 * 40 + 8, 6 * 40 + 8)
    );
    assert_eq!(rows.row_start(2), rows.row_start(1), "no third row read");
    assert_eq!(rows.cols, 20 + 15 - 8 + 1);
    let one_row = of(lanes(|j| 2 * j), lanes(|_| 9)).expect("one row, 31 columns");
    assert_eq!(
        (one_row.row_start(0), one_row.row_start(1)),
        (9 * 40, 9 * 40)
    );
    assert_eq!(one_row.cols, 31);
    assert!(of(lanes(|j| j * 3), lanes(|_| 0)).is_none(), "46 columns");
    assert!(of(lanes(|j| j), lanes(|j| j / 6)).is_none(), "three rows");
    // Bilinear's u8 windows: pixels on three rows and the row below fill four.
    // SAFETY: as above.
    let four = |ix, iy| unsafe { Rows16::of::<2>(ix, iy, [0, 0], size, (32, 4)) };
    let rows = four(lanes(|j| 3 + j), lanes(|j| 2 + j / 6)).expect("three pixel rows");
    let starts = [0, 1, 2, 3].map(|r| rows.row_start(r));
    assert_eq!(starts, [2 * 40 + 3, 3 * 40 + 3, 4 * 40 + 3, 5 * 40 + 3]);
    assert_eq!(rows.cols, 3 + 15 + 2 - 3);
    let last = four(lanes(|j| 3 + j), lanes(|j| 7 + j / 8)).expect("the last two rows");
    assert_eq!(
        last.row_start(3),
        last.row_start(2),
        "no row past the image"
    );
    assert!(
        four(lanes(|j| j), lanes(|j| j / 4)).is_none(),
        "four pixel rows"
    );
}

/// The bicubic window reads 32 samples of each row from its start, all inside the image
/// (it starts early near the right edge), with every pixel's four tap columns in [0, 32);
/// it refuses pixels off the interior, four pixel rows or more than 29 columns.
#[test]
fn cubic_windows_stay_inside_the_image() {
    if !crate::cpu::avx512_vbmi_vnni() {
        eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
        return;
    }
    let size = (40, 10);
    let split = |xi, yi| CubicSplit16 {
        xi,
        yi,
        tx: unsafe { _mm512_setzero_ps() },
        ty: unsafe { _mm512_setzero_ps() },
    };
    // SAFETY: the CPU has AVX-512 (checked above).
    let of = |xi, yi| unsafe { CubicWindow16::of(&split(xi, yi), size) };
    let cols = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [i32; 16]>(v) };
    for (xi, yi, rows) in [
        (lanes(|j| 20 + j), lanes(|j| 5 + j / 8), 5),
        (lanes(|j| 22 + j), lanes(|_| 7), 4),
        (lanes(|j| 1 + j), lanes(|j| 1 + j / 6), 6),
        (lanes(|j| 9 + 2 * j * 14 / 15), lanes(|_| 3), 4),
    ] {
        let win = of(xi, yi).expect("a window");
        assert_eq!(win.rows, rows);
        assert!(
            win.start + (win.rows - 1) * 40 + 32 <= 400,
            "inside the plane"
        );
        let (xs, first) = (win.start % 40, cols(xi));
        assert!(xs + 32 <= 40, "inside its rows");
        for (c, r) in first.iter().zip(cols(win.rel)) {
            assert_eq!(r, c - 1 - xs as i32, "tap columns from xs");
            assert!((0..=28).contains(&r));
        }
    }
    assert!(
        of(lanes(|j| j), lanes(|_| 3)).is_none(),
        "column 0 is not interior"
    );
    assert!(
        of(lanes(|j| 22 + j), lanes(|_| 8)).is_none(),
        "row 8 is not interior"
    );
    assert!(
        of(lanes(|j| 2 + j), lanes(|j| 1 + j / 4)).is_none(),
        "four pixel rows"
    );
    assert!(
        of(lanes(|j| 1 + 2 * j), lanes(|_| 3)).is_none(),
        "31 columns"
    );
}
