//! A lens model's valid domain: the disc about the axis where the model is one-to-one.
//!
//! Beyond the radius where a lens polynomial stops being monotonic the mapping folds back, and
//! far rays land inside the image again (mirrored ghosts of the ground beyond the footprint).
//! The domain is found in the closed form's argument space (ideal coordinates for OpenCV's
//! model, observed ones for the paper's) by marching rays from the axis: a point is inside while,
//! at every step from the axis out to it, the model's value along the ray increases strictly,
//! stays finite, and its point Jacobian keeps a positive determinant and diagonal (the sheet
//! that contains the identity, the criterion Newton's inverse checks at its root).

use super::{Direction, DistortionModel};
use serde::Serialize;

/// Radii are searched out to this normalised radius (89.4 degrees off the axis); a model that
/// does not fold before it is taken as monotonic everywhere.
const SCAN_LIMIT: f64 = 100.0;
/// Fine steps out to this radius, where real folds lie, then geometric ones.
const FINE_LIMIT: f64 = 2.0;
const FINE_STEP: f64 = 0.002;
const COARSE_RATIO: f64 = 1.004;
/// Rays marched for a model with terms that are not radially symmetric; the worst is then
/// refined by a golden-section search over the angle between its neighbours.
const DIRECTIONS: usize = 72;
const REFINEMENTS: usize = 40;
/// The domain's radius as a share of the first fold: it keeps Newton's method off the singular
/// Jacobian at the fold (1 - 1e-6) and, for a model that is not radially symmetric, covers a
/// narrower minimum of the fold over the angle than the search found (1 - 1e-4).
const RADIAL_MARGIN: f64 = 1.0 - 1e-6;
const ASYMMETRIC_MARGIN: f64 = 1.0 - 1e-4;

/// Where a lens model is valid: the disc `|q| <= radius` of the closed form's argument.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ValidDomain {
    /// The space `radius` is measured in: the closed form's argument (`ObservedFromIdeal`: ideal
    /// coordinates; `IdealFromObserved`: observed ones).
    pub direction: Direction,
    /// The radius, in normalised units, margin applied; infinite for a model that never folds.
    pub radius: f64,
    /// The radius of the largest circle about the axis, in the other space, inside the image of
    /// the disc (the smallest |value| on its rim); infinite with `radius`.
    pub image_radius: f64,
    radius_squared: f64,
}

impl ValidDomain {
    /// The whole plane (an ideal pinhole, a model that never folds).
    pub fn unbounded(direction: Direction) -> Self {
        Self {
            direction,
            radius: f64::INFINITY,
            image_radius: f64::INFINITY,
            radius_squared: f64::INFINITY,
        }
    }

    /// Whether the closed form's argument `q` is inside (one comparison of r^2).
    #[inline(always)]
    pub fn holds(&self, q: [f64; 2]) -> bool {
        q[0] * q[0] + q[1] * q[1] <= self.radius_squared
    }

    pub fn is_bounded(&self) -> bool {
        self.radius.is_finite()
    }

    /// The radius of the domain's disc in ideal coordinates (inscribed when the model's closed
    /// form goes the other way).
    pub fn ideal_radius(&self) -> f64 {
        match self.direction {
            Direction::ObservedFromIdeal => self.radius,
            Direction::IdealFromObserved => self.image_radius,
        }
    }

    /// The radius of the domain's disc in observed coordinates (inscribed when the model's
    /// closed form goes the other way).
    pub fn observed_radius(&self) -> f64 {
        match self.direction {
            Direction::ObservedFromIdeal => self.image_radius,
            Direction::IdealFromObserved => self.radius,
        }
    }
}

/// The domain of `m`, marching `DIRECTIONS` rays (one when `radial`).
pub(super) fn valid_domain<M: DistortionModel + ?Sized>(m: &M, radial: bool) -> ValidDomain {
    let fold_at = |a: f64| first_fold(m, [a.cos(), a.sin()]);
    let fold = if radial {
        fold_at(0.0)
    } else {
        let step = std::f64::consts::TAU / DIRECTIONS as f64;
        let (worst, fold) = (0..DIRECTIONS)
            .map(|i| (i, fold_at(step * i as f64)))
            .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
        let centre = step * worst as f64;
        fold.min(golden_minimum(fold_at, centre - step, centre + step))
    };
    if !fold.is_finite() {
        return ValidDomain::unbounded(m.direction());
    }
    let radius = fold
        * if radial {
            RADIAL_MARGIN
        } else {
            ASYMMETRIC_MARGIN
        };
    let rim = 4 * DIRECTIONS;
    let image_radius = (0..rim)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / rim as f64;
            let v = m.value([radius * a.cos(), radius * a.sin()]);
            v[0].hypot(v[1])
        })
        .fold(f64::INFINITY, f64::min);
    ValidDomain {
        direction: m.direction(),
        radius,
        image_radius,
        radius_squared: radius * radius,
    }
}

/// The smallest value of `f` found by a golden-section search on [lo, hi].
fn golden_minimum(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (lo, hi);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..REFINEMENTS {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = f(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    fc.min(fd)
}

/// Whether `m` is still on its valid sheet at radius `r` along unit direction `u`, given the
/// value along the ray one step before (`last`); returns the value along the ray there (from
/// the axis's value, which film and offset terms move off the origin).
fn step_ok<M: DistortionModel + ?Sized>(m: &M, u: [f64; 2], r: f64, last: f64) -> Option<f64> {
    let (v, j) = m.value_d_point([r * u[0], r * u[1]]);
    let v0 = m.value([0.0, 0.0]);
    let along = (v[0] - v0[0]) * u[0] + (v[1] - v0[1]) * u[1];
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    // d(value . u)/dr = u^T J u
    let slope = u[0] * (j[0][0] * u[0] + j[0][1] * u[1]) + u[1] * (j[1][0] * u[0] + j[1][1] * u[1]);
    let ok = along.is_finite()
        && along > last
        && slope > 0.0
        && det > 0.0
        && j[0][0] > 0.0
        && j[1][1] > 0.0;
    ok.then_some(along)
}

/// The first radius along `u` where the model leaves its valid sheet (bisected to 1e-12 of
/// the step), infinite when it does not before `SCAN_LIMIT`.
fn first_fold<M: DistortionModel + ?Sized>(m: &M, u: [f64; 2]) -> f64 {
    let (mut r_ok, mut last) = (0.0, 0.0);
    loop {
        let r = if r_ok < FINE_LIMIT {
            r_ok + FINE_STEP
        } else {
            r_ok * COARSE_RATIO
        };
        if r > SCAN_LIMIT {
            return f64::INFINITY;
        }
        match step_ok(m, u, r, last) {
            Some(along) => (r_ok, last) = (r, along),
            None => return bisect(m, u, (r_ok, last), r),
        }
    }
}

/// Bisects between a good radius (with its value along the ray) and a failing one.
fn bisect<M: DistortionModel + ?Sized>(m: &M, u: [f64; 2], good: (f64, f64), bad: f64) -> f64 {
    let ((mut lo, mut last), mut hi) = (good, bad);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        match step_ok(m, u, mid, last) {
            Some(along) => (lo, last) = (mid, along),
            None => hi = mid,
        }
    }
    lo
}
