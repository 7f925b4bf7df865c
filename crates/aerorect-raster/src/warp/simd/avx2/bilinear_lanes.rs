//! The bilinear taps of eight pixels (`Taps8`), their u8 byte windows (`Window`) and the
//! eight-lane blends, shared by the AVX2 bilinear kernel, the sample types and the AVX-512
//! steps.

use super::lanes::{Consts, extent8, load4, narrow_mask};
use crate::raster::U8_WEIGHT_BITS;
use std::arch::x86_64::*;

/// Bilinear split of four positions (`left_neighbour`): clamp to [0, vmax] (NaN to 0, as
/// `max_pd` returns its second operand for NaN), truncate, cap the index at n - 2.
#[target_feature(enable = "avx2")]
#[inline]
fn split(k: &Consts, v: __m256d, vmax: __m256d, imax: __m128i) -> (__m128i, __m128) {
    let c = _mm256_min_pd(_mm256_max_pd(v, k.zero), vmax);
    let i0 = _mm_min_epi32(_mm256_cvttpd_epi32(c), imax);
    let f = _mm256_cvtpd_ps(_mm256_sub_pd(c, _mm256_cvtepi32_pd(i0)));
    (i0, f)
}

/// The bilinear taps of eight pixels: upper-left offsets, fractions, inside lanes and mask bits.
pub(crate) struct Taps8 {
    pub(crate) off: __m256i,
    pub(crate) fx: __m256,
    pub(crate) fy: __m256,
    pub(crate) lanes: __m256i,
    pub(crate) mask: i32,
    /// For u8: the eight pixels' neighbours inside 16 bytes of two or three source rows.
    pub(crate) window: Option<Window>,
}

/// Eight u8 bilinear taps read as byte shuffles of 16-byte row loads instead of gathers: the
/// layout of pillow-simd and IPP for nearly horizontal rows. It applies when the eight upper
/// neighbour rows differ by at most one and their columns by at most 14.
pub(crate) struct Window {
    /// Offset of the first byte of the first row.
    pub(crate) start: usize,
    /// Per 32-bit lane: bytes (x0, x0 + 1) of the row to bytes 0, 1 (upper pair) ...
    pub(crate) top: __m256i,
    /// ... and to bytes 2, 3 (lower pair).
    pub(crate) low: __m256i,
    /// Lanes whose upper row is the first row (all when `rows == 2`).
    pub(crate) first: __m256i,
    /// Rows read: 2 when all eight upper rows are equal, else 3.
    pub(crate) rows: usize,
}

/// The byte window of eight u8 taps with upper-left neighbours (x0, y0), when there is one.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn window(k: &Consts, x0: __m256i, y0: __m256i, monotonic: bool) -> Option<Window> {
    let (xmin, xmax) = extent8(x0, monotonic);
    let (ymin, ymax) = extent8(y0, monotonic);
    let rows = if ymax == ymin { 2 } else { 3 };
    let (w, h) = k.size;
    // The 16 bytes from xmin of `rows` rows from ymin must be inside the image.
    if xmax - xmin > 14 || ymax - ymin > 1 || xmin + 16 > w || ymin + rows > h {
        return None;
    }
    let rel = _mm256_sub_epi32(x0, _mm256_set1_epi32(xmin));
    let pair = _mm256_or_si256(
        rel,
        _mm256_slli_epi32::<8>(_mm256_add_epi32(rel, _mm256_set1_epi32(1))),
    );
    Some(Window {
        start: (ymin * w + xmin) as usize,
        top: _mm256_or_si256(pair, _mm256_set1_epi32(0x8080_0000_u32 as i32)),
        low: _mm256_or_si256(_mm256_slli_epi32::<16>(pair), _mm256_set1_epi32(0x8080)),
        first: _mm256_cmpeq_epi32(y0, _mm256_set1_epi32(ymin)),
        rows: rows as usize,
    })
}

/// # Safety
/// AVX2; `i + 8 <= xs.len(), ys.len()`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn bilinear_taps8(
    k: &Consts,
    xs: &[f64],
    ys: &[f64],
    i: usize,
    with_window: bool,
) -> Taps8 {
    // SAFETY: i + 8 <= len (the contract).
    let ((x_lo, y_lo), (x_hi, y_hi)) = unsafe { (load4(xs, ys, i), load4(xs, ys, i + 4)) };
    let (in_lo, in_hi) = (k.inside(x_lo, y_lo), k.inside(x_hi, y_hi));
    let mask = _mm256_movemask_pd(in_lo) | (_mm256_movemask_pd(in_hi) << 4);
    let (x0_lo, fx_lo) = split(k, x_lo, k.max_x, k.i0max_x);
    let (x0_hi, fx_hi) = split(k, x_hi, k.max_x, k.i0max_x);
    let (y0_lo, fy_lo) = split(k, y_lo, k.max_y, k.i0max_y);
    let (y0_hi, fy_hi) = split(k, y_hi, k.max_y, k.i0max_y);
    let x0 = _mm256_set_m128i(x0_hi, x0_lo);
    let y0 = _mm256_set_m128i(y0_hi, y0_lo);
    Taps8 {
        off: _mm256_add_epi32(_mm256_mullo_epi32(y0, k.width), x0),
        fx: _mm256_set_m128(fx_hi, fx_lo),
        fy: _mm256_set_m128(fy_hi, fy_lo),
        lanes: narrow_mask(in_lo, in_hi),
        mask,
        window: if with_window {
            window(k, x0, y0, false)
        } else {
            None
        },
    }
}

/// The bilinear blend, in the order of `Bilinear::apply` (no FMA).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn blend(t: &Taps8, p00: __m256, p01: __m256, p10: __m256, p11: __m256) -> __m256 {
    let top = _mm256_add_ps(p00, _mm256_mul_ps(t.fx, _mm256_sub_ps(p01, p00)));
    let bottom = _mm256_add_ps(p10, _mm256_mul_ps(t.fx, _mm256_sub_ps(p11, p10)));
    _mm256_add_ps(top, _mm256_mul_ps(t.fy, _mm256_sub_ps(bottom, top)))
}

/// Eight blended values of an integer type rounded as `Sample::from_f32` rounds (v + 0.5,
/// truncated) in 32-bit lanes, `nodata` where the pixel is outside.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn rounded(k: &Consts, t: &Taps8, v: __m256, nodata: i32) -> __m256i {
    let q = _mm256_cvttps_epi32(_mm256_add_ps(v, k.half));
    _mm256_blendv_epi8(_mm256_set1_epi32(nodata), q, t.lanes)
}

/// `bilinear_weights_u8` at eight lanes (same operations, same order).
#[target_feature(enable = "avx2")]
#[inline]
fn bilinear_weights_u8_8((fx, fy): (__m256, __m256)) -> [__m256i; 4] {
    let one = _mm256_set1_ps(1.0);
    let scale = _mm256_set1_ps((1u32 << U8_WEIGHT_BITS) as f32);
    let (bx, by) = (_mm256_sub_ps(one, fx), _mm256_sub_ps(one, fy));
    let (sbx, sfx) = (_mm256_mul_ps(bx, scale), _mm256_mul_ps(fx, scale));
    [(sbx, by), (sfx, by), (sbx, fy), (sfx, fy)]
        .map(|(a, b)| _mm256_cvtps_epi32(_mm256_mul_ps(a, b)))
}

/// `bilinear_u8` at eight lanes, taps as 32-bit lanes.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn bilinear_u8_8(p: [__m256i; 4], f: (__m256, __m256)) -> __m256i {
    let w = bilinear_weights_u8_8(f);
    let [a, b, c, d] = [0, 1, 2, 3].map(|j| _mm256_mullo_epi32(p[j], w[j]));
    let sum = _mm256_add_epi32(_mm256_add_epi32(a, b), _mm256_add_epi32(c, d));
    let half = _mm256_set1_epi32(1 << (U8_WEIGHT_BITS - 1));
    _mm256_srli_epi32::<{ U8_WEIGHT_BITS as i32 }>(_mm256_add_epi32(sum, half))
}
