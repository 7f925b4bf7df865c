//! Camera calibration from control points: one image of a 3-D test field (the paper's
//! procedure: DLT start, distortion from zero, Levenberg-Marquardt until every update moves
//! every predicted point by less than 0.01 px) or several images of a planar target (Zhang's
//! closed-form start, then the same joint adjustment).
//!
//! Camera frame for calibration: OpenCV's (x right, y down, z forward); a world point X is seen
//! at X_c = R(w) X + t with w a rotation vector. Pixels: u = fx x + skew y + cx, v = fy y + cy
//! on the distorted normalised point (x, y).

mod blocks;
mod coverage;
mod identify;
mod init;
mod inputs;
mod jacobian;
mod lm;
#[cfg(test)]
mod oracle;
mod plan;
mod problem;
mod report;
mod start;

pub use coverage::{COVERAGE_GRID, Coverage, coverage};
pub use identify::calibrate;
pub use inputs::{CalibrationOptions, Observation};
pub use report::{CalibrationReport, Correlation, ParameterValue, ViewReport};

use aerorect_core::ImageSize;
use aerorect_core::error::Num;
use aerorect_core::spelling::Spelling;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum CalibrationError {
    #[error("{got} control points given, at least {need} needed")]
    TooFewPoints { got: usize, need: usize },
    #[error("image '{image}' has {got} points, at least {need} needed")]
    TooFewInImage {
        image: String,
        got: usize,
        need: usize,
    },
    #[error(
        "point {index} (image '{image}') at ({}, {}) lies outside the {} x {} image",
        Num(pixel[0]), Num(pixel[1]), size.width, size.height
    )]
    OutsideImage {
        index: usize,
        image: String,
        pixel: [f64; 2],
        size: ImageSize,
    },
    #[error("point {index} (image '{image}') is not finite")]
    NotFinite { index: usize, image: String },
    #[error("the points of image '{image}' are collinear: they cannot determine the camera")]
    Collinear { image: String },
    #[error(
        "a planar test field seen in a single image cannot determine a free focal length: \
         use several images of the plane or a 3-D field, or fix fx and fy"
    )]
    PlanarSingleImage,
    #[error("unknown parameter name '{name}' (in {fix})", name = .0, fix = Spelling::current().name("fix"))]
    UnknownParameter(String),
    #[error("the starting values could not be found: {0}")]
    Initialisation(String),
    #[error("the normal equations are singular: {0}")]
    Singular(String),
}
