//! A Levenberg-Marquardt loop with Marquardt's diagonal damping. The problem supplies its
//! residuals and its normal equations (J^T J, J^T r) in whatever block form it has, and solves
//! the damped system with nalgebra; this file only decides steps and stops, because the paper's
//! stop rule (every update moves every predicted point by less than a threshold in pixels) is
//! not one of the usual relative tolerances. Buffers are made once: an iteration allocates
//! nothing here.

use nalgebra::DVector;

/// The linearised problem's normal equations at one point.
pub(crate) trait NormalEquations {
    /// The step dx solving (J^T J + lambda D) dx = -J^T r, with D the diagonal of J^T J (each
    /// entry at least 1e-12); false when the damped matrix is not positive definite.
    fn solve_damped(&mut self, lambda: f64, dx: &mut DVector<f64>) -> bool;
}

/// What the loop minimises: residuals r(x) and the normal equations of their Jacobian.
pub(crate) trait Problem {
    type Normal: NormalEquations;
    /// The number of residuals.
    fn residual_count(&self) -> usize;
    fn residuals_into(&self, x: &DVector<f64>, r: &mut DVector<f64>);
    /// Empty normal equations (the buffers `normal_into` fills).
    fn new_normal(&self) -> Self::Normal;
    /// J^T J and J^T r at `x`, where `r` = residuals(x).
    fn normal_into(&self, x: &DVector<f64>, r: &DVector<f64>, n: &mut Self::Normal);
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

pub(crate) struct LmResult<N> {
    pub x: DVector<f64>,
    pub iterations: usize,
    pub stop: StopReason,
    /// The normal equations at `x`.
    pub normal: N,
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
) -> LmResult<P::Normal> {
    let m = p.residual_count();
    let mut x = x0;
    let mut r = DVector::zeros(m);
    p.residuals_into(&x, &mut r);
    let mut cost = r.norm_squared();
    let mut lambda = 1e-3;
    let mut normal = p.new_normal();
    p.normal_into(&x, &r, &mut normal);
    let (mut dx, mut x_new) = (DVector::zeros(x.len()), DVector::zeros(x.len()));
    let (mut r_new, mut dr) = (DVector::zeros(m), DVector::zeros(m));
    let mut stop = StopReason::MaxIterations;
    let mut iterations = 0;
    while iterations < max_iterations {
        iterations += 1;
        let mut accepted = false;
        for _ in 0..20 {
            if !normal.solve_damped(lambda, &mut dx) {
                lambda *= 10.0;
                continue;
            }
            x_new.copy_from(&x);
            x_new += &dx;
            p.residuals_into(&x_new, &mut r_new);
            let cost_new = r_new.norm_squared();
            if cost_new.is_finite() && cost_new <= cost {
                dr.copy_from(&r_new);
                dr -= &r;
                let shift = point_shift(&dr);
                let rel = (cost - cost_new) / cost.max(1e-300);
                std::mem::swap(&mut x, &mut x_new);
                std::mem::swap(&mut r, &mut r_new);
                cost = cost_new;
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
        p.normal_into(&x, &r, &mut normal);
        if stop != StopReason::MaxIterations {
            break;
        }
    }
    LmResult {
        x,
        iterations,
        stop,
        normal,
        residuals: r,
    }
}

/// Dense normal equations from a whole Jacobian (the tests' reference).
#[cfg(test)]
pub(crate) struct Dense {
    pub jtj: nalgebra::DMatrix<f64>,
    pub g: DVector<f64>,
}

#[cfg(test)]
impl NormalEquations for Dense {
    fn solve_damped(&mut self, lambda: f64, dx: &mut DVector<f64>) -> bool {
        let mut a = self.jtj.clone();
        for k in 0..a.nrows() {
            a[(k, k)] += lambda * self.jtj[(k, k)].max(1e-12);
        }
        let Some(chol) = a.cholesky() else {
            return false;
        };
        dx.copy_from(&-chol.solve(&self.g));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    /// Rosenbrock as least squares: r = (10 (y - x^2), 1 - x); minimum at (1, 1).
    struct Rosenbrock;
    impl Problem for Rosenbrock {
        type Normal = Dense;
        fn residual_count(&self) -> usize {
            2
        }
        fn residuals_into(&self, x: &DVector<f64>, r: &mut DVector<f64>) {
            r.copy_from_slice(&[10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
        }
        fn new_normal(&self) -> Dense {
            Dense {
                jtj: DMatrix::zeros(2, 2),
                g: DVector::zeros(2),
            }
        }
        fn normal_into(&self, x: &DVector<f64>, r: &DVector<f64>, n: &mut Dense) {
            let j = DMatrix::from_row_slice(2, 2, &[-20.0 * x[0], 10.0, -1.0, 0.0]);
            n.jtj = j.transpose() * &j;
            n.g = j.transpose() * r;
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
