//! Lens distortion models: one struct per model, one trait, one enum.
//!
//! Coordinates: **normalised image coordinates** (x, y) = ((u - cx) / fx, (v - cy) / fy) with the
//! skew removed, x right, y down, r^2 = x^2 + y^2 about the principal point.
//!
//! Directions:
//! - the paper's models (Tsai, Brown, improved) are written *ideal from observed*:
//!   ideal = observed + sum_j theta_j B_j(observed) (closed form); observed from ideal by Newton;
//! - the OpenCV model is written *observed from ideal* (closed form); ideal from observed by Newton.
//!
//! The inverse direction iterates Newton's method from the point itself and returns `None`
//! unless it converges (step below 1e-12, residual below 1e-10, within 30 iterations) to a point
//! where the Jacobian has a positive diagonal and determinant (the sheet that contains the
//! identity, not a point beyond a fold).

mod opencv;
mod paper;

pub use opencv::OpenCv;
pub use paper::{Brown, Improved, Tsai};

use serde::{Deserialize, Serialize};

/// Which direction a model's closed form computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    IdealFromObserved,
    ObservedFromIdeal,
}

/// A point and parameter Jacobian of a model's closed form at one point.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedForm {
    pub value: [f64; 2],
    /// d value / d point, row-major [[dx/dx, dx/dy], [dy/dx, dy/dy]].
    pub d_point: [[f64; 2]; 2],
    /// d value / d parameter, one column per parameter (in `names()` order).
    pub d_params: Vec<[f64; 2]>,
}

/// A distortion model.
pub trait DistortionModel {
    /// Parameter names, in the order of `params`.
    fn names(&self) -> &'static [&'static str];
    fn params(&self) -> Vec<f64>;
    /// Sets all parameters (in `names()` order); `values.len()` must equal `names().len()`.
    fn set_params(&mut self, values: &[f64]);
    fn direction(&self) -> Direction;
    /// The closed form and its Jacobians at `q`.
    fn closed(&self, q: [f64; 2]) -> ClosedForm;

    /// The closed form's value alone (no allocation; the hot path of pixel maps).
    fn value(&self, q: [f64; 2]) -> [f64; 2] {
        self.closed(q).value
    }

    /// The value and the point Jacobian (no allocation; Newton's method).
    fn value_d_point(&self, q: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let c = self.closed(q);
        (c.value, c.d_point)
    }

    /// Ideal (undistorted) normalised point of an observed one.
    fn ideal_from_observed(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        match self.direction() {
            Direction::IdealFromObserved => Some(self.value(p)),
            Direction::ObservedFromIdeal => newton_inverse(self, p),
        }
    }

    /// Observed (distorted) normalised point of an ideal one.
    fn observed_from_ideal(&self, p: [f64; 2]) -> Option<[f64; 2]> {
        match self.direction() {
            Direction::ObservedFromIdeal => Some(self.value(p)),
            Direction::IdealFromObserved => newton_inverse(self, p),
        }
    }
}

/// Solves closed(q) = target for q by Newton's method from q = target.
fn newton_inverse<M: DistortionModel + ?Sized>(m: &M, target: [f64; 2]) -> Option<[f64; 2]> {
    let mut q = target;
    for _ in 0..30 {
        let (value, d_point) = m.value_d_point(q);
        let (rx, ry) = (value[0] - target[0], value[1] - target[1]);
        let [[a, b], [cc, d]] = d_point;
        let det = a * d - b * cc;
        if !det.is_finite() || det.abs() < 1e-12 {
            return None;
        }
        let (sx, sy) = ((d * rx - b * ry) / det, (a * ry - cc * rx) / det);
        q = [q[0] - sx, q[1] - sy];
        if !(q[0].is_finite() && q[1].is_finite()) {
            return None;
        }
        if sx.abs().max(sy.abs()) < 1e-12 {
            // A root beyond a fold of the mapping (where it turns back) is another sheet's
            // point, not the inverse: on the valid sheet the Jacobian stays near the identity
            // (positive diagonal and determinant); a reflected sheet has both diagonals negative.
            let (value, d_point) = m.value_d_point(q);
            let [[a, b], [cc, d]] = d_point;
            let close = (value[0] - target[0]).hypot(value[1] - target[1]) < 1e-10;
            return (close && a > 0.0 && d > 0.0 && a * d - b * cc > 0.0).then_some(q);
        }
    }
    None
}

/// Any of the models, as stored in camera files (`[distortion]` with `model` and named coefficients).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase", deny_unknown_fields)]
pub enum Distortion {
    Tsai(Tsai),
    Brown(Brown),
    Improved(Improved),
    #[serde(rename = "opencv")]
    OpenCv(OpenCv),
}

impl Distortion {
    /// A zero model of the named kind (tsai, brown, improved, opencv).
    pub fn zero(kind: &str) -> Option<Self> {
        Some(match kind {
            "tsai" => Distortion::Tsai(Tsai::default()),
            "brown" => Distortion::Brown(Brown::default()),
            "improved" => Distortion::Improved(Improved::default()),
            "opencv" => Distortion::OpenCv(OpenCv::default()),
            _ => return None,
        })
    }

    pub fn model(&self) -> &dyn DistortionModel {
        match self {
            Distortion::Tsai(m) => m,
            Distortion::Brown(m) => m,
            Distortion::Improved(m) => m,
            Distortion::OpenCv(m) => m,
        }
    }

    pub fn model_mut(&mut self) -> &mut dyn DistortionModel {
        match self {
            Distortion::Tsai(m) => m,
            Distortion::Brown(m) => m,
            Distortion::Improved(m) => m,
            Distortion::OpenCv(m) => m,
        }
    }

    /// Coefficients that duplicate a camera parameter, each with what it duplicates: Brown's
    /// film terms scale (a1, b2) and shear (a2, b1) the image like fx, fy, the skew and the
    /// views' rotation, and its offsets (dx0, dy0) move it like cx, cy. Fitted together with
    /// their duplicate, the pair is unidentifiable (a planar target gave fx = 34 px).
    pub fn duplicates(&self) -> &'static [(&'static str, &'static str)] {
        const ROTATION: &str = "the views' rotation";
        match self {
            Distortion::Brown(_) => &[
                ("a1", "fx"),
                ("b2", "fy"),
                ("a2", ROTATION),
                ("b1", ROTATION),
                ("dx0", "cx"),
                ("dy0", "cy"),
            ],
            Distortion::Improved(_) => &[("dx0", "cx"), ("dy0", "cy")],
            Distortion::Tsai(_) | Distortion::OpenCv(_) => &[],
        }
    }

    /// The model's name in files.
    pub fn kind(&self) -> &'static str {
        match self {
            Distortion::Tsai(_) => "tsai",
            Distortion::Brown(_) => "brown",
            Distortion::Improved(_) => "improved",
            Distortion::OpenCv(_) => "opencv",
        }
    }
}

#[cfg(test)]
mod conformance;
