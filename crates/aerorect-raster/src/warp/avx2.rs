//! AVX2 kernel for the case that matters most: bilinear u8 (gray and colour frames).
//!
//! Eight destination pixels per step: f64 coordinates -> clamped i32 indices and f32 fractions
//! (as `Bilinear::prepare`), one 32-bit gather for the upper neighbour pair and one for the lower
//! pair, and the blend in f32 with the same operations in the same order as `Bilinear::apply`
//! (no FMA), so the result is bit-identical to the portable kernel (a test checks it).

use super::kernel::{Bilinear, Kernel, SourceGeometry};
use std::arch::x86_64::*;

/// Constants of one source image for the 8-pixel step.
pub(crate) struct Consts {
    lim_x: __m256d,
    lim_y: __m256d,
    neg_half: __m256d,
    zero: __m256d,
    max_x: __m256d,
    max_y: __m256d,
    i0max_x: __m128i,
    i0max_y: __m128i,
    width: __m256i,
    w_minus_2: __m256i,
    byte: __m256i,
    half: __m256,
    nodata: __m256i,
    pick: __m256i,
}

impl Consts {
    #[target_feature(enable = "avx2")]
    pub(crate) fn new(g: &SourceGeometry, nodata: u8) -> Self {
        let (w, h) = (g.width(), g.height());
        Self {
            lim_x: _mm256_set1_pd(w as f64 - 0.5),
            lim_y: _mm256_set1_pd(h as f64 - 0.5),
            neg_half: _mm256_set1_pd(-0.5),
            zero: _mm256_setzero_pd(),
            max_x: _mm256_set1_pd((w - 1) as f64),
            max_y: _mm256_set1_pd((h - 1) as f64),
            i0max_x: _mm_set1_epi32(w as i32 - 2),
            i0max_y: _mm_set1_epi32(h as i32 - 2),
            width: _mm256_set1_epi32(w as i32),
            w_minus_2: _mm256_set1_epi32(w as i32 - 2),
            byte: _mm256_set1_epi32(0xFF),
            half: _mm256_set1_ps(0.5),
            nodata: _mm256_set1_epi32(i32::from(nodata)),
            // Picks byte 0 of each 32-bit lane into the low 4 bytes of each 128-bit half.
            pick: _mm256_setr_epi8(
                0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 4, 8, 12, -1, -1,
                -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
            ),
        }
    }
}

/// Eight pixels: source positions (x, y) in two halves -> every band's output at `at`.
/// Returns the inside mask (bit k for pixel k).
///
/// # Safety
/// AVX2; source at least 2 x 2 with full planes; `at + 8 <= out.len()` for every output.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn step8(
    k: &Consts,
    (x_lo, x_hi, y_lo, y_hi): (__m256d, __m256d, __m256d, __m256d),
    planes: &[&[u8]],
    outs: &mut [&mut [u8]],
    at: usize,
) -> i32 {
    let inside = |x: __m256d, y: __m256d| {
        let a = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(x, k.neg_half),
            _mm256_cmp_pd::<_CMP_LT_OQ>(x, k.lim_x),
        );
        let b = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(y, k.neg_half),
            _mm256_cmp_pd::<_CMP_LT_OQ>(y, k.lim_y),
        );
        _mm256_and_pd(a, b)
    };
    let (in_lo, in_hi) = (inside(x_lo, y_lo), inside(x_hi, y_hi));
    let mask = _mm256_movemask_pd(in_lo) | (_mm256_movemask_pd(in_hi) << 4);
    // The eight 64-bit lane masks as eight 32-bit lane masks (even dwords of each half).
    let even = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    let lanes = _mm256_set_m128i(
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
            _mm256_castpd_si256(in_hi),
            even,
        )),
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
            _mm256_castpd_si256(in_lo),
            even,
        )),
    );
    // Clamp (max_pd returns its second operand, 0, for NaN), truncate, cap the index at n - 2.
    let split = |v: __m256d, vmax: __m256d, imax: __m128i| {
        let c = _mm256_min_pd(_mm256_max_pd(v, k.zero), vmax);
        let i0 = _mm_min_epi32(_mm256_cvttpd_epi32(c), imax);
        let f = _mm256_cvtpd_ps(_mm256_sub_pd(c, _mm256_cvtepi32_pd(i0)));
        (i0, f)
    };
    let (x0_lo, fx_lo) = split(x_lo, k.max_x, k.i0max_x);
    let (x0_hi, fx_hi) = split(x_hi, k.max_x, k.i0max_x);
    let (y0_lo, fy_lo) = split(y_lo, k.max_y, k.i0max_y);
    let (y0_hi, fy_hi) = split(y_hi, k.max_y, k.i0max_y);
    let x0 = _mm256_set_m128i(x0_hi, x0_lo);
    let y0 = _mm256_set_m128i(y0_hi, y0_lo);
    let fx = _mm256_set_m128(fx_hi, fx_lo);
    let fy = _mm256_set_m128(fy_hi, fy_lo);
    let off = _mm256_add_epi32(_mm256_mullo_epi32(y0, k.width), x0);
    let off_low = _mm256_add_epi32(off, k.w_minus_2);
    for (plane, out) in planes.iter().zip(outs.iter_mut()) {
        let base = plane.as_ptr() as *const i32;
        // SAFETY: off <= (h-2) w + (w-2), so the 4 bytes at off end by (h-1) w + 2 <= w h; the
        // lower pair is read at off + w - 2 >= 0 and ends by (h-2) w + (w-2) + w + 2 = w h.
        let (top, low) = unsafe {
            (
                _mm256_i32gather_epi32::<1>(base, off),
                _mm256_i32gather_epi32::<1>(base, off_low),
            )
        };
        let p00 = _mm256_cvtepi32_ps(_mm256_and_si256(top, k.byte));
        let p01 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32::<8>(top), k.byte));
        let p10 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32::<16>(low), k.byte));
        let p11 = _mm256_cvtepi32_ps(_mm256_srli_epi32::<24>(low));
        let t = _mm256_add_ps(p00, _mm256_mul_ps(fx, _mm256_sub_ps(p01, p00)));
        let b = _mm256_add_ps(p10, _mm256_mul_ps(fx, _mm256_sub_ps(p11, p10)));
        let v = _mm256_add_ps(t, _mm256_mul_ps(fy, _mm256_sub_ps(b, t)));
        let q = _mm256_cvttps_epi32(_mm256_add_ps(v, k.half));
        let q = _mm256_blendv_epi8(k.nodata, q, lanes);
        let bytes = _mm256_shuffle_epi8(q, k.pick);
        let packed = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
            bytes,
            _mm256_setr_epi32(0, 4, 1, 1, 1, 1, 1, 1),
        ));
        // SAFETY: at + 8 <= out.len() (the contract): the 8-byte store stays inside the row.
        unsafe { _mm_storel_epi64(out.as_mut_ptr().add(at) as *mut __m128i, packed) };
    }
    mask
}

/// Bilinear u8 for one block: `xs`, `ys` source positions, `planes` the source bands, `outs`
/// the destination bands (same length as `xs`); `valid`, when given, receives the inside flags.
///
/// # Safety
/// The CPU must have AVX2; the source must be at least 2 x 2 (`g.width, g.height >= 2`) and
/// every plane must hold `g.width * g.height` samples.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn bilinear_u8_block(
    g: &SourceGeometry,
    xs: &[f64],
    ys: &[f64],
    planes: &[&[u8]],
    outs: &mut [&mut [u8]],
    mut valid: Option<&mut [bool]>,
    nodata: u8,
) {
    let n = xs.len().min(ys.len());
    let k = Consts::new(g, nodata);
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: i + 8 <= n <= xs.len(), ys.len(), so the unaligned loads stay in bounds.
        let v = unsafe {
            (
                _mm256_loadu_pd(xs.as_ptr().add(i)),
                _mm256_loadu_pd(xs.as_ptr().add(i + 4)),
                _mm256_loadu_pd(ys.as_ptr().add(i)),
                _mm256_loadu_pd(ys.as_ptr().add(i + 4)),
            )
        };
        // SAFETY: as this function's contract; i + 8 <= n = every output's length.
        let mask = unsafe { step8(&k, v, planes, outs, i) };
        if let Some(v) = valid.as_deref_mut() {
            for b in 0..8 {
                v[i + b] = mask >> b & 1 == 1;
            }
        }
        i += 8;
    }
    // The tail through the portable kernel (same arithmetic).
    for k in i..n {
        let mut tap = Default::default();
        let ok = Bilinear::prepare(g, xs[k], ys[k], &mut tap);
        for (plane, out) in planes.iter().zip(outs.iter_mut()) {
            out[k] = if ok {
                Bilinear::apply(plane, g, &tap)
            } else {
                nodata
            };
        }
        if let Some(v) = valid.as_deref_mut() {
            v[k] = ok;
        }
    }
}
