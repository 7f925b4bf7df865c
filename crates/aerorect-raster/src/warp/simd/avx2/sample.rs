//! `SimdSample`: what each sample type (u8, u16, f32: one file each) brings to the AVX2 and
//! AVX-512 kernels.

use super::bicubic_lanes::{CubicWindow, cubic_sum8};
use super::bilinear_lanes::Taps8;
use super::lanes::Consts;
use super::nearest_lanes::NearestWindow;
use crate::raster::Sample;
use crate::warp::simd::avx512::rows::Rows16;
use std::arch::x86_64::*;

/// A sample type with an AVX2 bilinear step and a four-sample row load.
pub(crate) trait SimdSample: Sample {
    /// Whether `bilinear8` reads byte windows (`Window`) where they apply.
    const WINDOWS: bool = false;

    /// Bilinear at eight pixels of `plane`, written to `out[at..at + 8]` (nodata outside).
    ///
    /// # Safety
    /// AVX2; source at least 2 x 2 with a full plane (`g.width * g.height` samples); taps from
    /// `bilinear_taps8`; `at + 8 <= out.len()`.
    unsafe fn bilinear8(
        k: &Consts,
        t: &Taps8,
        plane: &[Self],
        out: &mut [Self],
        at: usize,
        nodata: Self,
    );

    /// Four adjacent samples from `p` on, as f32.
    ///
    /// # Safety
    /// AVX2; the four samples from `p` on are readable.
    unsafe fn row4(p: *const Self) -> __m128;

    /// Whether bicubic reads windows (`cubic_window`) where they apply: not for f32, whose
    /// pair kernel loads its four-sample rows as they are (measured 3.5 against 4.2 ms).
    const CUBIC_WINDOWS: bool = true;

    /// Sixteen samples from `p` as two f32 vectors (columns 0..8, 8..16).
    ///
    /// # Safety
    /// AVX2; the sixteen samples from `p` on are readable.
    unsafe fn row16(p: *const Self) -> [__m256; 2];

    /// Bicubic of a window's eight pixels (`cubic_window`) with per-tap weight vectors `w`
    /// (`keys_lanes`), written to `out[..8]` as `from_f32` writes them; here through
    /// `cubic_window8_wide` and `store8`, byte shuffles for u8.
    ///
    /// # Safety
    /// AVX2; `win.rows` rows of 16 samples from `win.start` (stride `width`) inside `plane`;
    /// `out.len() >= 8`.
    unsafe fn cubic_window8(
        k: &Consts,
        win: &CubicWindow,
        w: (&[__m256; 4], &[__m256; 4]),
        plane: &[Self],
        width: usize,
        out: &mut [Self],
    ) {
        let _ = k;
        // SAFETY: the contract.
        unsafe { Self::store8(cubic_window8_wide(win, w, plane, width), out) };
    }

    /// Eight values written to `out[..8]` as `from_f32` writes them (for |v| < 2^31: beyond,
    /// the integer types' truncation overflows to 0 where `as` saturates).
    ///
    /// # Safety
    /// AVX2; `out.len() >= 8`.
    unsafe fn store8(v: __m256, out: &mut [Self]);

    /// Thirty-two samples from `p` as two f32 vectors (columns 0..16, 16..32), for bicubic's
    /// sixteen-pixel windows (`avx512::bicubic_window16`).
    ///
    /// # Safety
    /// AVX-512 F; the 32 samples from `p` on are readable.
    unsafe fn row32(p: *const Self) -> [__m512; 2];

    /// Sixteen values written to `out[..16]` as `from_f32` writes them (`store8`'s).
    ///
    /// # Safety
    /// AVX-512 F; sixteen samples writable at `out`.
    unsafe fn store16(v: __m512, out: *mut Self);

    /// The columns of each source row `nearest_rows16` takes (a 512-bit vector's samples, or
    /// two vectors' for f32).
    const ROW_SPAN: i32;

    /// The source rows `nearest_rows16_wide` takes: two, as `nearest_rows16`, unless the type
    /// has a wider layout.
    const NEAREST_ROWS_WIDE: i32 = 2;

    /// The source rows `bilinear_rows16` takes: three (pixels on two rows and the row below).
    const BILINEAR_ROWS: i32 = 3;

    /// Nearest at sixteen pixels placed by `rows` (two source rows of `ROW_SPAN` samples), by
    /// an AVX-512 two-table permute, into `out[..16]`.
    ///
    /// # Safety
    /// AVX-512 F, BW, VL, VBMI and VNNI; `rows` from `Rows16::of` with `ROW_SPAN` and one tap
    /// on an image the size of `plane`; sixteen samples writable at `out`.
    unsafe fn nearest_rows16(rows: &Rows16, plane: &[Self], out: *mut Self);

    /// `nearest_rows16` for `rows` of `NEAREST_ROWS_WIDE` rows.
    ///
    /// # Safety
    /// As `nearest_rows16`, with `NEAREST_ROWS_WIDE` rows.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16_wide(rows: &Rows16, plane: &[Self], out: *mut Self) {
        // SAFETY: the contract (two rows unless the type overrides both).
        unsafe { Self::nearest_rows16(rows, plane, out) }
    }

    /// Bilinear at sixteen pixels placed by `rows` with fractions `f` (x, y), from AVX-512
    /// permutes of the rows, written to `out[..16]` as `Sample::bilinear` writes them;
    /// `SHARED` where several bands share the step (u8 then makes its weights' digits once).
    ///
    /// # Safety
    /// AVX-512 F, BW, VL, VBMI and VNNI; `rows` from `Rows16::of` with `ROW_SPAN` and two taps
    /// on an image the size of `plane`; sixteen samples writable at `out`.
    unsafe fn bilinear_rows16<const SHARED: bool>(
        rows: &Rows16,
        f: (__m512, __m512),
        plane: &[Self],
        out: *mut Self,
    );

    /// The eight nearest samples of a window (`nearest_window`) into `out[..8]`; the
    /// portable reading here, a shuffle for u8 (the only type with `WINDOWS`).
    ///
    /// # Safety
    /// AVX2; `win.rows` rows of 16 samples from `win.start` (row stride `width`) are inside
    /// `plane`; `out.len() >= 8`.
    unsafe fn nearest_window8(win: &NearestWindow, width: usize, plane: &[Self], out: &mut [Self]) {
        // SAFETY: both are 16 plain bytes.
        let (ctrl, first): ([u8; 16], [u8; 16]) = unsafe {
            (
                std::mem::transmute::<__m128i, [u8; 16]>(win.ctrl),
                std::mem::transmute::<__m128i, [u8; 16]>(win.first),
            )
        };
        for (j, d) in out.iter_mut().take(8).enumerate() {
            let row = usize::from(first[j] == 0);
            *d = plane[win.start + row * width + usize::from(ctrl[j])];
        }
    }
}

/// Bicubic of a window's eight pixels for u16 and f32 (`SimdSample::cubic_window8`): each row's
/// 16 samples as two f32 vectors (`SimdSample::row16`), the taps picked by lane permutes.
///
/// # Safety
/// AVX2; `win.rows` rows of 16 samples from `win.start` (stride `width`) inside `plane`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn cubic_window8_wide<T: SimdSample>(
    win: &CubicWindow,
    w: (&[__m256; 4], &[__m256; 4]),
    plane: &[T],
    width: usize,
) -> __m256 {
    debug_assert!(win.start + (win.rows - 1) * width + 16 <= plane.len());
    // Branch-free: with four rows, the fifth is the fourth again (and `lower` all clear).
    // SAFETY: the contract.
    let rows: [[__m256; 2]; 5] = std::array::from_fn(|j| unsafe {
        T::row16(plane.as_ptr().add(win.start + j.min(win.rows - 1) * width))
    });
    let lower = _mm256_castsi256_ps(win.lower);
    // Lane permutes read the low three bits; bit 3 chooses the second vector.
    let cols: [__m256i; 4] =
        std::array::from_fn(|c| _mm256_add_epi32(win.rel, _mm256_set1_epi32(c as i32)));
    let take = |r: &[__m256; 2], i: __m256i| {
        _mm256_blendv_ps(
            _mm256_permutevar8x32_ps(r[0], i),
            _mm256_permutevar8x32_ps(r[1], i),
            _mm256_castsi256_ps(_mm256_slli_epi32::<28>(i)),
        )
    };
    let pair = |j: usize, p: usize| [take(&rows[j], cols[2 * p]), take(&rows[j], cols[2 * p + 1])];
    let split = |upper: [__m256; 2], below: [__m256; 2]| {
        [0, 1].map(|c| _mm256_blendv_ps(upper[c], below[c], lower))
    };
    cubic_sum8(w, pair, split)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `row16` reads sixteen samples as their f32 values, and `store8` writes eight values as
    /// `Sample::from_f32` does (rounding and saturating for the integer types), for every type.
    fn rows_and_stores_match_the_scalar_definitions<T: SimdSample>(samples: [T; 16]) {
        if !crate::cpu::avx2() {
            return;
        }
        let values = [-3.7f32, -0.4, 0.49, 0.5, 254.5, 255.6, 65535.4, 70000.0];
        // SAFETY: AVX2 is there; sixteen samples are readable, eight writable.
        let (row, out) = unsafe {
            let row = T::row16(samples.as_ptr());
            let mut out = [T::default(); 8];
            T::store8(_mm256_loadu_ps(values.as_ptr()), &mut out);
            (std::mem::transmute::<[__m256; 2], [f32; 16]>(row), out)
        };
        for (j, (r, s)) in row.iter().zip(samples).enumerate() {
            assert_eq!(*r, s.to_f32(), "{}: sample {j}", T::NAME);
        }
        for (j, (o, v)) in out.iter().zip(values).enumerate() {
            assert!(*o == T::from_f32(v), "{}: value {v} (lane {j})", T::NAME);
        }
    }

    #[test]
    fn simd_rows_and_stores_match_the_scalar_definitions() {
        rows_and_stores_match_the_scalar_definitions::<u8>(std::array::from_fn(|i| {
            (i * 17 + 3) as u8
        }));
        rows_and_stores_match_the_scalar_definitions::<u16>(std::array::from_fn(|i| {
            (i * 4099 + 7) as u16
        }));
        rows_and_stores_match_the_scalar_definitions::<f32>(std::array::from_fn(|i| {
            i as f32 * -1.25 + 0.1
        }));
    }
}
