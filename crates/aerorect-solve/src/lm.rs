//! The one Levenberg-Marquardt loop of the crate, shared by the calibration and the flight
//! adjustment. A problem supplies its cost, its linearisation (normal equations in whatever
//! block form it has) and the damped step; this file decides steps and stops.
//!
//! Stops, as Ceres's solver does (its defaults in [`Tolerances::default`]):
//! - function tolerance: an accepted step lowered the cost by less than `function` of it;
//! - gradient tolerance: the gradient's largest entry is below `gradient`;
//! - parameter tolerance: the step is shorter than `parameter * (|x| + parameter)`;
//! - a problem's own rule ([`Model::settled`], e.g. the calibration's "every update moves
//!   every predicted point by less than 0.01 px");
//! - no damping gives a lower cost (20 tries with the damping raised each time);
//! - the iteration limit.
//!
//! Damping: Marquardt's (the diagonal of J^T J), starting at 1e-3, divided by 3 (to 1e-12 at
//! least) after an accepted step, multiplied by 4 after a rejected one and by 10 when the damped
//! system cannot be solved.

use serde::Serialize;

/// What the loop minimises.
pub(crate) trait Model {
    type State;
    /// The cost at `s` (a sum of squares; `None` where it is not defined).
    fn cost(&self, s: &Self::State) -> Option<f64>;
    /// Builds the normal equations at `s`; returns the gradient's largest entry (max-norm), or
    /// `None` when they cannot be formed.
    fn linearise(&mut self, s: &Self::State) -> Option<f64>;
    /// The state one damped step from `s` (the last linearisation's), with the step's and
    /// the parameters' Euclidean norms; `None` when the damped system cannot be solved.
    fn step(&mut self, s: &Self::State, lambda: f64) -> Option<Step<Self::State>>;
    /// The problem's own stop rule for an accepted step from `before` to `after`.
    fn settled(&self, _before: &Self::State, _after: &Self::State) -> bool {
        false
    }
    /// Whether the loop linearises at the state it stops at (the calibration's covariance
    /// comes from those normal equations); a model that builds its own there says no.
    fn linearise_at_end(&self) -> bool {
        true
    }
}

/// A damped step's result.
pub(crate) struct Step<S> {
    pub state: S,
    pub step_norm: f64,
    pub x_norm: f64,
}

/// Ceres's three tolerances.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Relative decrease of the cost.
    pub function: f64,
    /// Max-norm of the gradient.
    pub gradient: f64,
    /// Relative step length.
    pub parameter: f64,
}

impl Default for Tolerances {
    /// Ceres's `Solver::Options` defaults.
    fn default() -> Self {
        Self {
            function: 1e-6,
            gradient: 1e-10,
            parameter: 1e-8,
        }
    }
}

/// Why the loop stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    FunctionTolerance,
    GradientTolerance,
    ParameterTolerance,
    /// The problem's own rule ([`Model::settled`]).
    Settled,
    /// No damping lowered the cost.
    NoDescent,
    MaxIterations,
    /// The normal equations could not be formed at the start.
    Failed,
}

impl Termination {
    /// Whether this is a convergence (a tolerance or the problem's rule was met).
    pub fn converged(self) -> bool {
        matches!(
            self,
            Self::FunctionTolerance
                | Self::GradientTolerance
                | Self::ParameterTolerance
                | Self::Settled
                | Self::NoDescent
        )
    }
}

/// The loop's result: the final state (linearised there: the model's normal equations are
/// those at `state`), the iterations and why it stopped.
pub(crate) struct Outcome<S> {
    pub state: S,
    pub iterations: usize,
    pub termination: Termination,
}

/// Most damped solves per iteration before the loop gives up on lowering the cost.
const TRIES: usize = 20;

/// Minimises the model's cost from `s`.
pub(crate) fn minimise<M: Model>(
    m: &mut M,
    s: M::State,
    max_iterations: usize,
    tol: Tolerances,
) -> Outcome<M::State> {
    minimise_damped(m, s, max_iterations, tol, INITIAL_DAMPING)
}

/// The damping the loop starts with.
pub(crate) const INITIAL_DAMPING: f64 = 1e-3;

/// [`minimise`] with the damping starting at `lambda` instead of [`INITIAL_DAMPING`]: small
/// for a start already near the minimum, whose Gauss-Newton step is good (at 1e-3 a large,
/// weakly conditioned block crawls there, the damping falling threefold per step).
pub(crate) fn minimise_damped<M: Model>(
    m: &mut M,
    mut s: M::State,
    max_iterations: usize,
    tol: Tolerances,
    lambda: f64,
) -> Outcome<M::State> {
    let Some(mut cost) = m.cost(&s) else {
        return Outcome {
            state: s,
            iterations: 0,
            termination: Termination::Failed,
        };
    };
    let Some(mut gradient) = m.linearise(&s) else {
        return Outcome {
            state: s,
            iterations: 0,
            termination: Termination::Failed,
        };
    };
    let mut lambda = lambda;
    let (mut iterations, mut termination) = (0, Termination::MaxIterations);
    while iterations < max_iterations {
        if gradient < tol.gradient {
            termination = Termination::GradientTolerance;
            break;
        }
        iterations += 1;
        let mut accepted = None;
        for _ in 0..TRIES {
            let Some(step) = m.step(&s, lambda) else {
                lambda *= 10.0;
                continue;
            };
            match m.cost(&step.state) {
                Some(c) if c.is_finite() && c <= cost => {
                    accepted = Some((step, c));
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        let Some((step, cost_new)) = accepted else {
            termination = Termination::NoDescent;
            break;
        };
        let settled = m.settled(&s, &step.state);
        let rel = (cost - cost_new) / cost.max(1e-300);
        s = step.state;
        cost = cost_new;
        lambda = (lambda / 3.0).max(1e-12);
        termination = if settled {
            Termination::Settled
        } else if rel < tol.function {
            Termination::FunctionTolerance
        } else if step.step_norm <= tol.parameter * (step.x_norm + tol.parameter) {
            Termination::ParameterTolerance
        } else {
            Termination::MaxIterations
        };
        // A stopped loop is linearised again only for a model that asks (on a large flight a
        // linearisation costs about as much as a step).
        let stopped = termination != Termination::MaxIterations || iterations >= max_iterations;
        if stopped && !m.linearise_at_end() {
            break;
        }
        match m.linearise(&s) {
            Some(g) => gradient = g,
            None => {
                termination = Termination::Failed;
                break;
            }
        }
        if stopped {
            break;
        }
    }
    Outcome {
        state: s,
        iterations,
        termination,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    /// Rosenbrock as least squares: r = (10 (y - x^2), 1 - x); minimum at (1, 1).
    struct Rosenbrock {
        jtj: Matrix2<f64>,
        g: Vector2<f64>,
    }

    fn residuals(x: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0])
    }

    impl Model for Rosenbrock {
        type State = Vector2<f64>;
        fn cost(&self, x: &Vector2<f64>) -> Option<f64> {
            Some(residuals(x).norm_squared())
        }
        fn linearise(&mut self, x: &Vector2<f64>) -> Option<f64> {
            let j = Matrix2::new(-20.0 * x[0], 10.0, -1.0, 0.0);
            self.jtj = j.transpose() * j;
            self.g = j.transpose() * residuals(x);
            Some(self.g.amax())
        }
        fn step(&mut self, x: &Vector2<f64>, lambda: f64) -> Option<Step<Vector2<f64>>> {
            let mut a = self.jtj;
            for k in 0..2 {
                a[(k, k)] += lambda * self.jtj[(k, k)].max(1e-12);
            }
            let dx = -a.cholesky()?.solve(&self.g);
            Some(Step {
                state: x + dx,
                step_norm: dx.norm(),
                x_norm: x.norm(),
            })
        }
    }

    /// Rosenbrock that counts its linearisations and remembers the last one's state.
    struct Counted {
        inner: Rosenbrock,
        at_end: bool,
        count: usize,
        last: Vector2<f64>,
    }

    impl Model for Counted {
        type State = Vector2<f64>;
        fn cost(&self, x: &Vector2<f64>) -> Option<f64> {
            self.inner.cost(x)
        }
        fn linearise(&mut self, x: &Vector2<f64>) -> Option<f64> {
            self.count += 1;
            self.last = *x;
            self.inner.linearise(x)
        }
        fn step(&mut self, x: &Vector2<f64>, lambda: f64) -> Option<Step<Vector2<f64>>> {
            self.inner.step(x, lambda)
        }
        fn linearise_at_end(&self) -> bool {
            self.at_end
        }
    }

    /// A model that builds its own normal equations at the end is not linearised there: the
    /// same steps, the same result, one linearisation fewer; one that asks is linearised at
    /// the state the loop stops at (by a tolerance and by the iteration limit alike).
    #[test]
    fn the_loop_linearises_where_it_stops_only_when_asked() {
        for limit in [200, 5] {
            let run = |at_end: bool| {
                let mut m = Counted {
                    inner: rosenbrock(),
                    at_end,
                    count: 0,
                    last: Vector2::zeros(),
                };
                let tol = Tolerances {
                    function: 1e-6,
                    gradient: 0.0,
                    parameter: 0.0,
                };
                let out = minimise(&mut m, Vector2::new(-1.2, 1.0), limit, tol);
                (out, m.count, m.last)
            };
            let ((asked, n_asked, last), (not, n_not, _)) = (run(true), run(false));
            assert_eq!(asked.state, not.state);
            assert_eq!(asked.iterations, not.iterations);
            assert_eq!(asked.termination, not.termination);
            let stop = match limit {
                5 => Termination::MaxIterations,
                _ => Termination::FunctionTolerance,
            };
            assert_eq!(asked.termination, stop);
            assert_eq!(n_asked, n_not + 1);
            assert_eq!(last, asked.state);
        }
    }

    fn rosenbrock() -> Rosenbrock {
        Rosenbrock {
            jtj: Matrix2::zeros(),
            g: Vector2::zeros(),
        }
    }

    #[test]
    fn finds_the_rosenbrock_minimum_and_says_why_it_stopped() {
        let tight = Tolerances {
            function: 1e-15,
            gradient: 1e-12,
            parameter: 1e-14,
        };
        let res = minimise(&mut rosenbrock(), Vector2::new(-1.2, 1.0), 200, tight);
        assert!(
            (res.state - Vector2::new(1.0, 1.0)).amax() < 1e-6,
            "{}",
            res.state
        );
        assert!(res.termination.converged(), "{:?}", res.termination);
    }

    #[test]
    fn the_iteration_limit_is_reported_as_such() {
        let res = minimise(
            &mut rosenbrock(),
            Vector2::new(-1.2, 1.0),
            2,
            Tolerances::default(),
        );
        assert_eq!(res.termination, Termination::MaxIterations);
        assert_eq!(res.iterations, 2);
    }

    #[test]
    fn a_start_at_the_minimum_stops_by_the_gradient_tolerance() {
        let res = minimise(
            &mut rosenbrock(),
            Vector2::new(1.0, 1.0),
            50,
            Tolerances::default(),
        );
        assert_eq!(res.termination, Termination::GradientTolerance);
        assert_eq!(res.iterations, 0);
    }
}
