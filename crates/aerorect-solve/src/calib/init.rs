//! Starting values: Zhang's closed form for planar targets, the DLT for 3-D fields.

use super::CalibrationError;
use crate::fit_homography;
use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

/// Intrinsics as a matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]].
pub(crate) type K = Matrix3<f64>;

/// One planar view: the points in plane coordinates and their pixels.
pub(crate) type PlaneView = (Vec<[f64; 2]>, Vec<[f64; 2]>);

/// A pose: rotation vector and translation (X_c = R X + t).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pose {
    pub w: Vector3<f64>,
    pub t: Vector3<f64>,
}

fn init_err(m: impl ToString) -> CalibrationError {
    CalibrationError::Initialisation(m.to_string())
}

/// The right singular vector of the smallest singular value of `a` (rows padded to columns).
fn null_vector(mut a: DMatrix<f64>) -> Option<Vec<f64>> {
    let n = a.ncols();
    if a.nrows() < n {
        a = a.resize_vertically(n, 0.0);
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t?;
    let (k, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    Some(v_t.row(k).iter().copied().collect())
}

/// The rotation nearest to `m` (SVD), as a proper rotation.
fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (u, v_t) = (
        svd.u.unwrap_or_else(Matrix3::identity),
        svd.v_t.unwrap_or_else(Matrix3::identity),
    );
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        r = -r;
    }
    Rotation3::from_matrix_unchecked(r)
}

/// Zhang (2000): intrinsics (zero skew) from the homographies plane -> image of several views,
/// then each view's pose. Falls back to the principal point at `centre` and the focal lengths
/// alone when the full closed form is not positive definite.
pub(crate) fn zhang(
    views: &[PlaneView],
    centre: [f64; 2],
) -> Result<(K, Vec<Pose>), CalibrationError> {
    let hs: Vec<Matrix3<f64>> = views
        .iter()
        .map(|(plane, px)| {
            fit_homography(plane, px)
                .map(|h| *h.matrix())
                .map_err(init_err)
        })
        .collect::<Result<_, _>>()?;
    let k = zhang_intrinsics(&hs)
        .or_else(|| focal_only(&hs, centre))
        .ok_or_else(|| init_err("no positive focal length fits the homographies"))?;
    let kinv = k
        .try_inverse()
        .ok_or_else(|| init_err("singular intrinsics"))?;
    let poses = hs.iter().map(|h| pose_from_homography(&kinv, h)).collect();
    Ok((k, poses))
}

fn v_ij(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 6] {
    let (a, b) = (h.column(i), h.column(j));
    [
        a[0] * b[0],
        a[0] * b[1] + a[1] * b[0],
        a[1] * b[1],
        a[2] * b[0] + a[0] * b[2],
        a[2] * b[1] + a[1] * b[2],
        a[2] * b[2],
    ]
}

fn zhang_intrinsics(hs: &[Matrix3<f64>]) -> Option<K> {
    let mut rows: Vec<[f64; 6]> = vec![];
    for h in hs {
        // Condition each homography: scale so that |h| = 1.
        let h = h / h.norm();
        let (v12, v11, v22) = (v_ij(&h, 0, 1), v_ij(&h, 0, 0), v_ij(&h, 1, 1));
        rows.push(v12);
        rows.push(std::array::from_fn(|k| v11[k] - v22[k]));
    }
    let scale = rows
        .iter()
        .flat_map(|r| r.iter())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    rows.push([0.0, scale, 0.0, 0.0, 0.0, 0.0]); // zero skew
    let a = DMatrix::from_row_iterator(rows.len(), 6, rows.iter().flat_map(|r| r.iter().copied()));
    let mut b = null_vector(a)?;
    if b[0] < 0.0 {
        b.iter_mut().for_each(|v| *v = -*v);
    }
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let d = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / d;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / d).sqrt();
    let u0 = -b13 * alpha * alpha / lambda;
    let k = Matrix3::new(alpha, 0.0, u0, 0.0, beta, v0, 0.0, 0.0, 1.0);
    k.iter()
        .all(|v| v.is_finite())
        .then_some(k)
        .filter(|k| k[(0, 0)] > 0.0 && k[(1, 1)] > 0.0)
}

/// With the principal point at `c`: h1' K'^-2 h2' = 0 and |K'^-1 h1'| = |K'^-1 h2'| are linear
/// in (1/fx^2, 1/fy^2) (OpenCV's start).
fn focal_only(hs: &[Matrix3<f64>], c: [f64; 2]) -> Option<K> {
    let shift = Matrix3::new(1.0, 0.0, -c[0], 0.0, 1.0, -c[1], 0.0, 0.0, 1.0);
    let (mut a, mut rhs) = (vec![], vec![]);
    for h in hs {
        let h = shift * h;
        let (h1, h2) = (h.column(0), h.column(1));
        a.push([h1[0] * h2[0], h1[1] * h2[1]]);
        rhs.push(-h1[2] * h2[2]);
        a.push([h1[0] * h1[0] - h2[0] * h2[0], h1[1] * h1[1] - h2[1] * h2[1]]);
        rhs.push(-(h1[2] * h1[2] - h2[2] * h2[2]));
    }
    let am = DMatrix::from_row_iterator(a.len(), 2, a.iter().flat_map(|r| r.iter().copied()));
    let x = am
        .svd(true, true)
        .solve(&nalgebra::DVector::from_vec(rhs), 1e-12)
        .ok()?;
    let (fx, fy) = ((1.0 / x[0]).sqrt(), (1.0 / x[1]).sqrt());
    (fx.is_finite() && fy.is_finite())
        .then(|| Matrix3::new(fx, 0.0, c[0], 0.0, fy, c[1], 0.0, 0.0, 1.0))
}

fn pose_from_homography(kinv: &Matrix3<f64>, h: &Matrix3<f64>) -> Pose {
    let (a1, a2, a3) = (kinv * h.column(0), kinv * h.column(1), kinv * h.column(2));
    let mut lambda = 1.0 / a1.norm();
    if (lambda * a3).z < 0.0 {
        lambda = -lambda; // the target is in front of the camera
    }
    let (r1, r2) = (lambda * a1, lambda * a2);
    let m = Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]);
    Pose {
        w: nearest_rotation(&m).scaled_axis(),
        t: lambda * a3,
    }
}

/// The DLT of a 3-D field in one image: P = K [R | t] from >= 6 non-coplanar points.
pub(crate) fn dlt(world: &[[f64; 3]], px: &[[f64; 2]]) -> Result<(K, Pose), CalibrationError> {
    let n = world.len() as f64;
    let c: Vector3<f64> = world
        .iter()
        .map(|p| Vector3::new(p[0], p[1], p[2]))
        .sum::<Vector3<f64>>()
        / n;
    let sw = world
        .iter()
        .map(|p| (Vector3::new(p[0], p[1], p[2]) - c).norm())
        .sum::<f64>()
        / n;
    let cu = [
        px.iter().map(|p| p[0]).sum::<f64>() / n,
        px.iter().map(|p| p[1]).sum::<f64>() / n,
    ];
    let su = px
        .iter()
        .map(|p| (p[0] - cu[0]).hypot(p[1] - cu[1]))
        .sum::<f64>()
        / n;
    let (kw, ku) = (3f64.sqrt() / sw, 2f64.sqrt() / su);
    let mut rows = vec![];
    for (w, p) in world.iter().zip(px) {
        let x = (Vector3::new(w[0], w[1], w[2]) - c) * kw;
        let (u, v) = ((p[0] - cu[0]) * ku, (p[1] - cu[1]) * ku);
        rows.push([
            x[0],
            x[1],
            x[2],
            1.0,
            0.0,
            0.0,
            0.0,
            0.0,
            -u * x[0],
            -u * x[1],
            -u * x[2],
            -u,
        ]);
        rows.push([
            0.0,
            0.0,
            0.0,
            0.0,
            x[0],
            x[1],
            x[2],
            1.0,
            -v * x[0],
            -v * x[1],
            -v * x[2],
            -v,
        ]);
    }
    let a = DMatrix::from_row_iterator(rows.len(), 12, rows.iter().flat_map(|r| r.iter().copied()));
    let p = null_vector(a).ok_or_else(|| init_err("DLT failed"))?;
    let pn = nalgebra::Matrix3x4::from_row_slice(&p);
    // Undo the normalisations: P = Tu^-1 Pn Tw.
    let tu_inv = Matrix3::new(1.0 / ku, 0.0, cu[0], 0.0, 1.0 / ku, cu[1], 0.0, 0.0, 1.0);
    let mut tw = nalgebra::Matrix4::<f64>::identity() * kw;
    tw[(3, 3)] = 1.0;
    for i in 0..3 {
        tw[(i, 3)] = -kw * c[i];
    }
    let mut pm = tu_inv * pn * tw;
    let mut m: Matrix3<f64> = pm.fixed_view::<3, 3>(0, 0).into();
    if m.determinant() < 0.0 {
        pm = -pm;
        m = -m;
    }
    let (k_scaled, r) = rq(&m);
    let k = k_scaled / k_scaled[(2, 2)];
    let kinv = k_scaled
        .try_inverse()
        .ok_or_else(|| init_err("singular DLT camera"))?;
    let t = kinv * pm.column(3);
    Ok((
        k,
        Pose {
            w: Rotation3::from_matrix_unchecked(r).scaled_axis(),
            t,
        },
    ))
}

/// M = K R with K upper triangular (positive diagonal) and R a rotation (for det M > 0).
fn rq(m: &Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    let p = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let qr = (p * m).transpose().qr();
    let (q, r) = (qr.q(), qr.r());
    let mut k = p * r.transpose() * p;
    let mut rot = p * q.transpose();
    for i in 0..3 {
        if k[(i, i)] < 0.0 {
            for row in 0..3 {
                k[(row, i)] = -k[(row, i)];
            }
            for col in 0..3 {
                rot[(i, col)] = -rot[(i, col)];
            }
        }
    }
    (k, rot)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rq_recovers_an_upper_triangular_times_rotation() {
        let k = Matrix3::new(800.0, 2.0, 320.0, 0.0, 780.0, 240.0, 0.0, 0.0, 1.0);
        let r = *Rotation3::from_scaled_axis(Vector3::new(0.1, -0.2, 0.3)).matrix();
        let (k2, r2) = rq(&(k * r * 3.0));
        let k2 = k2 / k2[(2, 2)];
        assert!((k2 - k).abs().max() < 1e-9 && (r2 - r).abs().max() < 1e-12);
    }
}
