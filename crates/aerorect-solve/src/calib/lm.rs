//! A Levenberg-Marquardt loop with Marquardt's diagonal damping. The linear algebra is
//! nalgebra's (Cholesky of the damped normal equations); this file only decides steps and stops,
//! because the paper's stop rule (every update moves every predicted point by less than a
//! threshold in pixels) is not one of the usual relative tolerances.

use nalgebra::{DMatrix, DVector};

/// What the loop minimises: residuals r(x) and their Jacobian.
pub(crate) trait Problem {
    fn residuals(&self, x: &DVector<f64>) -> DVector<f64>;
    fn jacobian(&self, x: &DVector<f64>) -> DMatrix<f64>;
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// Every update changed every predicted point by less than the threshold.
    UpdateBelowThreshold,
    /// The sum of squares stopped decreasing (relative change below 1e-15).
    NoFurtherDecrease,
    MaxIterations,
}

pub(crate) struct LmResult {
    pub x: DVector<f64>,
    pub iterations: usize,
    pub stop: StopReason,
    pub jacobian: DMatrix<f64>,
    pub residuals: DVector<f64>,
}

/// Minimises |r(x)|^2 from `x0`. `point_shift(dr)` is the largest change of a predicted point
/// (in pixels) for a change `dr` of the residual vector: the stop rule.
pub(crate) fn minimise<P: Problem>(
    p: &P,
    x0: DVector<f64>,
    max_iterations: usize,
    stop_px: f64,
    point_shift: impl Fn(&DVector<f64>) -> f64,
) -> LmResult {
    let mut x = x0;
    let mut r = p.residuals(&x);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut j = p.jacobian(&x);
    let mut stop = StopReason::MaxIterations;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let jt = j.transpose();
        let jtj = &jt * &j;
        let g = &jt * &r;
        let mut accepted = false;
        for _ in 0..20 {
            let mut a = jtj.clone();
            for k in 0..a.nrows() {
                a[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(chol) = a.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let dx = -chol.solve(&g);
            let x_new = &x + &dx;
            let r_new = p.residuals(&x_new);
            let cost_new = r_new.norm_squared();
            if cost_new.is_finite() && cost_new <= cost {
                let shift = point_shift(&(&r_new - &r));
                let rel = (cost - cost_new) / cost.max(1e-300);
                (x, r, cost) = (x_new, r_new, cost_new);
                lambda = (lambda / 3.0).max(1e-12);
                accepted = true;
                if shift < stop_px {
                    stop = StopReason::UpdateBelowThreshold;
                } else if rel < 1e-15 {
                    stop = StopReason::NoFurtherDecrease;
                }
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            stop = StopReason::NoFurtherDecrease;
            break;
        }
        j = p.jacobian(&x);
        if stop != StopReason::MaxIterations {
            break;
        }
    }
    LmResult {
        x,
        iterations,
        stop,
        jacobian: j,
        residuals: r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rosenbrock as least squares: r = (10 (y - x^2), 1 - x); minimum at (1, 1).
    struct Rosenbrock;
    impl Problem for Rosenbrock {
        fn residuals(&self, x: &DVector<f64>) -> DVector<f64> {
            DVector::from_vec(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]])
        }
        fn jacobian(&self, x: &DVector<f64>) -> DMatrix<f64> {
            DMatrix::from_row_slice(2, 2, &[-20.0 * x[0], 10.0, -1.0, 0.0])
        }
    }

    #[test]
    fn finds_the_rosenbrock_minimum() {
        let res = minimise(
            &Rosenbrock,
            DVector::from_vec(vec![-1.2, 1.0]),
            200,
            1e-12,
            |d| d.amax(),
        );
        assert!(
            (res.x[0] - 1.0).abs() < 1e-6 && (res.x[1] - 1.0).abs() < 1e-6,
            "{:?}",
            res.x
        );
        assert_ne!(res.stop, StopReason::MaxIterations);
    }
}
