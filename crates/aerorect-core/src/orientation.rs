//! The one rotation type every attitude convention converts to: `ground_from_camera`, with the
//! camera frame of the paper (x right, y up on the image plane, z backwards: a ray is
//! (x, y, -f)) and, for the compass-based adapters, the ground frame east, north, up (ENU).
//! The standard image of an ENU rotation is therefore north-up with east to the right.
//!
//! Adapters (each pinned by tests, see CONVENTIONS.md):
//! - [`CameraRotation::dji_gimbal`]: DJI's GimbalYaw/Pitch/Roll are world-frame angles (NED,
//!   intrinsic Z-Y-X of the optical axis body frame) that already include the aircraft's motion:
//!   the aircraft's Flight angles must not be composed on top.
//! - [`CameraRotation::omega_phi_kappa`]: photogrammetry's R = Rx(omega) Ry(phi) Rz(kappa),
//!   image -> object, object frame ENU; all zero is nadir, north-up.
//! - `From<&SixAngleAttitude>`: the paper's gimbal + aircraft chain; its ground X/Y are the
//!   paper's (not tied to the compass).

use crate::Mat3;
use crate::attitude::SixAngleAttitude;
use crate::error::GeometryError;
use crate::homography::Homography;
use crate::intrinsics::Intrinsics;
use nalgebra::{Rotation3, Vector3};

/// `ground_from_camera`, a proper rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraRotation {
    ground_from_camera: Mat3,
}

fn finite_deg(field: &'static str, v: f64, limit: f64) -> Result<f64, GeometryError> {
    if !v.is_finite() {
        return Err(GeometryError::InvalidParameter {
            field,
            value: v,
            reason: "not a finite number",
        });
    }
    if v.abs() > limit {
        return Err(GeometryError::InvalidParameter {
            field,
            value: v,
            reason: "outside the angle's range",
        });
    }
    Ok(v.to_radians())
}

/// A body frame (x forward, y right, z down) in east-north-up, from NED Z-Y-X angles in
/// radians (`ned_from_body = Rz(yaw) Ry(pitch) Rx(roll)`, as DJI's gimbal and flight angles).
pub fn enu_from_body_zyx(yaw: f64, pitch: f64, roll: f64) -> Mat3 {
    let ned_from_body = rot(Vector3::z(), yaw) * rot(Vector3::y(), pitch) * rot(Vector3::x(), roll);
    // ENU from NED swaps north and east and flips down.
    let enu_from_ned = Mat3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    enu_from_ned * ned_from_body
}

fn rot(axis: Vector3<f64>, angle: f64) -> Mat3 {
    Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle).into_inner()
}

impl CameraRotation {
    /// Wraps a matrix; refuses one that is not a proper rotation (to 1e-9).
    pub fn from_matrix(m: Mat3) -> Result<Self, GeometryError> {
        let err = (m.transpose() * m - Mat3::identity()).abs().max();
        if err.is_nan() || err >= 1e-9 || (m.determinant() - 1.0).abs() > 1e-9 {
            return Err(GeometryError::InvalidParameter {
                field: "rotation matrix",
                value: err,
                reason: "not a proper rotation (orthonormal, determinant +1)",
            });
        }
        Ok(Self {
            ground_from_camera: m,
        })
    }

    /// DJI gimbal angles in degrees: yaw clockwise from north, pitch from the horizon (-90 =
    /// nadir), roll about the optical axis. Body frame: x along the optical axis, y right,
    /// z down; `ned_from_body = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn dji_gimbal(yaw_deg: f64, pitch_deg: f64, roll_deg: f64) -> Result<Self, GeometryError> {
        let yaw = finite_deg("gimbal yaw (deg)", yaw_deg, 360.0)?;
        let pitch = finite_deg("gimbal pitch (deg)", pitch_deg, 90.0)?;
        let roll = finite_deg("gimbal roll (deg)", roll_deg, 180.0)?;
        // Camera x (right) = body y, camera y (up) = -body z, camera z (back) = -body x.
        let body_from_camera = Mat3::new(0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
        Self::from_matrix(enu_from_body_zyx(yaw, pitch, roll) * body_from_camera)
    }

    /// Omega, phi, kappa in degrees: `object_from_image = Rx(omega) Ry(phi) Rz(kappa)` with
    /// right-handed rotations about east, north, up.
    pub fn omega_phi_kappa(
        omega_deg: f64,
        phi_deg: f64,
        kappa_deg: f64,
    ) -> Result<Self, GeometryError> {
        let o = finite_deg("omega (deg)", omega_deg, 180.0)?;
        let p = finite_deg("phi (deg)", phi_deg, 90.0)?;
        let k = finite_deg("kappa (deg)", kappa_deg, 360.0)?;
        Self::from_matrix(rot(Vector3::x(), o) * rot(Vector3::y(), p) * rot(Vector3::z(), k))
    }

    pub fn ground_from_camera(&self) -> &Mat3 {
        &self.ground_from_camera
    }

    /// Omega, phi, kappa (degrees) of this rotation: the inverse of
    /// [`CameraRotation::omega_phi_kappa`] (phi within [-90, 90]), for exporting poses.
    pub fn to_omega_phi_kappa(&self) -> [f64; 3] {
        let r = &self.ground_from_camera;
        let omega = (-r[(1, 2)]).atan2(r[(2, 2)]);
        let phi = r[(0, 2)].clamp(-1.0, 1.0).asin();
        let kappa = (-r[(0, 1)]).atan2(r[(0, 0)]);
        [omega.to_degrees(), phi.to_degrees(), kappa.to_degrees()]
    }

    /// The optical axis (the camera's -z) in the ground frame.
    pub fn optical_axis(&self) -> Vector3<f64> {
        -self.ground_from_camera.column(2).into_owned()
    }

    /// Angle of the optical axis from the nadir, degrees.
    pub fn off_nadir_deg(&self) -> f64 {
        (-self.optical_axis().z)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    }
}

impl From<&SixAngleAttitude> for CameraRotation {
    fn from(a: &SixAngleAttitude) -> Self {
        Self {
            ground_from_camera: a.ground_from_camera(),
        }
    }
}

/// `F = K R K^-1` of any rotation: oblique pixel -> standard (nadir) pixel; w > 0 on the ground.
pub fn standard_from_rotation(intr: &Intrinsics, rotation: &CameraRotation) -> Homography {
    let k = intr.pixel_from_camera();
    let kinv = intr.camera_from_pixel();
    let r = rotation.ground_from_camera;
    // K^-1 K is exact and R^T = R^-1, so G = F^-1 (eq. 13) without a numerical inverse.
    Homography::from_pair(k * r * kinv, k * r.transpose() * kinv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vector3<f64>, b: [f64; 3]) -> bool {
        (a - Vector3::from(b)).norm() < 1e-12
    }

    fn axes(r: &CameraRotation) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let m = r.ground_from_camera();
        (
            m.column(0).into_owned(),
            m.column(1).into_owned(),
            r.optical_axis(),
        )
    }

    #[test]
    fn dji_pitch_minus_90_is_nadir_north_up() {
        let (right, up, axis) = axes(&CameraRotation::dji_gimbal(0.0, -90.0, 0.0).expect("ok"));
        assert!(close(axis, [0.0, 0.0, -1.0]), "{axis:?}");
        assert!(close(up, [0.0, 1.0, 0.0]), "image up = north: {up:?}");
        assert!(
            close(right, [1.0, 0.0, 0.0]),
            "image right = east: {right:?}"
        );
    }

    #[test]
    fn dji_yaw_90_looking_down_puts_north_on_the_left() {
        let r = CameraRotation::dji_gimbal(90.0, -90.0, 0.0).expect("ok");
        let (right, up, _) = axes(&r);
        assert!(close(up, [1.0, 0.0, 0.0]), "image up = east: {up:?}");
        assert!(
            close(-right, [0.0, 1.0, 0.0]),
            "image left = north: {right:?}"
        );
    }

    #[test]
    fn dji_horizon_looks_along_the_yaw() {
        let (_, up, axis) = axes(&CameraRotation::dji_gimbal(0.0, 0.0, 0.0).expect("ok"));
        assert!(close(axis, [0.0, 1.0, 0.0]) && close(up, [0.0, 0.0, 1.0]));
        let (_, _, axis) = axes(&CameraRotation::dji_gimbal(90.0, 0.0, 0.0).expect("ok"));
        assert!(close(axis, [1.0, 0.0, 0.0]), "yaw 90 looks east: {axis:?}");
        let r = CameraRotation::dji_gimbal(117.6, -19.0, 0.0).expect("ok");
        assert!((r.off_nadir_deg() - 71.0).abs() < 1e-9);
    }

    /// Omega-phi-kappa and DJI describe the same nadir rotations: kappa counter-clockwise is
    /// yaw clockwise, and omega tilts the axis north like pitch above -90.
    #[test]
    fn omega_phi_kappa_agrees_with_dji_at_nadir() {
        for k in [-120.0, -30.0, 0.0, 45.0, 170.0] {
            let a = CameraRotation::omega_phi_kappa(0.0, 0.0, k).expect("ok");
            let b = CameraRotation::dji_gimbal(-k, -90.0, 0.0).expect("ok");
            assert!(
                (a.ground_from_camera() - b.ground_from_camera())
                    .abs()
                    .max()
                    < 1e-12,
                "{k}"
            );
        }
        for o in [5.0, 20.0, 30.0] {
            let a = CameraRotation::omega_phi_kappa(o, 0.0, 0.0).expect("ok");
            let b = CameraRotation::dji_gimbal(0.0, -90.0 + o, 0.0).expect("ok");
            assert!(
                (a.ground_from_camera() - b.ground_from_camera())
                    .abs()
                    .max()
                    < 1e-12,
                "{o}"
            );
        }
    }

    #[test]
    fn impossible_angles_are_refused() {
        for (y, p, r) in [(f64::NAN, -90.0, 0.0), (0.0, -95.0, 0.0), (0.0, 0.0, 400.0)] {
            assert!(CameraRotation::dji_gimbal(y, p, r).is_err());
        }
        assert!(CameraRotation::from_matrix(Mat3::identity() * 2.0).is_err());
    }

    #[test]
    fn six_angle_rotation_gives_the_papers_f() {
        let att = SixAngleAttitude::from_degrees(&crate::attitude::SixAngleDegrees {
            azimuth: 20.0,
            elevation: 20.0,
            image_rotation: 2.0,
            pitch: 3.0,
            roll: -2.0,
            yaw: 15.0,
        })
        .expect("ok");
        let intr = Intrinsics::new(500.0, 500.0, 255.5, 255.5).expect("ok");
        let a = standard_from_rotation(&intr, &CameraRotation::from(&att));
        let b = crate::rectify::standard_from_oblique(&intr, &att);
        assert_eq!(a, b);
    }

    #[test]
    fn omega_phi_kappa_round_trips() {
        for opk in [
            [0.0, 0.0, 0.0],
            [-0.349, 0.298, -179.087],
            [25.0, -40.0, 130.0],
        ] {
            let r = CameraRotation::omega_phi_kappa(opk[0], opk[1], opk[2]).unwrap();
            let back = r.to_omega_phi_kappa();
            for k in 0..3 {
                assert!((back[k] - opk[k]).abs() < 1e-9, "{opk:?} -> {back:?}");
            }
        }
    }
}
