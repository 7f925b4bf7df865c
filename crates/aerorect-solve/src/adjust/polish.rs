//! Tie points moved to their own minimum of the robust cost, the frames and cameras held.
//!
//! Why: the loop's steps weight an observation in Huber's linear arm by `k / |r|` (IRLS, as
//! Ceres does), which claims a curvature along the residual that the cost does not have
//! (there it is `2 k |r|`, a cone). A tie point with such an observation, held only by other
//! views and the terrain, slides along its ray by a few percent of the remaining way per
//! step (a linear rate near 0.96), and drags its frames with it. On the simulated fixed-wing
//! block (100 frames, 58,000 ties, `bench/sim_flight.py 10 10 DIR fixed-wing:5`) three such
//! observations kept each solve going about 50 iterations, each lowering the cost by a
//! relative 1e-4 to 1e-5 and moving the frames by about 1 % of their standard deviation
//! (the step's length in the reduced system's own metric): 269 iterations over the flight's
//! seven solves. A point alone is three unknowns: Newton's method with the cone's exact
//! curvature (the loop's IRLS curvature where that does not lower the cost), each step halved
//! until the point's cost falls, puts it at its minimum in a few iterations; with it the same
//! flight takes 50 iterations (the final solve 6 instead of 46), the gps-only fixed wing 71
//! instead of 575, and both end where the slow road ended (attitude error against the truth
//! 0.107 / 0.217 deg median / max, before 0.109 / 0.218).
//!
//! What the result is: the same minimum of the robust cost. Polishing only lowers the cost
//! (each point's terms are its own once the frames are held), the loop's acceptance and
//! stops are unchanged, and where it stops every polished point is at its own minimum. A
//! simulated block with 40 wrong matches ends within 0.001 of the frames' standard deviations
//! of a solve held to tolerances a million times tighter (`tests/adjust.rs`).

use super::TiePoint;
use super::blocks::State;
use super::jacobian::Posed;
use super::linear::{Linear, PART};
use super::residuals::Problem;
use aerorect_core::Vec3;
use nalgebra::{Matrix3, SVector};
use rayon::prelude::*;

/// Most Newton iterations per point and halvings per iteration.
const ITERATIONS: usize = 10;
const HALVINGS: usize = 10;

/// Below this Newton decrement (the cost's expected decrease, in squared sigmas) a point is
/// at its minimum.
const DECREMENT: f64 = 1e-10;

/// A point's half gradient and half Hessian of its cost: the exact one (the cone's
/// curvature in Huber's linear arm) and the loop's (IRLS).
struct PointNewton {
    gradient: Vec3,
    exact: Matrix3<f64>,
    irls: Matrix3<f64>,
}

impl Problem<'_> {
    fn point_newton(&self, posed: &[Posed<'_>], tie: &TiePoint, x: &Vec3) -> Option<PointNewton> {
        let (k, sig) = (self.huber, self.opts.pixel_sigma);
        let (hp, bp) = self.point_prior_blocks(tie, x);
        let mut out = PointNewton {
            gradient: bp,
            exact: hp,
            irls: hp,
        };
        for o in &tie.observations {
            let pj = posed[o.frame].pixel_jacobian(x)?;
            let r =
                SVector::<f64, 2>::new(pj.pixel[0] - o.pixel[0], pj.pixel[1] - o.pixel[1]) / sig;
            let jt = (pj.point / sig).transpose();
            let n = r.norm();
            let w = o.weight * if n <= k { 1.0 } else { k / n };
            let jtj = jt * jt.transpose();
            out.gradient += w * jt * r;
            out.irls += w * jtj;
            out.exact += match n <= k {
                true => w * jtj,
                // d^2 (2 k |r|) / dr^2 = 2 (k / |r|) (I - u u^T), u = r / |r|.
                false => {
                    let ju = jt * (r / n);
                    w * (jtj - ju * ju.transpose())
                }
            };
        }
        Some(out)
    }

    /// Tie point `x` moved to the minimum of its own cost (the frames of `s` held): Newton
    /// steps with the exact curvature, the loop's (IRLS) one where that fails to lower the
    /// cost, each halved until the cost falls.
    pub fn polished(&self, posed: &[Posed<'_>], tie: &TiePoint, x: Vec3) -> Vec3 {
        let mut x = x;
        let Some(mut cost) = self.tie_cost(posed, tie, &x) else {
            return x;
        };
        for _ in 0..ITERATIONS {
            let Some(nw) = self.point_newton(posed, tie, &x) else {
                break;
            };
            let steps = [nw.exact, nw.irls]
                .into_iter()
                .filter_map(|h| h.cholesky().map(|c| -c.solve(&nw.gradient)));
            let Some((y, c, dx)) = steps
                .filter_map(|dx| {
                    self.descent(posed, tie, (&x, cost), &dx)
                        .map(|(y, c)| (y, c, dx))
                })
                .next()
            else {
                break;
            };
            let decrement = -nw.gradient.dot(&dx);
            (x, cost) = (y, c);
            if decrement < DECREMENT {
                break;
            }
        }
        x
    }

    /// `x + a dx` for the first of a = 1, 1/2, 1/4, ... that lowers the point's cost, with
    /// that cost.
    fn descent(
        &self,
        posed: &[Posed<'_>],
        tie: &TiePoint,
        (x, cost): (&Vec3, f64),
        dx: &Vec3,
    ) -> Option<(Vec3, f64)> {
        let mut a = 1.0;
        for _ in 0..HALVINGS {
            let y = x + dx * a;
            match self.tie_cost(posed, tie, &y) {
                Some(c) if c < cost => return Some((y, c)),
                _ => a *= 0.5,
            }
        }
        None
    }
}

impl Problem<'_> {
    /// Moves every tie point of `s` that the linearisation `lin` found with an observation in
    /// Huber's linear arm to its own minimum, the frames of `s` held (in parallel: each point
    /// alone, so the result does not depend on the threads); returns the sum of the squared
    /// moves.
    pub(super) fn polish(&self, lin: &Linear, s: &mut State) -> f64 {
        let posed = self.posed(s);
        let moved: Vec<(usize, Vec3)> = (lin.parts.par_iter().enumerate())
            .flat_map_iter(|(k, part)| {
                let robust = part.points.iter().enumerate().filter(|(_, p)| p.robust);
                robust.map(move |(j, _)| k * PART + j)
            })
            .map(|i| (i, self.polished(&posed, &self.ties[i], s.points[i])))
            .collect();
        moved.into_iter().fold(0.0, |sum, (i, x)| {
            let d = (x - s.points[i]).norm_squared();
            s.points[i] = x;
            sum + d
        })
    }
}
