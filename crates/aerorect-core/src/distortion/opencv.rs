//! OpenCV's model, observed from ideal on normalised coordinates:
//! x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//! y_d = y (same ratio) + p1 (r^2 + 2 y^2) + 2 p2 x y
//! Note the tangential order differs from the paper's (OpenCV's p1 multiplies 2xy in x).
//! Parameter order: k1, k2, p1, p2, k3, k4, k5, k6 (OpenCV's distCoeffs order).

use super::{ClosedForm, Direction, DistortionModel};
use serde::{Deserialize, Serialize};

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
    #[serde(default)]
    pub k4: f64,
    #[serde(default)]
    pub k5: f64,
    #[serde(default)]
    pub k6: f64,
}

impl DistortionModel for OpenCv {
    fn names(&self) -> &'static [&'static str] {
        &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]
    }

    fn params(&self) -> Vec<f64> {
        vec![
            self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6,
        ]
    }

    fn set_params(&mut self, v: &[f64]) {
        let g = |i: usize| v.get(i).copied().unwrap_or(0.0);
        (
            self.k1, self.k2, self.p1, self.p2, self.k3, self.k4, self.k5, self.k6,
        ) = (g(0), g(1), g(2), g(3), g(4), g(5), g(6), g(7));
    }

    fn direction(&self) -> Direction {
        Direction::ObservedFromIdeal
    }

    #[inline]
    fn value(&self, q: [f64; 2]) -> [f64; 2] {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let s = (1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3)))
            / (1.0 + r2 * (self.k4 + r2 * (self.k5 + r2 * self.k6)));
        let (p1, p2) = (self.p1, self.p2);
        [
            x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
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
        let value = [
            x * s + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
            y * s + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y,
        ];
        let d_point = [
            [
                s + x * ds * 2.0 * x + 2.0 * p1 * y + 6.0 * p2 * x,
                x * ds * 2.0 * y + 2.0 * p1 * x + 2.0 * p2 * y,
            ],
            [
                y * ds * 2.0 * x + 2.0 * p1 * x + 2.0 * p2 * y,
                s + y * ds * 2.0 * y + 6.0 * p1 * y + 2.0 * p2 * x,
            ],
        ];
        (value, d_point)
    }

    fn closed(&self, q: [f64; 2]) -> ClosedForm {
        let (value, d_point) = self.value_d_point(q);
        let [x, y] = q;
        let r2 = x * x + y * y;
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        let num = 1.0 + self.k1 * r2 + self.k2 * r4 + self.k3 * r6;
        let den = 1.0 + self.k4 * r2 + self.k5 * r4 + self.k6 * r6;
        // d s / d k_i: r^(2i) / den for k1..k3, -num r^(2i) / den^2 for k4..k6
        let dk = |r: f64| [x * r / den, y * r / den];
        let dq = |r: f64| [-x * num * r / (den * den), -y * num * r / (den * den)];
        let d_params = vec![
            dk(r2),
            dk(r4),
            [2.0 * x * y, r2 + 2.0 * y * y],
            [r2 + 2.0 * x * x, 2.0 * x * y],
            dk(r6),
            dq(r2),
            dq(r4),
            dq(r6),
        ];
        ClosedForm {
            value,
            d_point,
            d_params,
        }
    }
}
