//! The positions a bicubic block reads, split eight at a time (`CubicPositions`).

use super::bicubic_lanes::{CubicSplit8, cubic_split};
use super::lanes::{Consts, load4, narrow_mask};
use super::positions::{Buffered, Exact, Positions};
use std::arch::x86_64::*;

/// The positions a bicubic block reads: eight at a time as splits, and one pixel's f64 position
/// for the portable kernel (border pixels and the tail).
pub(crate) trait CubicPositions: Positions {
    /// The f64 position of pixel `j < len`.
    fn at(&self, j: usize) -> (f64, f64);

    /// The split of pixels i..i + 8.
    ///
    /// # Safety
    /// AVX2; i + 8 <= len.
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8;
}

impl CubicPositions for Exact<'_> {
    fn at(&self, j: usize) -> (f64, f64) {
        (self.xs[j], self.ys[j])
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8 {
        let (hi_x, hi_y) = (
            _mm256_set1_pd(f64::from(k.size.0)),
            _mm256_set1_pd(f64::from(k.size.1)),
        );
        // SAFETY: i + 8 <= len (the contract).
        let ((x_lo, y_lo), (x_hi, y_hi)) =
            unsafe { (load4(self.xs, self.ys, i), load4(self.xs, self.ys, i + 4)) };
        let (xi_lo, tx_lo) = cubic_split(x_lo, hi_x);
        let (xi_hi, tx_hi) = cubic_split(x_hi, hi_x);
        let (yi_lo, ty_lo) = cubic_split(y_lo, hi_y);
        let (yi_hi, ty_hi) = cubic_split(y_hi, hi_y);
        CubicSplit8 {
            inside: narrow_mask(k.inside(x_lo, y_lo), k.inside(x_hi, y_hi)),
            xi: _mm256_set_m128i(xi_hi, xi_lo),
            yi: _mm256_set_m128i(yi_hi, yi_lo),
            tx: _mm256_set_m128(tx_hi, tx_lo),
            ty: _mm256_set_m128(ty_hi, ty_lo),
        }
    }
}

/// Fast positions: the split of origin + offset done on the f32 offset. The clamp to
/// [-1 - origin, n - origin] and the floor are exact in f32, and offset - floor(offset) is one
/// rounding of the exact fraction, as `Bicubic::prepare`'s f64 difference cast to f32 is: both
/// builds get the same taps.
impl CubicPositions for Buffered<'_> {
    fn at(&self, j: usize) -> (f64, f64) {
        let (mut x, mut y) = ([0.0], [0.0]);
        self.rel.block.fill(j, &mut x, &mut y);
        (x[0], y[0])
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8 {
        // SAFETY: i + 8 <= len, so within the buffers.
        let p = unsafe { self.load8(i) };
        let inside = self.rel.inside8(&p);
        let split = |a: usize, size: i32| {
            let o = self.rel.block.origin[a];
            let lo = _mm256_set1_ps((-1 - o) as f32);
            let hi = _mm256_set1_ps((size - o) as f32);
            let c = _mm256_min_ps(_mm256_max_ps(p[a], lo), hi);
            let f = _mm256_floor_ps(c);
            let i = _mm256_add_epi32(_mm256_cvttps_epi32(f), self.rel.origin[a]);
            (i, _mm256_sub_ps(c, f))
        };
        let ((xi, tx), (yi, ty)) = (split(0, k.size.0), split(1, k.size.1));
        CubicSplit8 {
            inside: _mm256_castps_si256(inside),
            xi,
            yi,
            tx,
            ty,
        }
    }
}
