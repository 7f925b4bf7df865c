//! Least-squares plane transforms from point pairs (ground control points, tie points):
//! polynomials of three orders, the projective transform (normalised DLT refined by
//! Gauss-Newton on the geometric error), and the piecewise-affine map over a Delaunay
//! triangulation.

use crate::{SolveError, fit_homography, normaliser, positive_at_centroid};
use aerorect_core::{Homography, Mat3, PiecewiseAffine, PlaneTransform, PolyKind, Polynomial};
use nalgebra::{DMatrix, SMatrix, SVector};

/// What a GCP correction fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GcpModel {
    Polynomial(PolyKind),
    Projective,
}

impl GcpModel {
    /// Parses "bilinear", "quadratic", "cubic" or "projective".
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "bilinear" => GcpModel::Polynomial(PolyKind::Bilinear),
            "quadratic" => GcpModel::Polynomial(PolyKind::Quadratic),
            "cubic" => GcpModel::Polynomial(PolyKind::Cubic),
            "projective" => GcpModel::Projective,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            GcpModel::Polynomial(k) => k.name(),
            GcpModel::Projective => "projective",
        }
    }

    /// Free parameters per fit.
    pub fn parameters(self) -> usize {
        match self {
            GcpModel::Polynomial(k) => 2 * k.terms().len(),
            GcpModel::Projective => 8,
        }
    }
}

/// Fits `to_from_from` to the pairs by least squares.
pub fn fit_transform(
    model: GcpModel,
    from: &[[f64; 2]],
    to: &[[f64; 2]],
) -> Result<PlaneTransform, SolveError> {
    Ok(match model {
        GcpModel::Polynomial(kind) => PlaneTransform::Polynomial(fit_polynomial(kind, from, to)?),
        GcpModel::Projective => PlaneTransform::Projective(fit_projective(from, to)?),
    })
}

fn check_pairs(from: &[[f64; 2]], to: &[[f64; 2]], need: usize) -> Result<usize, SolveError> {
    let n = from.len().min(to.len());
    if n < need {
        return Err(SolveError::TooFewPoints { got: n, need });
    }
    if let Some(index) = (0..n).find(|&i| from[i].iter().chain(&to[i]).any(|v| !v.is_finite())) {
        return Err(SolveError::NotFinite { index });
    }
    Ok(n)
}

/// The least-squares polynomial `to = P(from)` (one polynomial per coordinate), solved by SVD in
/// coordinates centred on the points and scaled to unit spread. Refuses fewer points than terms
/// and configurations that do not fix every term (for example collinear points).
pub fn fit_polynomial(
    kind: PolyKind,
    from: &[[f64; 2]],
    to: &[[f64; 2]],
) -> Result<Polynomial, SolveError> {
    let terms = kind.terms();
    let n = check_pairs(from, to, terms.len())?;
    let centre = [
        from[..n].iter().map(|p| p[0]).sum::<f64>() / n as f64,
        from[..n].iter().map(|p| p[1]).sum::<f64>() / n as f64,
    ];
    let spread = from[..n]
        .iter()
        .map(|p| (p[0] - centre[0]).abs().max((p[1] - centre[1]).abs()))
        .fold(0.0, f64::max);
    if spread <= 0.0 {
        return Err(SolveError::Degenerate);
    }
    let scale = 1.0 / spread;
    let a = DMatrix::from_fn(n, terms.len(), |r, c| {
        let (i, j) = terms[c];
        let (p, q) = (
            (from[r][0] - centre[0]) * scale,
            (from[r][1] - centre[1]) * scale,
        );
        p.powi(i) * q.powi(j)
    });
    let b = DMatrix::from_fn(n, 2, |r, c| to[r][c]);
    let svd = a.svd(true, true);
    let s = &svd.singular_values;
    if s.min() <= 1e-9 * s.max() {
        return Err(SolveError::Degenerate);
    }
    let x = svd.solve(&b, 0.0).map_err(|_| SolveError::Degenerate)?;
    let coeffs = [
        x.column(0).iter().copied().collect(),
        x.column(1).iter().copied().collect(),
    ];
    Polynomial::from_normalised(kind, centre, scale, coeffs).map_err(|_| SolveError::Degenerate)
}

/// The projective transform minimising the sum of squared distances in `to` (the geometric
/// least-squares fit): normalised DLT, then Gauss-Newton with h33 = 1 in normalised coordinates.
pub fn fit_projective(from: &[[f64; 2]], to: &[[f64; 2]]) -> Result<Homography, SolveError> {
    let n = check_pairs(from, to, 4)?;
    let dlt = fit_homography(&from[..n], &to[..n])?;
    let (ta, tb) = (normaliser(&from[..n]), normaliser(&to[..n]));
    let tb_inv = tb.try_inverse().ok_or(SolveError::Degenerate)?;
    let ta_inv = ta.try_inverse().ok_or(SolveError::Degenerate)?;
    let hn = tb * dlt.matrix() * ta_inv;
    if hn[(2, 2)].abs() < 1e-12 {
        return Ok(dlt);
    }
    let apply = |m: &Mat3, p: [f64; 2]| {
        let q = m * nalgebra::Vector3::new(p[0], p[1], 1.0);
        [q.x / q.z, q.y / q.z]
    };
    let xs: Vec<[f64; 2]> = from[..n].iter().map(|&p| apply(&ta, p)).collect();
    let ys: Vec<[f64; 2]> = to[..n].iter().map(|&p| apply(&tb, p)).collect();
    let mut h: SVector<f64, 8> = SVector::from_fn(|k, _| hn[(k / 3, k % 3)] / hn[(2, 2)]);
    for _ in 0..30 {
        let mut jtj = SMatrix::<f64, 8, 8>::zeros();
        let mut jtr = SVector::<f64, 8>::zeros();
        for (x, y) in xs.iter().zip(&ys) {
            let w = h[6] * x[0] + h[7] * x[1] + 1.0;
            let u = (h[0] * x[0] + h[1] * x[1] + h[2]) / w;
            let v = (h[3] * x[0] + h[4] * x[1] + h[5]) / w;
            let ju = SVector::<f64, 8>::from_column_slice(&[
                x[0] / w,
                x[1] / w,
                1.0 / w,
                0.0,
                0.0,
                0.0,
                -u * x[0] / w,
                -u * x[1] / w,
            ]);
            let jv = SVector::<f64, 8>::from_column_slice(&[
                0.0,
                0.0,
                0.0,
                x[0] / w,
                x[1] / w,
                1.0 / w,
                -v * x[0] / w,
                -v * x[1] / w,
            ]);
            jtj += ju * ju.transpose() + jv * jv.transpose();
            jtr += ju * (u - y[0]) + jv * (v - y[1]);
        }
        let Some(step) = jtj.cholesky().map(|c| c.solve(&jtr)) else {
            break;
        };
        h -= step;
        if step.norm() < 1e-13 * h.norm() {
            break;
        }
    }
    let m = Mat3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0);
    positive_at_centroid(tb_inv * m * ta, &from[..n])
}

/// The piecewise-affine map through every pair, over the Delaunay triangulation of `from`;
/// outside the triangulation, the least-squares projective transform of all pairs.
pub fn fit_piecewise(from: &[[f64; 2]], to: &[[f64; 2]]) -> Result<PiecewiseAffine, SolveError> {
    let n = check_pairs(from, to, 4)?;
    let outside = fit_projective(&from[..n], &to[..n])?;
    let points: Vec<delaunator::Point> = from[..n]
        .iter()
        .map(|p| delaunator::Point { x: p[0], y: p[1] })
        .collect();
    let tri = delaunator::triangulate(&points);
    if tri.triangles.is_empty() {
        return Err(SolveError::Degenerate);
    }
    let triangles = tri
        .triangles
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    PiecewiseAffine::new(&from[..n], &to[..n], triangles, outside)
        .map_err(|_| SolveError::Degenerate)
}

/// Residuals `transform(from) - to` per pair; `None` for a pair mapped beyond the horizon.
pub fn residuals(
    transform: &PlaneTransform,
    from: &[[f64; 2]],
    to: &[[f64; 2]],
) -> Vec<Option<[f64; 2]>> {
    from.iter()
        .zip(to)
        .map(|(f, t)| {
            transform
                .map(f[0], f[1])
                .map(|m| [m[0] - t[0], m[1] - t[1]])
        })
        .collect()
}

/// sqrt(mean(du^2 + dv^2)) of residuals (pairs beyond the horizon excluded).
pub fn rms(res: &[Option<[f64; 2]>]) -> f64 {
    let (s, n) = res.iter().flatten().fold((0.0, 0usize), |(s, n), r| {
        (s + r[0] * r[0] + r[1] * r[1], n + 1)
    });
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}
