//! Rectification of an oblique frame to the nadir standard image (the paper's indirect method).

use crate::{Error, warp_any};
use aerorect_core::attitude::SixAngleDegrees;
use aerorect_core::{
    AltitudeScale, Camera, Intrinsics, RectifyGeometry, RectifyLimits, SixAngleAttitude,
};
use aerorect_raster::{AnyRaster, LensDirection, LensMap, Then, WarpOptions};
use serde::Serialize;
use std::time::Instant;

/// Everything that fixes one frame's rectification, planned once, run on any number of images
/// of the camera's size.
#[derive(Debug, Clone)]
pub struct RectifyPlan {
    /// The camera of the input frames; with a lens model the frame is undistorted on the fly
    /// (G, then ideal -> observed).
    pub camera: Camera,
    /// The six angles, when the plan was made from them.
    pub attitude: Option<SixAngleAttitude>,
    pub altitude: Option<AltitudeScale>,
    pub limits: RectifyLimits,
    pub warp: WarpOptions,
    pub geometry: RectifyGeometry,
}

impl RectifyPlan {
    /// The output grid comes from the frame's corner pixels as recorded (not their undistorted
    /// positions).
    pub fn new(
        camera: Camera,
        attitude: SixAngleAttitude,
        altitude: Option<AltitudeScale>,
        limits: RectifyLimits,
        warp: WarpOptions,
    ) -> Result<Self, Error> {
        let geometry =
            RectifyGeometry::new(&camera.intrinsics, camera.size, &attitude, altitude, limits)
                .map_err(Error::geometry("rectify"))?;
        Ok(Self {
            camera,
            attitude: Some(attitude),
            altitude,
            limits,
            warp,
            geometry,
        })
    }

    /// A plan for a grid planned elsewhere (for example georeferenced from photo metadata).
    pub fn from_geometry(
        camera: Camera,
        geometry: RectifyGeometry,
        limits: RectifyLimits,
        warp: WarpOptions,
    ) -> Self {
        Self {
            camera,
            attitude: None,
            altitude: None,
            limits,
            warp,
            geometry,
        }
    }

    /// Resamples `input` onto the output grid; returns the image and the seconds the warp took.
    pub fn run(&self, input: &AnyRaster) -> Result<(AnyRaster, f64), Error> {
        crate::check_input_size(input, self.camera.size, "plan")?;
        let t = Instant::now();
        let (g, size) = (
            &self.geometry.oblique_from_output,
            self.geometry.output_size,
        );
        let out = match LensMap::of_camera(&self.camera, LensDirection::ObservedFromIdeal) {
            None => warp_any(input, g, size, &self.warp)?,
            Some(lens) => warp_any(input, &Then(*g, lens), size, &self.warp)?,
        };
        Ok((out, t.elapsed().as_secs_f64()))
    }

    /// The report of a run (`warp_seconds` from [`RectifyPlan::run`]).
    pub fn report(&self, input: &str, output: &str, warp_seconds: f64) -> RectifyReport {
        let g = &self.geometry;
        RectifyReport {
            input: input.to_string(),
            output: output.to_string(),
            homography_output_to_input: g.oblique_from_output.row_major(),
            homography_input_to_standard: g.standard_from_oblique.row_major(),
            output_size: [g.output_size.width, g.output_size.height],
            standard_origin: g.standard_origin,
            clipped: g.clipped,
            interp: self.warp.interp.name(),
            nodata: self.warp.nodata,
            alpha: self.warp.alpha,
            warp_seconds,
            input_size: [self.camera.size.width, self.camera.size.height],
            intrinsics_px: self.camera.intrinsics,
            attitude_deg: self.attitude.map(|a| a.to_degrees()),
            altitude_m: self.altitude.map(|a| a.altitude_m),
            base_altitude_m: self.altitude.map(|a| a.base_altitude_m),
            max_output_px: self.limits.max_output_px,
            footprint_px: g.footprint.clone(),
        }
    }
}

/// REPORT.json of `aerorect rectify`.
#[derive(Debug, Clone, Serialize)]
pub struct RectifyReport {
    pub input: String,
    pub output: String,
    /// Maps output pixel (col, row, 1) to input pixel, homogeneous, row-major.
    pub homography_output_to_input: [[f64; 3]; 3],
    /// F of eq. (12): input pixel -> standard frame (before altitude scaling and grid offset).
    pub homography_input_to_standard: [[f64; 3]; 3],
    pub output_size: [usize; 2],
    /// Standard-frame coordinate (after altitude scaling) of output pixel (0, 0).
    pub standard_origin: [f64; 2],
    pub clipped: bool,
    pub interp: &'static str,
    pub nodata: f64,
    pub alpha: bool,
    pub warp_seconds: f64,
    pub input_size: [usize; 2],
    pub intrinsics_px: Intrinsics,
    pub attitude_deg: Option<SixAngleDegrees>,
    pub altitude_m: Option<f64>,
    pub base_altitude_m: Option<f64>,
    pub max_output_px: u64,
    /// The part of the input that was rectified (input pixels; the whole frame unless clipped).
    pub footprint_px: Vec<[f64; 2]>,
}
