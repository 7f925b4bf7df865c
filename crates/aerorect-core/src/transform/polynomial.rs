//! Polynomial plane transforms of one of three orders (bilinear, quadratic, cubic), held in
//! normalised coordinates, with their raw coefficients for reports.

use crate::error::{GeometryError, require_finite, require_positive};
use serde::{Deserialize, Serialize};

/// The polynomial orders of GCP correction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PolyKind {
    /// a0 + a1 u + a2 v + a3 uv (the paper's bilinear polynomial).
    Bilinear,
    /// Full second order: 6 terms.
    Quadratic,
    /// Full third order: 10 terms.
    Cubic,
}

const TERMS: [(i32, i32); 10] = [
    (0, 0),
    (1, 0),
    (0, 1),
    (2, 0),
    (1, 1),
    (0, 2),
    (3, 0),
    (2, 1),
    (1, 2),
    (0, 3),
];

impl PolyKind {
    /// The exponents (of u, of v) of each term, in coefficient order.
    pub fn terms(self) -> &'static [(i32, i32)] {
        const BILINEAR: [(i32, i32); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];
        match self {
            PolyKind::Bilinear => &BILINEAR,
            PolyKind::Quadratic => &TERMS[..6],
            PolyKind::Cubic => &TERMS,
        }
    }

    /// Each term written out: "1", "u", "v", "u^2", "uv", ...
    pub fn term_names(self) -> Vec<String> {
        let power = |name: &str, k: i32| match k {
            0 => String::new(),
            1 => name.to_string(),
            k => format!("{name}^{k}"),
        };
        self.terms()
            .iter()
            .map(|&(i, j)| match (i, j) {
                (0, 0) => "1".to_string(),
                (i, j) => format!("{}{}", power("u", i), power("v", j)),
            })
            .collect()
    }

    pub fn name(self) -> &'static str {
        match self {
            PolyKind::Bilinear => "bilinear",
            PolyKind::Quadratic => "quadratic",
            PolyKind::Cubic => "cubic",
        }
    }
}

/// `b = P(a)`: one polynomial per output coordinate, held in normalised input coordinates
/// p = s (u - cu), q = s (v - cv) for conditioning.
#[derive(Debug, Clone, PartialEq)]
pub struct Polynomial {
    kind: PolyKind,
    pub(super) centre: [f64; 2],
    scale: f64,
    /// Coefficients of the normalised terms for the output's x and y.
    coeffs: [Vec<f64>; 2],
}

impl Polynomial {
    /// A polynomial in normalised coordinates p = scale (u - centre.0), q = scale (v - centre.1).
    pub fn from_normalised(
        kind: PolyKind,
        centre: [f64; 2],
        scale: f64,
        coeffs: [Vec<f64>; 2],
    ) -> Result<Self, GeometryError> {
        require_finite("polynomial centre u", centre[0])?;
        require_finite("polynomial centre v", centre[1])?;
        require_positive("polynomial scale", scale)?;
        let n = kind.terms().len();
        for c in &coeffs {
            if c.len() != n {
                return Err(GeometryError::InvalidParameter {
                    field: "polynomial coefficient count",
                    value: c.len() as f64,
                    reason: "does not match the polynomial's order",
                });
            }
            for &v in c {
                require_finite("polynomial coefficient", v)?;
            }
        }
        Ok(Self {
            kind,
            centre,
            scale,
            coeffs,
        })
    }

    pub fn kind(&self) -> PolyKind {
        self.kind
    }

    /// The normalised coordinates of (u, v).
    #[inline]
    pub fn normalise(&self, u: f64, v: f64) -> [f64; 2] {
        [
            (u - self.centre[0]) * self.scale,
            (v - self.centre[1]) * self.scale,
        ]
    }

    pub fn map(&self, u: f64, v: f64) -> [f64; 2] {
        let [p, q] = self.normalise(u, v);
        let terms = self.kind.terms();
        let mut out = [0.0; 2];
        for (o, c) in out.iter_mut().zip(&self.coeffs) {
            *o = terms
                .iter()
                .zip(c)
                .map(|(&(i, j), a)| a * p.powi(i) * q.powi(j))
                .sum();
        }
        out
    }

    /// For input row v: the coefficients of p^0..p^3 of each output coordinate, so that a
    /// whole row is evaluated by Horner's rule in p alone.
    pub fn along_row(&self, v: f64) -> [[f64; 4]; 2] {
        let q = (v - self.centre[1]) * self.scale;
        let mut out = [[0.0; 4]; 2];
        for (o, c) in out.iter_mut().zip(&self.coeffs) {
            for (&(i, j), a) in self.kind.terms().iter().zip(c) {
                o[i as usize] += a * q.powi(j);
            }
        }
        out
    }

    /// The coefficients in the input's own coordinates (u, v), in `kind.terms()` order:
    /// each normalised term s^(i+j) (u - cu)^i (v - cv)^j expanded binomially. Every order's term
    /// set is closed under this expansion.
    pub fn raw_coefficients(&self) -> [Vec<f64>; 2] {
        let terms = self.kind.terms();
        let binom = |n: i32, k: i32| -> f64 {
            (0..k).fold(1.0, |acc, t| acc * (n - t) as f64 / (t + 1) as f64)
        };
        let mut out = [vec![0.0; terms.len()], vec![0.0; terms.len()]];
        for (o, c) in out.iter_mut().zip(&self.coeffs) {
            for (&(i, j), a) in terms.iter().zip(c) {
                let s = a * self.scale.powi(i + j);
                for ai in 0..=i {
                    for bj in 0..=j {
                        let k = terms
                            .iter()
                            .position(|&t| t == (ai, bj))
                            .unwrap_or_default();
                        o[k] += s
                            * binom(i, ai)
                            * (-self.centre[0]).powi(i - ai)
                            * binom(j, bj)
                            * (-self.centre[1]).powi(j - bj);
                    }
                }
            }
        }
        out
    }
}
