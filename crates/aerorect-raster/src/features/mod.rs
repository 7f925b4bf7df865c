//! Scale- and rotation-invariant keypoints and descriptors: SIFT (Lowe 2004) through
//! `aerorect-sift` (kornia-imgproc's pure-Rust port of OpenCV's `cv::SIFT`, forked so that its
//! x86 loops vectorise: the same scale space, extremum refinement, orientation histogram and
//! 128-value descriptor), wrapped in our raster types.
//!
//! Positions follow the crate's pixel convention (0-based, pixel centres at integers). Frames
//! are reduced first ([`gray_reduced`], box means of `factor` x `factor` pixels): a position x in
//! the reduced frame is `factor (x + 0.5) - 0.5` in the full one ([`full_from_reduced`]).

mod gray;

pub use gray::{full_from_reduced, gray_reduced};

use crate::Raster;
use aerorect_sift::{FirstOctave, SiftConfig, SiftWorkspace, sift_detect_and_compute};
use thiserror::Error;

/// Values per descriptor.
pub const DESCRIPTOR_LEN: usize = 128;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum FeatureError {
    #[error("feature option {field} = {value} is out of range ({why})")]
    Option {
        field: &'static str,
        value: f64,
        why: &'static str,
    },
    #[error("the SIFT detector refused the {width} x {height} image: {message}")]
    Detector {
        width: usize,
        height: usize,
        message: String,
    },
}

/// Detector settings (OpenCV's names and defaults except where said).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureOptions {
    /// Keep at most this many keypoints, the strongest (0: all).
    pub max_features: usize,
    /// OpenCV's `contrastThreshold` (0.04 there); lower finds more keypoints on low-contrast
    /// ground (snow, fields): 0.02 by default.
    pub contrast_threshold: f64,
    /// OpenCV's `edgeThreshold`.
    pub edge_threshold: f64,
    /// Upsample 2x before the first octave, as OpenCV does (about 3.6x the time for about
    /// twice the keypoints); off by default.
    pub double_first_octave: bool,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        Self {
            max_features: 4000,
            contrast_threshold: 0.02,
            edge_threshold: 10.0,
            double_first_octave: false,
        }
    }
}

impl FeatureOptions {
    pub fn validate(&self) -> Result<(), FeatureError> {
        let bad = |field, value, why| Err(FeatureError::Option { field, value, why });
        if !(self.contrast_threshold > 0.0 && self.contrast_threshold < 1.0) {
            return bad("contrast_threshold", self.contrast_threshold, "0 < t < 1");
        }
        if !(self.edge_threshold > 1.0 && self.edge_threshold.is_finite()) {
            return bad("edge_threshold", self.edge_threshold, "finite and > 1");
        }
        Ok(())
    }
}

/// One keypoint: position (pixels), scale (diameter of its neighbourhood, pixels), dominant
/// orientation (degrees clockwise from +x, i.e. from +u towards +v) and contrast.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Keypoint {
    pub x: f64,
    pub y: f64,
    pub size: f32,
    pub angle_deg: f32,
    pub response: f32,
}

/// Keypoints and their descriptors, [`DESCRIPTOR_LEN`] values each, in the same order.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Features {
    pub keypoints: Vec<Keypoint>,
    pub descriptors: Vec<f32>,
}

impl Features {
    pub fn len(&self) -> usize {
        self.keypoints.len()
    }

    pub fn is_empty(&self) -> bool {
        self.keypoints.is_empty()
    }

    /// Keypoint positions as `[x, y]`.
    pub fn positions(&self) -> Vec<[f64; 2]> {
        self.keypoints.iter().map(|k| [k.x, k.y]).collect()
    }
}

/// SIFT keypoints and descriptors of band 0 of `image` (intensities on a 0..255 scale, as
/// OpenCV's thresholds expect: [`gray_reduced`] gives that).
pub fn sift(image: &Raster<f32>, opts: &FeatureOptions) -> Result<Features, FeatureError> {
    opts.validate()?;
    let (w, h) = (image.width(), image.height());
    let cfg = SiftConfig {
        n_features: opts.max_features,
        contrast_threshold: opts.contrast_threshold,
        edge_threshold: opts.edge_threshold,
        ..SiftConfig::default()
    };
    let first = if opts.double_first_octave {
        FirstOctave::Double
    } else {
        FirstOctave::Native
    };
    let mut ws = SiftWorkspace::new();
    let found = sift_detect_and_compute(
        &mut ws,
        image.plane(0),
        w,
        h,
        &cfg,
        first,
        usize::MAX,
        false,
    )
    .map_err(|e| FeatureError::Detector {
        width: w,
        height: h,
        message: e.to_string(),
    })?;
    let keypoints = found
        .keypoints
        .iter()
        .map(|k| Keypoint {
            x: k.x as f64,
            y: k.y as f64,
            size: k.size,
            angle_deg: k.angle,
            response: k.response,
        })
        .collect();
    Ok(Features {
        keypoints,
        descriptors: found.descriptors,
    })
}
