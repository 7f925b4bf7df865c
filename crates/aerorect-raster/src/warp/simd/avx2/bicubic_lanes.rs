//! Bicubic's eight-lane pieces shared by the AVX2 bicubic kernel and the sample types: the
//! interior tap, the Keys weights, the split of positions, the row windows and the sum.

use super::lanes::{Consts, ends8};
use std::arch::x86_64::*;

/// The weights of one interior bicubic pixel (`keys_weights_f32`); the upper-left index of its
/// 4 x 4 neighbourhood is kept apart (`SimdScratch::base`).
#[derive(Clone, Copy, Default)]
#[repr(C, align(16))]
pub(crate) struct CubicTap {
    pub(crate) wx: [f32; 4],
    pub(crate) wy: [f32; 4],
}

/// The four Keys weights of eight fractions, as `keys_weights_f32` (same operations and order),
/// transposed to per-pixel vectors: `[pixel 0 | pixel 4], [1 | 5], [2 | 6], [3 | 7]`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn keys8(t: __m256) -> [__m256; 4] {
    let [w0, w1, w2, w3] = keys_lanes(t);
    let (a, b) = (_mm256_unpacklo_ps(w0, w1), _mm256_unpackhi_ps(w0, w1));
    let (c, d) = (_mm256_unpacklo_ps(w2, w3), _mm256_unpackhi_ps(w2, w3));
    [
        _mm256_shuffle_ps::<0x44>(a, c),
        _mm256_shuffle_ps::<0xEE>(a, c),
        _mm256_shuffle_ps::<0x44>(b, d),
        _mm256_shuffle_ps::<0xEE>(b, d),
    ]
}

/// The four Keys weights of eight fractions as `keys_weights_f32` (same operations and order),
/// one vector per tap: `[w0 of pixels 0..8], [w1 ..], [w2 ..], [w3 ..]`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn keys_lanes(t: __m256) -> [__m256; 4] {
    let c = _mm256_set1_ps;
    let t2 = _mm256_mul_ps(t, t);
    let t3 = _mm256_mul_ps(t2, t);
    let half_t = _mm256_mul_ps(c(0.5), t);
    let w0 = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(c(-0.5), t3), t2), half_t);
    let w1 = _mm256_add_ps(
        _mm256_sub_ps(_mm256_mul_ps(c(1.5), t3), _mm256_mul_ps(c(2.5), t2)),
        c(1.0),
    );
    let w2 = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(c(-1.5), t3), _mm256_mul_ps(c(2.0), t2)),
        half_t,
    );
    let w3 = _mm256_sub_ps(_mm256_mul_ps(c(0.5), t3), _mm256_mul_ps(c(0.5), t2));
    [w0, w1, w2, w3]
}

/// Bicubic split of four positions (`Bicubic::prepare`): clamp to [-1, n] (NaN to -1), floor;
/// the integer part and the fraction (f64, then rounded to f32).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn cubic_split(v: __m256d, hi: __m256d) -> (__m128i, __m128) {
    let c = _mm256_min_pd(_mm256_max_pd(v, _mm256_set1_pd(-1.0)), hi);
    let f = _mm256_floor_pd(c);
    (_mm256_cvttpd_epi32(f), _mm256_cvtpd_ps(_mm256_sub_pd(c, f)))
}

/// The split of eight bicubic positions (`Bicubic::prepare`): inside lanes, the floors of the
/// positions clamped to [-1, n] and their fractions.
pub(crate) struct CubicSplit8 {
    pub(crate) inside: __m256i,
    pub(crate) xi: __m256i,
    pub(crate) yi: __m256i,
    pub(crate) tx: __m256,
    pub(crate) ty: __m256,
}

/// Eight interior bicubic pixels whose 4 x 4 neighbourhoods lie within 16 samples of four or
/// five source rows: each row is loaded once and the taps are picked from it by shuffles (the
/// `Window` layout of bilinear, for 4 x 4 taps).
pub(crate) struct CubicWindow {
    /// Index of the first sample of the first row (column xmin - 1 of row ymin - 1).
    pub(crate) start: usize,
    /// Per pixel: its first tap column from the window's first (x - xmin, 0..=12).
    pub(crate) rel: __m256i,
    /// All ones where the pixel's tap rows start one row lower (y = ymin + 1).
    pub(crate) lower: __m256i,
    /// Rows read: 4 when the eight pixels' rows are equal, else 5.
    pub(crate) rows: usize,
}

/// The window of eight pixels split as `s`, when all are interior and it fits (monotonic
/// positions: the extremes are the first and last lanes).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn cubic_window(k: &Consts, s: &CubicSplit8) -> Option<CubicWindow> {
    let (w, h) = k.size;
    let (xmin, xmax) = ends8(s.xi);
    let (ymin, ymax) = ends8(s.yi);
    // Interior (1 <= x <= w - 3, 1 <= y <= h - 3); 16 samples from xmin - 1 hold the columns
    // xmin - 1 ..= xmax + 2 and end inside the row.
    if xmin < 1 || xmax > w - 3 || ymin < 1 || ymax > h - 3 {
        return None;
    }
    if xmax - xmin > 12 || ymax - ymin > 1 || xmin + 15 > w {
        return None;
    }
    Some(CubicWindow {
        start: ((ymin - 1) * w + xmin - 1) as usize,
        rel: _mm256_sub_epi32(s.xi, _mm256_set1_epi32(xmin)),
        lower: _mm256_cmpgt_epi32(s.yi, _mm256_set1_epi32(ymin)),
        rows: (4 + ymax - ymin) as usize,
    })
}

/// The vertical-then-horizontal bicubic sum of eight pixels (`Bicubic::apply`'s order). One pair
/// of tap columns (`p`: columns 2p, 2p + 1) at a time, so that few registers are live:
/// `row(j, p)` reads the pair from the window's row j, `split(upper, lower)` gives the pair's
/// two columns of each pixel, from its upper or its lower row (`CubicWindow::lower`).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn cubic_sum8<R: Copy>(
    (wx, wy): (&[__m256; 4], &[__m256; 4]),
    row: impl Fn(usize, usize) -> R,
    split: impl Fn(R, R) -> [__m256; 2],
) -> __m256 {
    let pair = |p: usize| {
        let (mut a, mut b) = (_mm256_setzero_ps(), _mm256_setzero_ps());
        let mut upper = row(0, p);
        for (r, &wr) in wy.iter().enumerate() {
            let below = row(r + 1, p);
            let [ta, tb] = split(upper, below);
            let (ma, mb) = (_mm256_mul_ps(ta, wr), _mm256_mul_ps(tb, wr));
            (a, b) = match r {
                0 => (ma, mb),
                _ => (_mm256_add_ps(a, ma), _mm256_add_ps(b, mb)),
            };
            upper = below;
        }
        (_mm256_mul_ps(a, wx[2 * p]), _mm256_mul_ps(b, wx[2 * p + 1]))
    };
    let (h0, h1) = pair(0);
    let (h2, h3) = pair(1);
    _mm256_add_ps(_mm256_add_ps(h0, h2), _mm256_add_ps(h1, h3))
}
