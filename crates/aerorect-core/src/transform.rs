//! Plane transforms fitted to point pairs (ground control points, tie points): polynomials of
//! one of three orders and a piecewise-affine map over a triangulation. Both are `b_from_a`:
//! the fitting code in aerorect-solve decides which frame is `a`.

use crate::error::{GeometryError, require_finite, require_positive};
use crate::{Homography, Mat3, Vec3};
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
    centre: [f64; 2],
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

/// Any of the fitted plane transforms, `b_from_a`.
#[derive(Debug, Clone)]
pub enum PlaneTransform {
    Polynomial(Polynomial),
    Projective(Homography),
    Piecewise(PiecewiseAffine),
}

impl PlaneTransform {
    /// The image of (u, v); `None` beyond a homography's horizon.
    pub fn map(&self, u: f64, v: f64) -> Option<[f64; 2]> {
        match self {
            PlaneTransform::Polynomial(p) => Some(p.map(u, v)),
            PlaneTransform::Projective(h) => h.map(u, v),
            PlaneTransform::Piecewise(p) => p.map(u, v),
        }
    }

    /// The transform of (u + du, v + dv): the same map read from a grid whose origin is at
    /// (du, dv).
    pub fn after_translation(&self, du: f64, dv: f64) -> PlaneTransform {
        match self {
            PlaneTransform::Polynomial(p) => {
                let mut q = p.clone();
                q.centre = [p.centre[0] - du, p.centre[1] - dv];
                PlaneTransform::Polynomial(q)
            }
            PlaneTransform::Projective(h) => {
                PlaneTransform::Projective(h.after(&Homography::translation(du, dv)))
            }
            PlaneTransform::Piecewise(p) => PlaneTransform::Piecewise(p.after_translation(du, dv)),
        }
    }
}

/// A piecewise-affine map over a triangulation of control points in the `a` frame: exact at
/// every vertex, affine inside each triangle, and a homography outside the triangulation.
#[derive(Debug, Clone)]
pub struct PiecewiseAffine {
    vertices: Vec<[f64; 2]>,
    triangles: Vec<[usize; 3]>,
    /// Per triangle: b = (m0 + m1 u + m2 v, m3 + m4 u + m5 v).
    affine: Vec<[f64; 6]>,
    outside: Homography,
    index: CellIndex,
}

impl PiecewiseAffine {
    /// `from[k] -> to[k]` at every vertex; `triangles` index into them (counter- or clockwise).
    /// Refuses a degenerate (zero-area) triangle or an index out of range.
    pub fn new(
        from: &[[f64; 2]],
        to: &[[f64; 2]],
        triangles: Vec<[usize; 3]>,
        outside: Homography,
    ) -> Result<Self, GeometryError> {
        let mut affine = Vec::with_capacity(triangles.len());
        for t in &triangles {
            if t.iter().any(|&k| k >= from.len() || k >= to.len()) {
                return Err(GeometryError::InvalidParameter {
                    field: "triangle vertex index",
                    value: t.iter().copied().max().unwrap_or_default() as f64,
                    reason: "beyond the control points",
                });
            }
            let m = Mat3::from_fn(|r, c| match c {
                0 => 1.0,
                c => from[t[r]][c - 1],
            });
            let inv = m.try_inverse().ok_or(GeometryError::Singular)?;
            let bx = inv * Vec3::new(to[t[0]][0], to[t[1]][0], to[t[2]][0]);
            let by = inv * Vec3::new(to[t[0]][1], to[t[1]][1], to[t[2]][1]);
            affine.push([bx[0], bx[1], bx[2], by[0], by[1], by[2]]);
        }
        let index = CellIndex::new(from, &triangles);
        Ok(Self {
            vertices: from.to_vec(),
            triangles,
            affine,
            outside,
            index,
        })
    }

    /// The map of (u + du, v + dv).
    pub fn after_translation(&self, du: f64, dv: f64) -> Self {
        let vertices: Vec<[f64; 2]> = self
            .vertices
            .iter()
            .map(|p| [p[0] - du, p[1] - dv])
            .collect();
        let affine = self
            .affine
            .iter()
            .map(|m| {
                [
                    m[0] + m[1] * du + m[2] * dv,
                    m[1],
                    m[2],
                    m[3] + m[4] * du + m[5] * dv,
                    m[4],
                    m[5],
                ]
            })
            .collect();
        let index = CellIndex::new(&vertices, &self.triangles);
        Self {
            vertices,
            triangles: self.triangles.clone(),
            affine,
            outside: self.outside.after(&Homography::translation(du, dv)),
            index,
        }
    }

    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// The triangle that holds (u, v), if any.
    pub fn locate(&self, u: f64, v: f64) -> Option<usize> {
        self.index
            .candidates(u, v)
            .iter()
            .map(|&t| t as usize)
            .find(|&t| self.contains(t, u, v))
    }

    fn contains(&self, t: usize, u: f64, v: f64) -> bool {
        let [a, b, c] = self.triangles[t].map(|k| self.vertices[k]);
        let side =
            |p: [f64; 2], q: [f64; 2]| (q[0] - p[0]) * (v - p[1]) - (q[1] - p[1]) * (u - p[0]);
        let (d1, d2, d3) = (side(a, b), side(b, c), side(c, a));
        let tol = 1e-9;
        (d1 >= -tol && d2 >= -tol && d3 >= -tol) || (d1 <= tol && d2 <= tol && d3 <= tol)
    }

    /// The image of (u, v); outside the triangulation, the homography's (None beyond its horizon).
    pub fn map(&self, u: f64, v: f64) -> Option<[f64; 2]> {
        match self.locate(u, v) {
            Some(t) => {
                let m = &self.affine[t];
                Some([m[0] + m[1] * u + m[2] * v, m[3] + m[4] * u + m[5] * v])
            }
            None => self.outside.map(u, v),
        }
    }
}

/// A uniform grid over the vertices' bounding box; each cell lists the triangles whose bounding
/// boxes touch it.
#[derive(Debug, Clone)]
struct CellIndex {
    origin: [f64; 2],
    cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

impl CellIndex {
    fn new(vertices: &[[f64; 2]], triangles: &[[usize; 3]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in vertices {
            for d in 0..2 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let n = (triangles.len() as f64).sqrt().ceil().clamp(1.0, 256.0);
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
        let cell = extent / n;
        let nx = (((hi[0] - lo[0]) / cell).floor() as usize + 1).max(1);
        let ny = (((hi[1] - lo[1]) / cell).floor() as usize + 1).max(1);
        let mut cells = vec![Vec::new(); nx * ny];
        if vertices.is_empty() {
            return Self {
                origin: [0.0; 2],
                cell: 1.0,
                nx: 1,
                ny: 1,
                cells: vec![Vec::new()],
            };
        }
        for (t, tri) in triangles.iter().enumerate() {
            let ps = tri.map(|k| vertices[k]);
            let cx = |x: f64| (((x - lo[0]) / cell).floor().max(0.0) as usize).min(nx - 1);
            let cy = |y: f64| (((y - lo[1]) / cell).floor().max(0.0) as usize).min(ny - 1);
            let (x0, x1) = (
                ps.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
                ps.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
            );
            let (y0, y1) = (
                ps.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min),
                ps.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max),
            );
            for gy in cy(y0)..=cy(y1) {
                for gx in cx(x0)..=cx(x1) {
                    cells[gy * nx + gx].push(t as u32);
                }
            }
        }
        Self {
            origin: lo,
            cell,
            nx,
            ny,
            cells,
        }
    }

    fn candidates(&self, u: f64, v: f64) -> &[u32] {
        let (gx, gy) = (
            ((u - self.origin[0]) / self.cell).floor(),
            ((v - self.origin[1]) / self.cell).floor(),
        );
        if !(gx >= 0.0 && gy >= 0.0 && gx < self.nx as f64 && gy < self.ny as f64) {
            return &[];
        }
        &self.cells[gy as usize * self.nx + gx as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample_poly(kind: PolyKind) -> Polynomial {
        let n = kind.terms().len();
        let cx: Vec<f64> = (0..n).map(|k| 3.0 - 0.7 * k as f64).collect();
        let cy: Vec<f64> = (0..n).map(|k| -1.0 + 0.45 * (k * k) as f64).collect();
        Polynomial::from_normalised(kind, [512.0, 300.0], 1.0 / 400.0, [cx, cy]).expect("valid")
    }

    /// The raw (unnormalised) coefficients evaluate to the same values as the normalised form.
    #[test]
    fn raw_coefficients_equal_the_normalised_polynomial() {
        for kind in [PolyKind::Bilinear, PolyKind::Quadratic, PolyKind::Cubic] {
            let p = sample_poly(kind);
            let raw = p.raw_coefficients();
            for (u, v) in [(0.0, 0.0), (100.0, 700.0), (1023.0, 5.5), (-40.0, 250.0)] {
                let want = p.map(u, v);
                for (d, c) in raw.iter().enumerate() {
                    let got: f64 = kind
                        .terms()
                        .iter()
                        .zip(c)
                        .map(|(&(i, j), a)| a * u.powi(i) * v.powi(j))
                        .sum();
                    assert!(
                        (got - want[d]).abs() < 1e-9 * want[d].abs().max(1.0),
                        "{kind:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn along_row_matches_map() {
        let p = sample_poly(PolyKind::Cubic);
        let v = 77.25;
        let rows = p.along_row(v);
        for u in [0.0, 10.0, 999.0] {
            let [x, _] = p.normalise(u, v);
            let want = p.map(u, v);
            for d in 0..2 {
                let c = rows[d];
                let got = ((c[3] * x + c[2]) * x + c[1]) * x + c[0];
                assert!((got - want[d]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn term_names_follow_the_exponents() {
        assert_eq!(PolyKind::Bilinear.term_names(), ["1", "u", "v", "uv"]);
        assert_eq!(
            PolyKind::Cubic.term_names()[5..],
            ["v^2", "u^3", "u^2v", "uv^2", "v^3"]
        );
    }

    /// Affine pieces reproduce the vertices and are continuous across a shared edge.
    #[test]
    fn piecewise_is_exact_at_vertices_and_continuous() {
        let from = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let to = [[1.0, 2.0], [12.0, 1.0], [13.0, 14.0], [0.0, 11.0]];
        let pw = PiecewiseAffine::new(
            &from,
            &to,
            vec![[0, 1, 2], [0, 2, 3]],
            Homography::identity(),
        )
        .expect("valid");
        for (f, t) in from.iter().zip(&to) {
            let m = pw.map(f[0], f[1]).expect("inside");
            assert!((m[0] - t[0]).abs() < 1e-9 && (m[1] - t[1]).abs() < 1e-9);
        }
        // On the diagonal both pieces give the linear interpolation of its end points.
        let m = pw.map(4.0, 4.0).expect("inside");
        assert!(
            (m[0] - (1.0 + 0.4 * 12.0)).abs() < 1e-9 && (m[1] - (2.0 + 0.4 * 12.0)).abs() < 1e-9
        );
        // Outside: the homography (identity here).
        assert_eq!(pw.map(20.0, 5.0), Some([20.0, 5.0]));
    }

    #[test]
    fn after_translation_reads_the_same_map_from_a_shifted_grid() {
        let from = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let to = [[1.0, 2.0], [12.0, 1.0], [13.0, 14.0], [0.0, 11.0]];
        let h =
            Homography::new(Mat3::new(1.0, 0.1, 2.0, 0.0, 0.9, 1.0, 1e-3, 0.0, 1.0)).expect("h");
        let pw = PiecewiseAffine::new(&from, &to, vec![[0, 1, 2], [0, 2, 3]], h).expect("ok");
        let all = [
            PlaneTransform::Polynomial(sample_poly(PolyKind::Cubic)),
            PlaneTransform::Projective(h),
            PlaneTransform::Piecewise(pw),
        ];
        for t in &all {
            let s = t.after_translation(-3.0, 7.0);
            for (u, v) in [(5.0, 1.0), (9.0, -2.0), (30.0, 4.0), (2.5, 2.5)] {
                let (a, b) = (s.map(u, v).expect("a"), t.map(u - 3.0, v + 7.0).expect("b"));
                assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn degenerate_triangle_is_refused() {
        let from = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]];
        let r = PiecewiseAffine::new(&from, &from, vec![[0, 1, 2]], Homography::identity());
        assert!(r.is_err());
    }
}
