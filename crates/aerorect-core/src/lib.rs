//! Pure geometry for airborne camera images: no I/O, no threads.
//!
//! Conventions (see `CONVENTIONS.md` at the repository root, each pinned by a test):
//! pixel centres at integer coordinates, u right, v down; angles in radians inside, degrees at
//! the boundaries; transforms named `a_from_b`; f64 throughout.

pub mod attitude;
pub mod camera;
pub mod distortion;
pub mod error;
pub mod evaluate;
mod footprint;
pub mod homography;
pub mod intrinsics;
pub mod motion;
pub mod orientation;
pub mod rectify;
pub mod spelling;
pub mod transform;

pub use attitude::SixAngleAttitude;
pub use camera::Camera;
pub use error::GeometryError;
pub use evaluate::{CheckPoint, CheckPointStats};
pub use homography::Homography;
pub use intrinsics::{ImageSize, Intrinsics};
pub use orientation::CameraRotation;
pub use rectify::{AltitudeScale, RectifyGeometry, RectifyLimits};
pub use transform::{PiecewiseAffine, PlaneTransform, PolyKind, Polynomial};

/// A 3x3 matrix of f64, row-major in memory views and in reports.
pub type Mat3 = nalgebra::Matrix3<f64>;
/// A 3-vector of f64.
pub type Vec3 = nalgebra::Vector3<f64>;
