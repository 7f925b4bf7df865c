//! Exterior orientation in the world frame (a projected CRS's easting, northing, height), and
//! the fixed mounting of a camera on its gimbal or IMU (boresight and lever arm).

use aerorect_core::{CameraRotation, Mat3, Vec3};
use serde::Serialize;

/// Where the camera is and how it is turned, in the world frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pose {
    /// The projection centre: easting, northing, height (m).
    pub centre: [f64; 3],
    /// `world_from_camera`, row-major.
    world_from_camera: [[f64; 3]; 3],
}

impl Pose {
    /// A pose from the centre and a `world_from_camera` rotation given in the world's own axes.
    pub fn new(centre: [f64; 3], world_from_camera: &Mat3) -> Self {
        let m = world_from_camera;
        Self {
            centre,
            world_from_camera: [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
        }
    }

    /// A pose from a rotation in local east-north-up axes (every compass-based attitude:
    /// DJI gimbal angles, omega-phi-kappa about true north) and the rotation from those axes to
    /// the CRS's grid axes (see [`crate::grid_from_enu`]).
    pub fn from_enu(
        centre: [f64; 3],
        enu_from_camera: &CameraRotation,
        grid_from_enu: &Mat3,
    ) -> Self {
        Self::new(
            centre,
            &(grid_from_enu * enu_from_camera.ground_from_camera()),
        )
    }

    pub fn world_from_camera(&self) -> Mat3 {
        let m = &self.world_from_camera;
        Mat3::new(
            m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
        )
    }

    /// A world point in the camera frame.
    #[inline]
    pub fn camera_from_world(&self, p: [f64; 3]) -> Vec3 {
        let d = [
            p[0] - self.centre[0],
            p[1] - self.centre[1],
            p[2] - self.centre[2],
        ];
        let m = &self.world_from_camera;
        // The transpose of world_from_camera.
        Vec3::new(
            m[0][0] * d[0] + m[1][0] * d[1] + m[2][0] * d[2],
            m[0][1] * d[0] + m[1][1] * d[1] + m[2][1] * d[2],
            m[0][2] * d[0] + m[1][2] * d[1] + m[2][2] * d[2],
        )
    }

    /// Where a world direction from the centre meets the level `z` (world x, y); `None` for a
    /// direction at or above the horizon. A level above the camera gives the centre.
    pub fn level_point(&self, dir: Vec3, z: f64) -> Option<[f64; 2]> {
        let c = self.centre;
        (dir.z < 0.0).then(|| {
            let t = ((z - c[2]) / dir.z).max(0.0);
            [c[0] + t * dir.x, c[1] + t * dir.y]
        })
    }

    /// A camera-frame direction in the world frame.
    pub fn world_direction(&self, d: Vec3) -> Vec3 {
        self.world_from_camera() * d
    }
}

/// How the camera sits on the platform whose attitude and position are recorded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Mounting {
    /// `platform_from_camera`: a small fixed rotation (boresight misalignment), applied as
    /// `world_from_camera = world_from_platform * boresight`.
    pub boresight: Mat3Serde,
    /// The camera's projection centre relative to the position fix (GNSS antenna), in the
    /// platform's frame (metres); the world offset is `world_from_platform * lever_arm`.
    pub lever_arm_m: [f64; 3],
}

/// A row-major 3x3 matrix that serialises as nested arrays.
pub type Mat3Serde = [[f64; 3]; 3];

impl Default for Mounting {
    fn default() -> Self {
        Self {
            boresight: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            lever_arm_m: [0.0; 3],
        }
    }
}

impl Mounting {
    /// A boresight from three small angles (degrees) about the camera's x, y and z axes,
    /// `Rx(rx) Ry(ry) Rz(rz)`, and a lever arm.
    pub fn from_angles(boresight_deg: [f64; 3], lever_arm_m: [f64; 3]) -> Self {
        let r =
            nalgebra::Rotation3::from_axis_angle(&Vec3::x_axis(), boresight_deg[0].to_radians())
                * nalgebra::Rotation3::from_axis_angle(
                    &Vec3::y_axis(),
                    boresight_deg[1].to_radians(),
                )
                * nalgebra::Rotation3::from_axis_angle(
                    &Vec3::z_axis(),
                    boresight_deg[2].to_radians(),
                );
        let m = r.into_inner();
        Self {
            boresight: [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
            lever_arm_m,
        }
    }

    pub fn is_identity(&self) -> bool {
        *self == Self::default()
    }

    /// The camera's pose from the platform's: `platform` is the recorded pose (position fix and
    /// `world_from_platform`), `lever_frame` the rotation the lever arm is expressed in
    /// (usually the same as the platform's).
    pub fn camera_pose(&self, platform: &Pose, world_from_lever_frame: &Mat3) -> Pose {
        let b = &self.boresight;
        let bm = Mat3::new(
            b[0][0], b[0][1], b[0][2], b[1][0], b[1][1], b[1][2], b[2][0], b[2][1], b[2][2],
        );
        let arm = world_from_lever_frame * Vec3::from(self.lever_arm_m);
        let c = platform.centre;
        Pose::new(
            [c[0] + arm.x, c[1] + arm.y, c[2] + arm.z],
            &(platform.world_from_camera() * bm),
        )
    }
}
