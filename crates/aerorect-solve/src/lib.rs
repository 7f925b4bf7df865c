//! Estimators: the normalised DLT homography (Hartley) and camera calibration.

pub mod adjust;
pub mod calib;
pub mod fundamental;
pub mod gcp;
pub mod lm;
pub mod matching;
pub mod pairs;
pub mod ransac;
pub mod significance;

use aerorect_core::{Homography, Mat3};
use nalgebra::{DMatrix, Vector3};
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum SolveError {
    #[error("{got} point pairs given, at least {need} needed")]
    TooFewPoints { got: usize, need: usize },
    #[error("point {index} is not finite")]
    NotFinite { index: usize },
    #[error("the points are degenerate (collinear or repeated): the solution is not unique")]
    Degenerate,
    /// An adjustment frame that names a camera the adjustment was not given.
    #[error("frame {frame} names camera {camera}, but {cameras} camera(s) were given")]
    UnknownCamera {
        frame: usize,
        camera: usize,
        cameras: usize,
    },
    /// A tie point the adjustment cannot take, and why.
    #[error("tie point {index}: {why}")]
    BadTie { index: usize, why: String },
    /// GPS drift times that are not one finite time per frame.
    #[error("{got} GPS drift times given for {frames} frames: one finite time per frame is needed")]
    DriftTimes { got: usize, frames: usize },
}

/// Hartley's normalisation: centroid to the origin, mean distance sqrt(2).
pub(crate) fn normaliser(p: &[[f64; 2]]) -> Mat3 {
    let n = p.len() as f64;
    let (mx, my) = (
        p.iter().map(|q| q[0]).sum::<f64>() / n,
        p.iter().map(|q| q[1]).sum::<f64>() / n,
    );
    let d = p.iter().map(|q| (q[0] - mx).hypot(q[1] - my)).sum::<f64>() / n;
    let s = if d > 0.0 {
        std::f64::consts::SQRT_2 / d
    } else {
        1.0
    };
    Mat3::new(s, 0.0, -s * mx, 0.0, s, -s * my, 0.0, 0.0, 1.0)
}

/// The homography `to_from_from` that best maps `from[i]` to `to[i]` in the algebraic
/// least-squares sense (normalised DLT), with w > 0 at the points' centroid.
pub fn fit_homography(from: &[[f64; 2]], to: &[[f64; 2]]) -> Result<Homography, SolveError> {
    let n = from.len().min(to.len());
    if n < 4 {
        return Err(SolveError::TooFewPoints { got: n, need: 4 });
    }
    if let Some(index) = (0..n).find(|&i| from[i].iter().chain(&to[i]).any(|v| !v.is_finite())) {
        return Err(SolveError::NotFinite { index });
    }
    let (ta, tb) = (normaliser(&from[..n]), normaliser(&to[..n]));
    let rows = (2 * n).max(9);
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for i in 0..n {
        let p = ta * Vector3::new(from[i][0], from[i][1], 1.0);
        let q = tb * Vector3::new(to[i][0], to[i][1], 1.0);
        let (x, y, u, v) = (p.x / p.z, p.y / p.z, q.x / q.z, q.y / q.z);
        a.row_mut(2 * i)
            .copy_from_slice(&[-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u]);
        a.row_mut(2 * i + 1)
            .copy_from_slice(&[0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v]);
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t.ok_or(SolveError::Degenerate)?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    let s1 = svd.singular_values[order[1]];
    if s1 <= 1e-10 * svd.singular_values.max() {
        return Err(SolveError::Degenerate);
    }
    let h = v_t.row(order[0]);
    let hn = Mat3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let tb_inv = tb.try_inverse().ok_or(SolveError::Degenerate)?;
    positive_at_centroid(tb_inv * hn * ta, &from[..n])
}

/// `m` scaled to unit norm with w > 0 at the centroid of `from` (the crate's sign of w).
pub(crate) fn positive_at_centroid(m: Mat3, from: &[[f64; 2]]) -> Result<Homography, SolveError> {
    let n = from.len().max(1) as f64;
    let c = Vector3::new(
        from.iter().map(|q| q[0]).sum::<f64>() / n,
        from.iter().map(|q| q[1]).sum::<f64>() / n,
        1.0,
    );
    let m = if (m * c).z < 0.0 { -m } else { m };
    Homography::new(m / m.norm()).map_err(|_| SolveError::Degenerate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_homography_exactly() {
        let truth = Homography::new(Mat3::new(
            1.1, 0.2, 30.0, -0.1, 0.9, -12.0, 2e-4, -1e-4, 1.0,
        ))
        .expect("ok");
        let from: Vec<[f64; 2]> = (0..30)
            .map(|i| [(i * 37 % 500) as f64, (i * 53 % 400) as f64])
            .collect();
        let to: Vec<[f64; 2]> = from
            .iter()
            .map(|p| truth.map(p[0], p[1]).expect("finite"))
            .collect();
        let fit = fit_homography(&from, &to).expect("fit");
        for p in &from {
            let (a, b) = (
                fit.map(p[0], p[1]).expect("finite"),
                truth.map(p[0], p[1]).expect("finite"),
            );
            assert!((a[0] - b[0]).abs() < 1e-8 && (a[1] - b[1]).abs() < 1e-8);
        }
    }

    #[test]
    fn four_points_are_enough_and_three_are_not() {
        let from = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let to = [[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]];
        let h = fit_homography(&from, &to).expect("fit");
        let p = h.map(0.5, 0.5).expect("finite");
        assert!((p[0] - 1.0).abs() < 1e-12 && (p[1] - 1.5).abs() < 1e-12);
        assert_eq!(
            fit_homography(&from[..3], &to[..3]).unwrap_err(),
            SolveError::TooFewPoints { got: 3, need: 4 }
        );
    }

    #[test]
    fn collinear_points_are_refused() {
        let from: Vec<[f64; 2]> = (0..6).map(|i| [i as f64, 2.0 * i as f64]).collect();
        assert_eq!(
            fit_homography(&from, &from).unwrap_err(),
            SolveError::Degenerate
        );
    }
}
