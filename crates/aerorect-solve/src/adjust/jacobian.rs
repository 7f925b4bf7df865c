//! Analytic Jacobians of a tie point's pixel with respect to its frame's block (rotation,
//! position), its camera's block (focal scale, principal point, radial terms, boresight) and
//! the point (the numeric ones are the tests' oracle, `oracle.rs`).
//!
//! With v = x - c, d = Rot(b)^T R0^T Rot(w)^T v, the derivative of Rot(w)^T v by w is
//! Rot(w)^T [v]x J_l(w), J_l the left Jacobian of SO(3); likewise for b.

use super::AdjustFrame;
use super::blocks::{CameraBlock, FrameBlock, LOCAL};
use super::residuals::{distorted, pixel_of};
use aerorect_core::distortion::Direction;
use aerorect_core::{Camera, Vec3};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Rotation3, SMatrix};

/// A pixel and its Jacobians: by the observation's local columns (frame's six, camera's
/// eight) and by the point.
pub(super) struct PixelJacobian {
    pub pixel: [f64; 2],
    pub local: SMatrix<f64, 2, LOCAL>,
    pub point: Matrix2x3<f64>,
}

fn skew(v: &Vec3) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The left Jacobian of SO(3) at the rotation vector `w`.
fn left_jacobian(w: &Vec3) -> Matrix3<f64> {
    let t2 = w.norm_squared();
    let k = skew(w);
    let (a, b) = if t2 < 1e-10 {
        (0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0)
    } else {
        let t = t2.sqrt();
        ((1.0 - t.cos()) / t2, (t - t.sin()) / (t2 * t))
    };
    Matrix3::identity() + a * k + b * k * k
}

/// The lens's observed point of the ideal `n` and its derivative by `n`.
fn lens(camera: &Camera, n: [f64; 2]) -> Option<([f64; 2], Matrix2<f64>)> {
    let Some(d) = &camera.distortion else {
        return Some((n, Matrix2::identity()));
    };
    let m = d.model();
    match m.direction() {
        Direction::ObservedFromIdeal => {
            let (q, [[a, b], [c, e]]) = m.value_d_point(n);
            Some((q, Matrix2::new(a, b, c, e)))
        }
        Direction::IdealFromObserved => {
            let q = m.observed_from_ideal(n)?;
            let (_, [[a, b], [c, e]]) = m.value_d_point(q);
            Some((q, Matrix2::new(a, b, c, e).try_inverse()?))
        }
    }
}

/// One frame's pose at one state, composed once for all its observations: the rotations
/// and their SO(3) Jacobians cost two sine-cosine pairs and a dozen 3 x 3 products, and were
/// computed per observation (a fifth of a large flight's solve).
pub(super) struct Posed<'a> {
    camera: &'a Camera,
    cb: CameraBlock,
    /// The centre `C0 + dc`.
    centre: Vec3,
    /// `Rot(b)^T R0^T Rot(w)^T`.
    camera_from_world: Matrix3<f64>,
    /// `R0^T Rot(w)^T`: a point's direction before the boresight turns it.
    recorded_from_world: Matrix3<f64>,
    boresight_t: Matrix3<f64>,
    left_w: Matrix3<f64>,
    left_b: Matrix3<f64>,
}

impl<'a> Posed<'a> {
    pub fn new(frame: &AdjustFrame, camera: &'a Camera, fb: &FrameBlock, cb: &CameraBlock) -> Self {
        let rw = Rotation3::new(fb.rotation).into_inner();
        let rb = Rotation3::new(cb.boresight).into_inner();
        let recorded_from_world = frame.world_from_camera.transpose() * rw.transpose();
        Self {
            camera,
            cb: *cb,
            centre: Vec3::from(frame.centre) + fb.position,
            camera_from_world: rb.transpose() * recorded_from_world,
            recorded_from_world,
            boresight_t: rb.transpose(),
            left_w: left_jacobian(&fb.rotation),
            left_b: left_jacobian(&cb.boresight),
        }
    }

    /// The pixel of `x` (`None` behind the camera or beyond the lens).
    pub fn project(&self, x: &Vec3) -> Option<[f64; 2]> {
        let d = self.camera_from_world * (x - self.centre);
        if d.z >= 0.0 {
            return None;
        }
        let q = distorted(self.camera, &self.cb, [d.x / -d.z, d.y / d.z])?;
        Some(pixel_of(self.camera, &self.cb, q))
    }

    /// The pixel of `x` and its Jacobians (`None` where [`Self::project`] gives none).
    pub fn pixel_jacobian(&self, x: &Vec3) -> Option<PixelJacobian> {
        let (camera, cb) = (self.camera, &self.cb);
        let v = x - self.centre;
        let d = self.camera_from_world * v;
        if d.z >= 0.0 {
            return None;
        }
        let dd_w = self.camera_from_world * skew(&v) * self.left_w;
        let u2 = self.recorded_from_world * v;
        let dd_b = self.boresight_t * skew(&u2) * self.left_b;
        let dd_x = self.camera_from_world;
        // n = (d.x / -d.z, d.y / d.z).
        let n = [d.x / -d.z, d.y / d.z];
        let dn_dd = Matrix2x3::new(
            -1.0 / d.z,
            0.0,
            d.x / (d.z * d.z),
            0.0,
            1.0 / d.z,
            -d.y / (d.z * d.z),
        );
        let (q0, dq0_dn) = lens(camera, n)?;
        let r2 = n[0] * n[0] + n[1] * n[1];
        let [k1, k2] = cb.radial;
        let radial = k1 * r2 + k2 * r2 * r2;
        let q = [q0[0] + n[0] * radial, q0[1] + n[1] * radial];
        let nv = nalgebra::Vector2::new(n[0], n[1]);
        let dq_dn = dq0_dn
            + Matrix2::identity() * radial
            + nv * nv.transpose() * (2.0 * k1 + 4.0 * k2 * r2);
        let k = &camera.intrinsics;
        let s = 1.0 + cb.focal_scale;
        let dp_dq = Matrix2::new(s * k.fx, s * k.skew, 0.0, s * k.fy);
        let dp_dd = dp_dq * dq_dn * dn_dd;
        let mut local = SMatrix::<f64, 2, LOCAL>::zeros();
        local.fixed_columns_mut::<3>(0).copy_from(&(dp_dd * dd_w));
        local.fixed_columns_mut::<3>(3).copy_from(&(-dp_dd * dd_x));
        local.set_column(
            6,
            &nalgebra::Vector2::new(k.fx * q[0] + k.skew * q[1], k.fy * q[1]),
        );
        local[(0, 7)] = 1.0;
        local[(1, 8)] = 1.0;
        local.set_column(9, &(dp_dq * nv * r2));
        local.set_column(10, &(dp_dq * nv * (r2 * r2)));
        local.fixed_columns_mut::<3>(11).copy_from(&(dp_dd * dd_b));
        Some(PixelJacobian {
            pixel: pixel_of(camera, cb, q),
            local,
            point: dp_dd * dd_x,
        })
    }
}

/// The pixel of `x` in `frame` and its Jacobians (`None` where `project` gives none): the
/// numeric oracle's entry (the library poses each frame once, [`Posed`]).
#[cfg(test)]
pub(super) fn pixel_jacobian(
    frame: &AdjustFrame,
    camera: &Camera,
    fb: &FrameBlock,
    cb: &CameraBlock,
    x: &Vec3,
) -> Option<PixelJacobian> {
    Posed::new(frame, camera, fb, cb).pixel_jacobian(x)
}
