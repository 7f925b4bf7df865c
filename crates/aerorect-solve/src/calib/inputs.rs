//! The calibration's inputs: control points seen in images and the options of the adjustment.

use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;

/// One control point seen in one image.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    pub image: String,
    pub world: [f64; 3],
    pub pixel: [f64; 2],
}

#[derive(Debug, Clone)]
pub struct CalibrationOptions {
    /// The model to fit (its coefficients are the starting values, normally zero).
    pub model: Distortion,
    /// Parameter names held at their starting values (fx, fy, cx, cy, skew, or a coefficient).
    pub fix: Vec<String>,
    /// Free the skew (held at zero otherwise).
    pub skew: bool,
    /// Hold fy / fx at this ratio (OpenCV's CALIB_FIX_ASPECT_RATIO without a guess uses 1).
    pub fixed_aspect: Option<f64>,
    pub max_iterations: usize,
    /// Stop when an update moves every predicted point by less than this (pixels).
    pub stop_px: f64,
    pub image_size: ImageSize,
}

impl CalibrationOptions {
    pub fn new(model: Distortion, image_size: ImageSize) -> Self {
        Self {
            model,
            fix: vec![],
            skew: false,
            fixed_aspect: None,
            max_iterations: 200,
            stop_px: 0.01,
            image_size,
        }
    }
}
