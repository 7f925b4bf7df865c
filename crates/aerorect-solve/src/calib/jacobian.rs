//! One control point's residual and its analytic derivatives with respect to the intrinsics,
//! the lens coefficients and the view's pose (rotation vector w and translation t), by the
//! chain rule through the lens model's closed form ([`DistortionModel::closed`]: its point and
//! parameter Jacobians).
//!
//! Residuals (pixels), with A = [[fx, skew], [0, fy]], p = the projection of X_c = R(w) X + t:
//! - observed from ideal (OpenCV's model): r = A d(p) + c - pixel;
//! - ideal from observed (the paper's models): r = A (p - m(q)), where q is the measured pixel
//!   normalised by the same intrinsics (so r depends on them through q too).
//!
//! The rotation's derivative: R(w + dw) X = R X - [R X]x R J_r(w) dw to first order, with
//! J_r the right Jacobian of SO(3).

use aerorect_core::Intrinsics;
use aerorect_core::distortion::{Direction, DistortionModel};
use nalgebra::{Matrix2, Matrix2x3, Matrix2x6, Matrix3, Rotation3, Vector2, Vector3};

/// The intrinsics of the parameter vector's first five entries (fx, fy, cx, cy, skew), unchecked:
/// an iterate may wander where `Intrinsics::new` would refuse it.
pub(crate) fn intrinsics_from_slice(x: &[f64]) -> Intrinsics {
    Intrinsics {
        fx: x[0],
        fy: x[1],
        cx: x[2],
        cy: x[3],
        skew: x[4],
    }
}

/// [[fx, skew], [0, fy]]: d pixel / d normalised point.
fn pixel_from_normalized_jacobian(k: &Intrinsics) -> Matrix2<f64> {
    Matrix2::new(k.fx, k.skew, 0.0, k.fy)
}

/// A view's pose for one evaluation: X_c = R X + t, and R J_r(w).
pub(crate) struct PoseFrame {
    rot: Matrix3<f64>,
    t: Vector3<f64>,
    rot_jr: Matrix3<f64>,
}

impl PoseFrame {
    /// From a rotation vector and a translation (the parameter vector's six pose entries).
    pub fn from_slice(p: &[f64]) -> Self {
        let w = Vector3::new(p[0], p[1], p[2]);
        let rot = *Rotation3::from_scaled_axis(w).matrix();
        PoseFrame {
            rot,
            t: Vector3::new(p[3], p[4], p[5]),
            rot_jr: rot * right_jacobian(&w),
        }
    }
}

/// The right Jacobian of SO(3) at w: R(w + d) = R(w) Exp(J_r(w) d) to first order;
/// J_r = I - (1 - cos a) / a^2 [w]x + (a - sin a) / a^3 [w]x^2 with a = |w| (Taylor terms
/// below a = 1e-4, where they are exact to rounding).
fn right_jacobian(w: &Vector3<f64>) -> Matrix3<f64> {
    let a2 = w.norm_squared();
    let (c1, c2) = if a2 < 1e-8 {
        (0.5 - a2 / 24.0, 1.0 / 6.0 - a2 / 120.0)
    } else {
        let a = a2.sqrt();
        ((1.0 - a.cos()) / a2, (a - a.sin()) / (a2 * a))
    };
    let k = w.cross_matrix();
    Matrix3::identity() - k * c1 + k * k * c2
}

fn mat2(d: [[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(d[0][0], d[0][1], d[1][0], d[1][1])
}

/// The residual of world point `world` measured at `pixel`.
pub(crate) fn residual(
    k: &Intrinsics,
    m: &dyn DistortionModel,
    pose: &PoseFrame,
    world: &Vector3<f64>,
    pixel: [f64; 2],
) -> [f64; 2] {
    let xc = pose.rot * world + pose.t;
    let p = [xc.x / xc.z, xc.y / xc.z];
    match m.direction() {
        Direction::ObservedFromIdeal => {
            let d = m.value(p);
            let u = k.pixel_from_normalized(d[0], d[1]);
            [u[0] - pixel[0], u[1] - pixel[1]]
        }
        Direction::IdealFromObserved => {
            let ideal = m.value(k.normalized_from_pixel(pixel[0], pixel[1]));
            let (ex, ey) = (p[0] - ideal[0], p[1] - ideal[1]);
            [k.fx * ex + k.skew * ey, k.fy * ey]
        }
    }
}

/// One point's derivatives by the global parameters, made once per Jacobian.
pub(crate) struct PointScratch {
    /// d r / d (fx, fy, cx, cy, skew, coefficients in the model's order).
    pub dg: Vec<Vector2<f64>>,
    /// The model's parameter Jacobian.
    dtheta: Vec<[f64; 2]>,
}

impl PointScratch {
    /// For a model of `nd` coefficients.
    pub fn new(nd: usize) -> Self {
        PointScratch {
            dg: vec![Vector2::zeros(); 5 + nd],
            dtheta: vec![[0.0; 2]; nd],
        }
    }
}

/// The derivatives of `residual`: d r / d (fx, fy, cx, cy, skew, coefficients) into
/// `scratch.dg`, and d r / d (w, t) returned.
pub(crate) fn residual_jacobian(
    k: &Intrinsics,
    m: &dyn DistortionModel,
    pose: &PoseFrame,
    world: &Vector3<f64>,
    pixel: [f64; 2],
    scratch: &mut PointScratch,
) -> Matrix2x6<f64> {
    let PointScratch { dg, dtheta } = scratch;
    let rx = pose.rot * world;
    let xc = rx + pose.t;
    let iz = 1.0 / xc.z;
    let p = [xc.x * iz, xc.y * iz];
    let dp = Matrix2x3::new(iz, 0.0, -p[0] * iz, 0.0, iz, -p[1] * iz);
    let a = pixel_from_normalized_jacobian(k);
    let h = match m.direction() {
        Direction::ObservedFromIdeal => {
            let (d, d_point) = m.closed_into(p, dtheta);
            dg[0] = Vector2::new(d[0], 0.0);
            dg[1] = Vector2::new(0.0, d[1]);
            dg[2] = Vector2::new(1.0, 0.0);
            dg[3] = Vector2::new(0.0, 1.0);
            dg[4] = Vector2::new(d[1], 0.0);
            for (out, dt) in dg[5..].iter_mut().zip(dtheta.iter()) {
                *out = a * Vector2::from(*dt);
            }
            a * mat2(d_point) * dp
        }
        Direction::IdealFromObserved => {
            let q = k.normalized_from_pixel(pixel[0], pixel[1]);
            let (ideal, d_point) = m.closed_into(q, dtheta);
            let (ex, ey) = (p[0] - ideal[0], p[1] - ideal[1]);
            // d r / d q = -A M; q's derivatives by each intrinsic.
            let drq = -(a * mat2(d_point));
            let (fx, fy, s, yo) = (k.fx, k.fy, k.skew, q[1]);
            dg[0] = Vector2::new(ex, 0.0) + drq * Vector2::new(-q[0] / fx, 0.0);
            dg[1] = Vector2::new(0.0, ey) + drq * Vector2::new(s * yo / (fx * fy), -yo / fy);
            dg[2] = drq * Vector2::new(-1.0 / fx, 0.0);
            dg[3] = drq * Vector2::new(s / (fx * fy), -1.0 / fy);
            dg[4] = Vector2::new(ey, 0.0) + drq * Vector2::new(-yo / fx, 0.0);
            for (out, dt) in dg[5..].iter_mut().zip(dtheta.iter()) {
                *out = -(a * Vector2::from(*dt));
            }
            a * dp
        }
    };
    let dw = -(h * rx.cross_matrix() * pose.rot_jr);
    let mut j = Matrix2x6::zeros();
    j.fixed_view_mut::<2, 3>(0, 0).copy_from(&dw);
    j.fixed_view_mut::<2, 3>(0, 3).copy_from(&h);
    j
}
