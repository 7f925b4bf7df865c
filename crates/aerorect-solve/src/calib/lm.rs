//! The calibration's side of the crate's Levenberg-Marquardt loop ([`crate::lm`]): the problem
//! supplies its residuals and its normal equations (J^T J, J^T r) in whatever block form it
//! has, and solves the damped system with nalgebra; the paper's stop rule (every update moves
//! every predicted point by less than a threshold in pixels) is the loop's
//! [`crate::lm::Model::settled`].

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

/// The calibration's state in the shared loop: the free vector and its residuals.
struct CalibState {
    x: DVector<f64>,
    r: DVector<f64>,
}

/// A calibration problem as the crate's [`crate::lm::Model`], with the paper's stop rule.
struct Adapter<'a, P: Problem, F> {
    p: &'a P,
    normal: P::Normal,
    stop_px: f64,
    point_shift: F,
}

impl<P: Problem, F: Fn(&DVector<f64>) -> f64> crate::lm::Model for Adapter<'_, P, F> {
    type State = CalibState;
    fn cost(&self, s: &CalibState) -> Option<f64> {
        Some(s.r.norm_squared())
    }
    fn linearise(&mut self, s: &CalibState) -> Option<f64> {
        self.p.normal_into(&s.x, &s.r, &mut self.normal);
        // No gradient stop: the paper's rule and the cost's own decrease decide.
        Some(f64::INFINITY)
    }
    fn step(&mut self, s: &CalibState, lambda: f64) -> Option<crate::lm::Step<CalibState>> {
        let mut dx = DVector::zeros(s.x.len());
        if !self.normal.solve_damped(lambda, &mut dx) {
            return None;
        }
        let x = &s.x + &dx;
        let mut r = DVector::zeros(s.r.len());
        self.p.residuals_into(&x, &mut r);
        Some(crate::lm::Step {
            state: CalibState { x, r },
            step_norm: dx.norm(),
            x_norm: s.x.norm(),
        })
    }
    fn settled(&self, before: &CalibState, after: &CalibState) -> bool {
        (self.point_shift)(&(&after.r - &before.r)) < self.stop_px
    }
}

/// Minimises |r(x)|^2 from `x0` with the crate's loop ([`crate::lm::minimise`]).
/// `point_shift(dr)` is the largest change of a predicted point (in pixels) for a change `dr`
/// of the residual vector: the stop rule. The cost's relative decrease stops it below 1e-15;
/// the gradient and step tolerances are not used.
pub(crate) fn minimise<P: Problem>(
    p: &P,
    x0: DVector<f64>,
    max_iterations: usize,
    stop_px: f64,
    point_shift: impl Fn(&DVector<f64>) -> f64,
) -> LmResult<P::Normal> {
    let mut r = DVector::zeros(p.residual_count());
    p.residuals_into(&x0, &mut r);
    let mut model = Adapter {
        p,
        normal: p.new_normal(),
        stop_px,
        point_shift,
    };
    let tol = crate::lm::Tolerances {
        function: 1e-15,
        gradient: 0.0,
        parameter: 0.0,
    };
    let out = crate::lm::minimise(&mut model, CalibState { x: x0, r }, max_iterations, tol);
    use crate::lm::Termination as T;
    let stop = match out.termination {
        T::Settled => StopReason::UpdateBelowThreshold,
        T::MaxIterations => StopReason::MaxIterations,
        _ => StopReason::NoFurtherDecrease,
    };
    LmResult {
        x: out.state.x,
        iterations: out.iterations,
        stop,
        normal: model.normal,
        residuals: out.state.r,
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
