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
//!
//! Valid domain: every model has one ([`DistortionModel::valid_domain`], see [`domain`]): the
//! disc about the axis where it is monotonic along rays. The `*_within` directions answer `None`
//! outside it; per-pixel maps compute the domain once and gate with them.

mod domain;
mod opencv;
mod paper;

pub use domain::ValidDomain;
pub use opencv::{OpenCv, OpenCvTerms};
pub use paper::{Brown, Improved, Tsai};

use serde::{Deserialize, Serialize};

/// Which direction a model's closed form computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
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

    /// The value and the point Jacobian, with the parameter Jacobian written into `d_params`
    /// (one entry a parameter, `names()` order): `closed` without allocating (a calibration's
    /// Jacobian rows).
    fn closed_into(&self, q: [f64; 2], d_params: &mut [[f64; 2]]) -> ([f64; 2], [[f64; 2]; 2]) {
        let c = self.closed(q);
        for (out, d) in d_params.iter_mut().zip(&c.d_params) {
            *out = *d;
        }
        (c.value, c.d_point)
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

    /// Whether every non-zero term is radially symmetric (the valid domain is then found on
    /// one ray).
    fn is_radial(&self) -> bool {
        false
    }

    /// The disc where the model is one-to-one (see [`ValidDomain`]); marches rays, so compute
    /// it once per map, not per point.
    fn valid_domain(&self) -> ValidDomain {
        domain::valid_domain(self, self.is_radial())
    }

    /// [`DistortionModel::observed_from_ideal`] inside `domain` (this model's), `None` outside.
    #[inline(always)]
    fn observed_from_ideal_within(&self, domain: &ValidDomain, p: [f64; 2]) -> Option<[f64; 2]> {
        match self.direction() {
            Direction::ObservedFromIdeal => domain.holds(p).then(|| self.value(p)),
            Direction::IdealFromObserved => newton_inverse(self, p).filter(|q| domain.holds(*q)),
        }
    }

    /// [`DistortionModel::ideal_from_observed`] inside `domain` (this model's), `None` outside.
    #[inline(always)]
    fn ideal_from_observed_within(&self, domain: &ValidDomain, p: [f64; 2]) -> Option<[f64; 2]> {
        match self.direction() {
            Direction::IdealFromObserved => domain.holds(p).then(|| self.value(p)),
            Direction::ObservedFromIdeal => newton_inverse(self, p).filter(|q| domain.holds(*q)),
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
/// OpenCV's variants share one struct; the file's `model` names its terms (`opencv`,
/// `opencv-rational`, `opencv-thin-prism`, `opencv-rational-thin-prism`), and a file naming fewer
/// terms than its non-zero coefficients need (an older `model = "opencv"` with k4..k6) loads as
/// the variant that has them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "DistortionFile", into = "DistortionFile")]
pub enum Distortion {
    Tsai(Tsai),
    Brown(Brown),
    Improved(Improved),
    OpenCv(OpenCv),
}

/// The file form of [`Distortion`]: one tag per model name.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "lowercase", deny_unknown_fields)]
enum DistortionFile {
    Tsai(Tsai),
    Brown(Brown),
    Improved(Improved),
    #[serde(rename = "opencv")]
    OpenCv(OpenCv),
    #[serde(rename = "opencv-rational")]
    OpenCvRational(OpenCv),
    #[serde(rename = "opencv-thin-prism")]
    OpenCvThinPrism(OpenCv),
    #[serde(rename = "opencv-rational-thin-prism")]
    OpenCvRationalThinPrism(OpenCv),
}

impl From<DistortionFile> for Distortion {
    fn from(f: DistortionFile) -> Self {
        let opencv = |mut m: OpenCv, terms: OpenCvTerms| {
            m.terms = terms;
            m.terms = m.effective_terms();
            Distortion::OpenCv(m)
        };
        match f {
            DistortionFile::Tsai(m) => Distortion::Tsai(m),
            DistortionFile::Brown(m) => Distortion::Brown(m),
            DistortionFile::Improved(m) => Distortion::Improved(m),
            DistortionFile::OpenCv(m) => opencv(m, OpenCvTerms::Standard),
            DistortionFile::OpenCvRational(m) => opencv(m, OpenCvTerms::Rational),
            DistortionFile::OpenCvThinPrism(m) => opencv(m, OpenCvTerms::ThinPrism),
            DistortionFile::OpenCvRationalThinPrism(m) => opencv(m, OpenCvTerms::RationalThinPrism),
        }
    }
}

impl From<Distortion> for DistortionFile {
    fn from(d: Distortion) -> Self {
        match d {
            Distortion::Tsai(m) => DistortionFile::Tsai(m),
            Distortion::Brown(m) => DistortionFile::Brown(m),
            Distortion::Improved(m) => DistortionFile::Improved(m),
            Distortion::OpenCv(m) => match m.effective_terms() {
                OpenCvTerms::Standard => DistortionFile::OpenCv(m),
                OpenCvTerms::Rational => DistortionFile::OpenCvRational(m),
                OpenCvTerms::ThinPrism => DistortionFile::OpenCvThinPrism(m),
                OpenCvTerms::RationalThinPrism => DistortionFile::OpenCvRationalThinPrism(m),
            },
        }
    }
}

impl Distortion {
    /// The model names `zero` knows, in the order help texts list them.
    pub const NAMES: [&'static str; 7] = [
        "tsai",
        "brown",
        "improved",
        "opencv",
        "opencv-rational",
        "opencv-thin-prism",
        "opencv-rational-thin-prism",
    ];

    /// A zero model of the named kind (one of [`Distortion::NAMES`]).
    pub fn zero(kind: &str) -> Option<Self> {
        Some(match kind {
            "tsai" => Distortion::Tsai(Tsai::default()),
            "brown" => Distortion::Brown(Brown::default()),
            "improved" => Distortion::Improved(Improved::default()),
            _ => Distortion::OpenCv(OpenCv::with_terms(OpenCvTerms::from_name(kind)?)),
        })
    }

    /// Every coefficient name the model's family knows (OpenCV's twelve for each of its
    /// variants; a model's own `names()` otherwise).
    pub fn all_coefficient_names(&self) -> &'static [&'static str] {
        match self {
            Distortion::OpenCv(_) => OpenCvTerms::RationalThinPrism.names(),
            _ => self.model().names(),
        }
    }

    /// Groups of coefficients a calibration may hold at zero when the data cannot determine
    /// them (OpenCV's rational and thin-prism terms), each with its name.
    pub fn optional_groups(&self) -> Vec<(&'static str, &'static [&'static str])> {
        match self {
            Distortion::OpenCv(m) => m.effective_terms().optional_groups(),
            _ => vec![],
        }
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

    /// The model's valid domain (see [`ValidDomain`]).
    pub fn valid_domain(&self) -> ValidDomain {
        self.model().valid_domain()
    }

    /// The model's name in files.
    pub fn kind(&self) -> &'static str {
        match self {
            Distortion::Tsai(_) => "tsai",
            Distortion::Brown(_) => "brown",
            Distortion::Improved(_) => "improved",
            Distortion::OpenCv(m) => m.effective_terms().name(),
        }
    }
}

#[cfg(test)]
mod conformance;
