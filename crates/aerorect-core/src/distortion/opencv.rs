//! OpenCV's model, observed from ideal on normalised coordinates:
//! x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2) + s1 r^2 + s2 r^4
//! y_d = y (same ratio) + p1 (r^2 + 2 y^2) + 2 p2 x y + s3 r^2 + s4 r^4
//! Note the tangential order differs from the paper's (OpenCV's p1 multiplies 2xy in x).
//! Coefficient order: k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 (OpenCV's distCoeffs order).
//!
//! One struct carries every coefficient; [`OpenCvTerms`] says which of them the model has (and a
//! calibration frees): OpenCV's default five, the rational model's eight (CALIB_RATIONAL_MODEL),
//! the thin prism's nine (CALIB_THIN_PRISM_MODEL) or all twelve. A coefficient outside the terms
//! that is non-zero widens them (`effective_terms`), so a lens is never evaluated with a term its
//! parameter list does not show.

use super::{ClosedForm, Direction, DistortionModel};
use serde::{Deserialize, Serialize};

/// Which of OpenCV's coefficients a model has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OpenCvTerms {
    /// k1, k2, p1, p2, k3: OpenCV's default (`opencv`).
    #[default]
    Standard,
    /// + k4, k5, k6 (`opencv-rational`).
    Rational,
    /// + s1..s4 (`opencv-thin-prism`).
    ThinPrism,
    /// + k4..k6 and s1..s4 (`opencv-rational-thin-prism`).
    RationalThinPrism,
}

const ALL: [&str; 12] = [
    "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4",
];

impl OpenCvTerms {
    /// The model's name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            OpenCvTerms::Standard => "opencv",
            OpenCvTerms::Rational => "opencv-rational",
            OpenCvTerms::ThinPrism => "opencv-thin-prism",
            OpenCvTerms::RationalThinPrism => "opencv-rational-thin-prism",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        [
            OpenCvTerms::Standard,
            OpenCvTerms::Rational,
            OpenCvTerms::ThinPrism,
            OpenCvTerms::RationalThinPrism,
        ]
        .into_iter()
        .find(|t| t.name() == name)
    }

    fn rational(self) -> bool {
        matches!(self, OpenCvTerms::Rational | OpenCvTerms::RationalThinPrism)
    }

    fn thin_prism(self) -> bool {
        matches!(
            self,
            OpenCvTerms::ThinPrism | OpenCvTerms::RationalThinPrism
        )
    }

    fn of(rational: bool, thin_prism: bool) -> Self {
        match (rational, thin_prism) {
            (false, false) => OpenCvTerms::Standard,
            (true, false) => OpenCvTerms::Rational,
            (false, true) => OpenCvTerms::ThinPrism,
            (true, true) => OpenCvTerms::RationalThinPrism,
        }
    }

    /// Indices into the twelve coefficients, in OpenCV's order.
    fn indices(self) -> &'static [usize] {
        match self {
            OpenCvTerms::Standard => &[0, 1, 2, 3, 4],
            OpenCvTerms::Rational => &[0, 1, 2, 3, 4, 5, 6, 7],
            OpenCvTerms::ThinPrism => &[0, 1, 2, 3, 4, 8, 9, 10, 11],
            OpenCvTerms::RationalThinPrism => &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
        }
    }

    pub fn names(self) -> &'static [&'static str] {
        match self {
            OpenCvTerms::Standard => &["k1", "k2", "p1", "p2", "k3"],
            OpenCvTerms::Rational => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"],
            OpenCvTerms::ThinPrism => &["k1", "k2", "p1", "p2", "k3", "s1", "s2", "s3", "s4"],
            OpenCvTerms::RationalThinPrism => &ALL,
        }
    }

    /// The groups of optional terms the model has beyond OpenCV's default five.
    pub fn optional_groups(self) -> Vec<(&'static str, &'static [&'static str])> {
        let mut g = vec![];
        if self.rational() {
            g.push(("rational", &["k4", "k5", "k6"][..]));
        }
        if self.thin_prism() {
            g.push(("thin prism", &["s1", "s2", "s3", "s4"][..]));
        }
        g
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpenCv {
    #[serde(default)]
    pub k1: f64,
    #[serde(default)]
    pub k2: f64,
    #[serde(default)]
    pub p1: f64,
    #[serde(default)]
    pub p2: f64,
    #[serde(default)]
    pub k3: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub k4: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub k5: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub k6: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub s1: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub s2: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub s3: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub s4: f64,
    /// The terms the model has (and a calibration frees); files carry it as the model's name.
    #[serde(skip)]
    pub terms: OpenCvTerms,
}

impl OpenCv {
    /// A zero model with these terms.
    pub fn with_terms(terms: OpenCvTerms) -> Self {
        OpenCv {
            terms,
            ..OpenCv::default()
        }
    }

    /// All twelve coefficients in OpenCV's order (k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4).
    pub fn coefficients(&self) -> [f64; 12] {
        [
            self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6, self.s1,
            self.s2, self.s3, self.s4,
        ]
    }

    /// Sets all twelve coefficients (OpenCV's order); `terms` is kept.
    pub fn set_coefficients(&mut self, c: [f64; 12]) {
        [
            self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6, self.s1,
            self.s2, self.s3, self.s4,
        ] = c;
    }

    /// `terms`, widened to hold every non-zero coefficient.
    pub fn effective_terms(&self) -> OpenCvTerms {
        let rational =
            self.terms.rational() || [self.k4, self.k5, self.k6].iter().any(|v| *v != 0.0);
        let prism = self.terms.thin_prism()
            || [self.s1, self.s2, self.s3, self.s4]
                .iter()
                .any(|v| *v != 0.0);
        OpenCvTerms::of(rational, prism)
    }

    /// All twelve coefficients' derivatives of the value at `q` (OpenCV's order).
    fn d_all(&self, q: [f64; 2]) -> [[f64; 2]; 12] {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        let num = 1.0 + self.k1 * r2 + self.k2 * r4 + self.k3 * r6;
        let den = 1.0 + self.k4 * r2 + self.k5 * r4 + self.k6 * r6;
        // d s / d k_i: r^(2i) / den for k1..k3, -num r^(2i) / den^2 for k4..k6
        let dk = |r: f64| [x * r / den, y * r / den];
        let dq = |r: f64| [-x * num * r / (den * den), -y * num * r / (den * den)];
        [
            dk(r2),
            dk(r4),
            [2.0 * x * y, r2 + 2.0 * y * y],
            [r2 + 2.0 * x * x, 2.0 * x * y],
            dk(r6),
            dq(r2),
            dq(r4),
            dq(r6),
            [r2, 0.0],
            [r4, 0.0],
            [0.0, r2],
            [0.0, r4],
        ]
    }
}

impl DistortionModel for OpenCv {
    fn names(&self) -> &'static [&'static str] {
        self.effective_terms().names()
    }

    fn params(&self) -> Vec<f64> {
        let c = self.coefficients();
        self.effective_terms()
            .indices()
            .iter()
            .map(|&i| c[i])
            .collect()
    }

    fn set_params(&mut self, v: &[f64]) {
        let mut c = self.coefficients();
        for (k, &i) in self.effective_terms().indices().iter().enumerate() {
            c[i] = v.get(k).copied().unwrap_or(0.0);
        }
        self.set_coefficients(c);
    }

    fn direction(&self) -> Direction {
        Direction::ObservedFromIdeal
    }

    /// k1..k6 are radial; the tangential p1, p2 and the thin prism's s1..s4 are not.
    fn is_radial(&self) -> bool {
        [self.p1, self.p2, self.s1, self.s2, self.s3, self.s4]
            .iter()
            .all(|v| *v == 0.0)
    }

    #[inline]
    fn value(&self, q: [f64; 2]) -> [f64; 2] {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let s = (1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3)))
            / (1.0 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6)));
        let (p1, p2) = (self.p1, self.p2);
        [
            x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (self.s1 + r2 * self.s2),
            y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (self.s3 + r2 * self.s4),
        ]
    }

    fn value_d_point(&self, q: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        let num = 1.0 + self.k1 * r2 + self.k2 * r4 + self.k3 * r6;
        let den = 1.0 + self.k4 * r2 + self.k5 * r4 + self.k6 * r6;
        let s = num / den;
        let dnum = self.k1 + 2.0 * self.k2 * r2 + 3.0 * self.k3 * r4;
        let dden = self.k4 + 2.0 * self.k5 * r2 + 3.0 * self.k6 * r4;
        let ds = (dnum * den - num * dden) / (den * den);
        let (p1, p2) = (self.p1, self.p2);
        // Thin prism: d(s1 r^2 + s2 r^4)/dr^2 and the same for s3, s4.
        let (tx, ty) = (self.s1 + 2.0 * self.s2 * r2, self.s3 + 2.0 * self.s4 * r2);
        let value = [
            x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + r2 * (self.s1 + r2 * self.s2),
            y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + r2 * (self.s3 + r2 * self.s4),
        ];
        let d_point = [
            [
                s + x * ds * 2.0 * x + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * tx,
                x * ds * 2.0 * y + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * tx,
            ],
            [
                y * ds * 2.0 * x + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * ty,
                s + y * ds * 2.0 * y + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * ty,
            ],
        ];
        (value, d_point)
    }

    fn closed_into(&self, q: [f64; 2], d_params: &mut [[f64; 2]]) -> ([f64; 2], [[f64; 2]; 2]) {
        let all = self.d_all(q);
        for (out, &i) in d_params.iter_mut().zip(self.effective_terms().indices()) {
            *out = all[i];
        }
        self.value_d_point(q)
    }

    fn closed(&self, q: [f64; 2]) -> ClosedForm {
        let (value, d_point) = self.value_d_point(q);
        let all = self.d_all(q);
        let d_params = self
            .effective_terms()
            .indices()
            .iter()
            .map(|&i| all[i])
            .collect();
        ClosedForm {
            value,
            d_point,
            d_params,
        }
    }
}
