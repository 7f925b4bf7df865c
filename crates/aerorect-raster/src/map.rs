//! Destination pixel -> source pixel maps for the warp engine.

use aerorect_core::Homography;

/// Where each destination pixel comes from in the source image (pixel-centre coordinates).
pub trait PixelMap: Sync {
    /// The source position of destination pixel (col, row); `None` where it has none.
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]>;

    /// Fills the source positions of destination row `row`, columns `col0..col0 + xs.len()`.
    /// A pixel without a source gets NaN. Implementations override this for speed.
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let p = self
                .source_of((col0 + i) as f64, row as f64)
                .unwrap_or([f64::NAN; 2]);
            (*x, *y) = (p[0], p[1]);
        }
    }
}

/// A homography used as `source_from_destination`; w <= 0 has no source (beyond the horizon).
impl PixelMap for Homography {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        self.map(col, row)
    }

    #[inline]
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        let m = self.matrix();
        let r = row as f64;
        let (bx, by, bw) = (
            m[(0, 1)] * r + m[(0, 2)],
            m[(1, 1)] * r + m[(1, 2)],
            m[(2, 1)] * r + m[(2, 2)],
        );
        let (ax, ay, aw) = (m[(0, 0)], m[(1, 0)], m[(2, 0)]);
        // Columns fit i32 (output widths are far below 2^31); i32 -> f64 vectorises, usize does not.
        let c0 = col0 as i32;
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let c = (c0 + i as i32) as f64;
            let w = aw * c + bw;
            let inv = if w > 0.0 { 1.0 / w } else { f64::NAN };
            *x = (ax * c + bx) * inv;
            *y = (ay * c + by) * inv;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aerorect_core::Mat3;

    #[test]
    fn fast_row_equals_point_map() {
        let h = Homography::new(Mat3::new(0.9, 0.1, 5.0, -0.05, 1.1, -3.0, 1e-4, 2e-4, 1.0))
            .expect("ok");
        let mut xs = vec![0.0; 40];
        let mut ys = vec![0.0; 40];
        h.source_row(7, 3, &mut xs, &mut ys);
        for i in 0..40 {
            let p = h.map((3 + i) as f64, 7.0).expect("ground");
            assert!((xs[i] - p[0]).abs() < 1e-12 * p[0].abs().max(1.0));
            assert!((ys[i] - p[1]).abs() < 1e-12 * p[1].abs().max(1.0));
        }
    }

    #[test]
    fn beyond_the_horizon_is_nan() {
        let h =
            Homography::new(Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, -5.0)).expect("ok");
        let (mut xs, mut ys) = (vec![0.0; 2], vec![0.0; 2]);
        h.source_row(4, 0, &mut xs, &mut ys);
        assert!(xs[0].is_nan() && ys[1].is_nan());
        h.source_row(6, 0, &mut xs, &mut ys);
        assert!(xs[0].is_finite());
    }
}
