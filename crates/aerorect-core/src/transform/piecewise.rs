//! The piecewise-affine plane transform over a triangulation, and the uniform grid that finds
//! the triangle under a point.

use crate::error::GeometryError;
use crate::{Homography, Mat3, Vec3};

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
