//! Fast coordinates for projective maps (`Coordinates::Fast`): per block of a destination row,
//! the first source position in f64 and every other one as an f32 offset from it.
//!
//! Along a row, a homography's source position is x(k) = (nx0 + mx k) / (w0 + mw k) for the
//! block's k-th pixel, so x(k) - x(0) = k a / (1 + c k) with a = (mx - x(0) mw) / w0 and
//! c = mw / w0. The offsets are small (a block spans at most `BLOCK` pixels), so f32 keeps them
//! to about 1e-4 px, where the position itself stored in f32 would already be rounded by up to
//! 1.2e-4 px at x ~ 4000 (2.4e-4 px at x ~ 8000), before any arithmetic on it. Each
//! block carries a bound of its own error (first order in f32's unit roundoff); a block whose
//! bound exceeds `FAST_MAX_ERROR`, or that reaches the horizon, uses exact positions.
//!
//! The offsets are split off an integer origin, so both builds of the kernels (portable and
//! AVX2) see the same positions: the portable one as origin + offset in f64 (exact), the AVX2 one
//! as the f32 offset against limits moved by the origin.

use aerorect_core::Mat3;

/// The largest position error, in source pixels, that `Coordinates::Fast` accepts for a block
/// (OpenCV 4's warp tables are 1/32 px; OpenCV 5 evaluates positions in f32).
pub const FAST_MAX_ERROR: f64 = 5e-4;

/// f32's unit roundoff.
const U: f64 = 1.0 / (1u64 << 24) as f64;

/// Positions beyond this (in source pixels) keep exact coordinates: the origin and the limits
/// moved by it must be exact in f32.
const ORIGIN_LIMIT: f64 = (1u64 << 22) as f64;

/// The most w may grow along a fast block (w_last / w0, that is 1 + c (n - 1)); far beyond any
/// map worth resampling, and what keeps the f32 offsets monotonic in k (the AVX2 kernels rely
/// on it, `Positions::MONOTONIC`). k / (1 + c k) grows from k to k + 1 by the factor
/// 1 + 1 / (k (1 + c (k + 1))), and its f32 evaluation (`RelativeBlock::offset`: three
/// roundings, then the product's) is within 4u of it, so it stays monotonic while that factor
/// exceeds (1 + 4u) / (1 - 4u), about 1 + 8u = 1 + 2^-21: k (1 + c (k + 1)) < 2^21. With
/// k < 1024 (`block::BLOCK`) and 1 + c (k + 1) <= 1000 that holds twice over; for c < 0 the
/// factor is larger still. The roundings of a k r, then first + a k r keep monotonicity.
const MAX_W_GROWTH: f64 = 1000.0;

/// floor(v) for |v| < 2^22, without a libm call.
#[inline]
fn floor(v: f64) -> f64 {
    let t = v as i64 as f64;
    if t > v { t - 1.0 } else { t }
}

/// One block's positions: pixel k of the block is at `origin + offset(k) - shift`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RelativeBlock {
    /// The integer part of the first pixel's position.
    pub(crate) origin: [i32; 2],
    /// The first pixel's position minus `origin`, in [0, 1].
    pub(crate) first: [f32; 2],
    /// `a` of each axis (the module's formula).
    pub(crate) slope: [f32; 2],
    /// `c` (the module's formula).
    pub(crate) c: f32,
    /// Added to the positions before the split (`new`).
    pub(crate) shift: f64,
    /// The bound of this block's position error, in source pixels.
    pub(crate) bound: f64,
}

impl RelativeBlock {
    /// The block of `n` pixels from (`col0`, `row`) under `source_from_destination` `m`, with
    /// positions moved by `shift` before they are split (0.5 for the nearest kernel, whose
    /// floor(x + 0.5) is then the floor of the offset); `None` where the block reaches the
    /// horizon (w <= 0), lies beyond `ORIGIN_LIMIT`, or its error bound exceeds `FAST_MAX_ERROR`.
    pub(crate) fn new(m: &Mat3, row: usize, col0: usize, n: usize, shift: f64) -> Option<Self> {
        let (r, c0) = (row as f64, col0 as f64);
        let along = |i: usize| m[(i, 0)] * c0 + m[(i, 1)] * r + m[(i, 2)];
        let w0 = along(2);
        let w_last = w0 + m[(2, 0)] * n.saturating_sub(1) as f64;
        if !(w0 > 0.0 && w_last > 0.0 && w_last <= MAX_W_GROWTH * w0) {
            return None;
        }
        let inv_w0 = 1.0 / w0;
        let p0 = [along(0) * inv_w0, along(1) * inv_w0];
        let q0 = p0.map(|v| v + shift);
        if !q0.iter().all(|v| v.abs() < ORIGIN_LIMIT) {
            return None;
        }
        let origin = q0.map(floor);
        let mut block = Self {
            origin: origin.map(|v| v as i32),
            first: [(q0[0] - origin[0]) as f32, (q0[1] - origin[1]) as f32],
            slope: [0, 1].map(|i| ((m[(i, 0)] - p0[i] * m[(2, 0)]) * inv_w0) as f32),
            c: (m[(2, 0)] * inv_w0) as f32,
            shift,
            bound: 0.0,
        };
        block.bound = block.error_bound(n);
        (block.bound <= FAST_MAX_ERROR).then_some(block)
    }

    /// A first-order bound of |position error| over the block's `n` pixels: f32's rounding of
    /// the inputs (a, c, the first position: one unit roundoff each) and of each operation of
    /// `offset`, with 1 + c k's error relative to itself grown by |c k| / (1 + c k).
    fn error_bound(&self, n: usize) -> f64 {
        let k = n.saturating_sub(1) as f64;
        let ck = f64::from(self.c) * k;
        let den_min = (1.0 + ck).min(1.0);
        if den_min.is_nan() || den_min <= 0.0 {
            return f64::INFINITY;
        }
        let inv_den_min = 1.0 / den_min;
        let rel = U * (6.0 + 2.0 * ck.abs() * inv_den_min);
        let axis = |i: usize| {
            // |k a / (1 + c k)| grows monotonically with k, so the last pixel has the largest;
            // 1 / (1 + c k) <= 1 / den_min.
            let offset = (f64::from(self.slope[i]) * k * inv_den_min).abs();
            let first = f64::from(self.first[i]).abs();
            offset * rel + U * (2.0 * first + offset)
        };
        // 10% for second-order terms, plus the f64 evaluation of the origin.
        1.1 * axis(0).max(axis(1)) + 1e-9
    }

    /// Pixel `k`'s offset from `origin`: first + a (k / (1 + c k)), in f32 and in this order
    /// (the AVX2 build does the same operations).
    #[inline(always)]
    pub(crate) fn offset(&self, k: usize) -> [f32; 2] {
        let k = k as f32;
        let kr = k * (1.0 / (1.0 + self.c * k));
        [
            self.first[0] + self.slope[0] * kr,
            self.first[1] + self.slope[1] * kr,
        ]
    }

    /// The positions of pixels `from`, `from + 1`, ... as f64 (`origin + offset - shift`, exact
    /// in f64).
    pub(crate) fn fill(&self, from: usize, xs: &mut [f64], ys: &mut [f64]) {
        let [ox, oy] = self.origin.map(|v| f64::from(v) - self.shift);
        for (k, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let [dx, dy] = self.offset(from + k);
            (*x, *y) = (ox + f64::from(dx), oy + f64::from(dy));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::PixelMap;
    use crate::warp::block::{BLOCK, MIN_FAST_BLOCK};
    use aerorect_core::Homography;

    /// Strong and mild perspectives, rotations and scales from 1/3 to 3 (source_from_destination).
    fn homographies() -> Vec<Mat3> {
        let mut out = Vec::new();
        for (i, &(angle, scale, p, q)) in [
            (0.0, 1.0, 0.0, 0.0),
            (0.3, 0.95, 5e-5, 8e-5),
            (-0.7, 1.7, -2e-4, 1e-4),
            (2.5, 0.33, 3e-4, -2.5e-4),
            (1.2, 3.0, 6e-4, 5e-4),
            (0.05, 1.02, -4e-4, -6e-4),
        ]
        .iter()
        .enumerate()
        {
            let (s, c) = (f64::sin(angle), f64::cos(angle));
            let t = 300.0 + 1500.0 * i as f64;
            out.push(Mat3::new(
                scale * c,
                -scale * s,
                t,
                scale * s,
                scale * c,
                -0.5 * t,
                p,
                q,
                1.0,
            ));
        }
        out
    }

    /// Whether a block of `n` pixels from (`col0`, `row`) is one the fast path must cover: no
    /// horizon, w changing by less than 2x, and at most 2 source pixels per destination pixel.
    fn ordinary(h: &Homography, row: usize, col0: usize, n: usize) -> bool {
        let m = h.matrix();
        let w = |c: usize| m[(2, 0)] * c as f64 + m[(2, 1)] * row as f64 + m[(2, 2)];
        let (w0, w1) = (w(col0), w(col0 + n - 1));
        let ends = (
            h.map(col0 as f64, row as f64),
            h.map((col0 + n - 1) as f64, row as f64),
        );
        match ends {
            (Some(a), Some(b)) if w0 > 0.0 && w1 > 0.0 && w1 / w0 < 2.0 && w0 / w1 < 2.0 => {
                (a[0] - b[0]).hypot(a[1] - b[1]) <= 2.0 * (n - 1) as f64
            }
            _ => false,
        }
    }

    #[test]
    fn fast_positions_are_within_their_bound_of_the_exact_map() {
        let (mut worst, mut ordinaries, mut fast) = (0.0f64, 0, 0);
        // Every block length the rows are cut into (`RowPlan::block`); the shortest must cover
        // every ordinary block.
        let lengths = [MIN_FAST_BLOCK, 2 * MIN_FAST_BLOCK, BLOCK];
        for ((m, shift), n) in homographies()
            .into_iter()
            .flat_map(|m| [(m, 0.0), (m, 0.5)])
            .flat_map(|ms| lengths.map(|n| (ms, n)))
        {
            let h = Homography::new(m).expect("invertible");
            for row in (0..4000).step_by(97) {
                for col0 in (0..4000).step_by(n) {
                    let must = n == MIN_FAST_BLOCK && ordinary(&h, row, col0, n);
                    ordinaries += usize::from(must);
                    let Some(b) = RelativeBlock::new(&m, row, col0, n, shift) else {
                        assert!(!must, "{m:?}: row {row}, col {col0} is not fast");
                        continue;
                    };
                    fast += 1;
                    assert!(b.bound <= FAST_MAX_ERROR);
                    let (mut xs, mut ys) = (vec![0.0; n], vec![0.0; n]);
                    let (mut ex, mut ey) = (vec![0.0; n], vec![0.0; n]);
                    b.fill(0, &mut xs, &mut ys);
                    h.source_row(row, col0, &mut ex, &mut ey);
                    // The AVX2 kernels rely on it (`MAX_W_GROWTH`).
                    let monotonic = |v: &[f64]| {
                        v.windows(2).all(|p| p[0] <= p[1]) || v.windows(2).all(|p| p[0] >= p[1])
                    };
                    assert!(monotonic(&xs) && monotonic(&ys), "row {row}, col {col0}");
                    for k in 0..n {
                        let e = (xs[k] - ex[k]).abs().max((ys[k] - ey[k]).abs());
                        assert!(
                            e <= b.bound,
                            "row {row}, col {}: error {e:e} px over the block's bound {:e}",
                            col0 + k,
                            b.bound
                        );
                        worst = worst.max(e);
                    }
                }
            }
        }
        // The limit is 1e-3 px; the bound keeps every block within half of it.
        assert!(worst < FAST_MAX_ERROR, "worst error {worst:e} px");
        assert!(
            ordinaries > 2000 && fast > 3 * ordinaries / 2,
            "the cases cover {ordinaries} ordinary blocks, {fast} fast ones of all lengths"
        );
        eprintln!("{fast} blocks fast ({ordinaries} ordinary), worst error {worst:e} px");
    }

    #[test]
    fn blocks_reaching_the_horizon_stay_exact() {
        // w = 1 - 0.001 col: zero at column 1000.
        let m = Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1e-3, 0.0, 1.0);
        assert!(RelativeBlock::new(&m, 0, 768, 256, 0.0).is_none());
        assert!(RelativeBlock::new(&m, 0, 1100, 256, 0.0).is_none());
        // Far from it, the bound passes.
        assert!(RelativeBlock::new(&m, 0, 0, 256, 0.0).is_some());
        // w growing 1000-fold along a block is refused even where the bound would pass
        // (x and y do not move along the row).
        let m = Mat3::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 1.0);
        assert!(RelativeBlock::new(&m, 0, 0, 256, 0.0).is_none());
        assert!(RelativeBlock::new(&m, 0, 0, 200, 0.0).is_some());
    }
}
