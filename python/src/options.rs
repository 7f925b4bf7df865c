//! The keyword arguments of the Python functions turned into the facade's requests
//! (`aerorect::options`), which check them as they check the CLI's flags; messages name the
//! keyword (`gsd_m=1e308: ...`).

use crate::py_err;
use aerorect::core::RectifyLimits;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::drone::DroneOptions;
use aerorect::options::{FlightRequest, PhotoRequest, Spelling, parse_interp};
use aerorect::photo_source::SenseflyRoll;
use aerorect::raster::WarpOptions;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// How Python spells the facade's option keys: `gsd_m=1e308`.
pub const KEYWORDS: Spelling = Spelling {
    prefix: "",
    dashes: false,
    before_value: "=",
};

/// The keyword arguments, by the facade's option keys.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotoArgs {
    pub gsd_m: Option<f64>,
    pub dem: Option<PathBuf>,
    pub ground_height_m: Option<f64>,
    #[serde(default)]
    pub vertical_offset_m: f64,
    #[serde(default)]
    pub strict: bool,
    #[serde(default)]
    pub occlusion: bool,
    pub crs: Option<String>,
    pub camera: Option<PathBuf>,
    pub boresight_deg: Option<[f64; 3]>,
    pub lever_arm_m: Option<[f64; 3]>,
    /// A pose table (CSV `filename,x,y,z,omega,phi,kappa`).
    pub poses: Option<PathBuf>,
    /// One frame's pose: x, y, z, omega, phi, kappa.
    pub pose: Option<[f64; 6]>,
    /// An external-orientation file (geo.txt, Pix4D CSV, geoinfo.txt, pose table).
    pub geo: Option<PathBuf>,
    /// `as_recorded` or `flipped`.
    pub sensefly_roll: Option<String>,
    pub interp: Option<String>,
    #[serde(default)]
    pub nodata: f64,
    #[serde(default)]
    pub alpha: bool,
    pub max_output_px: Option<u64>,
    #[serde(default)]
    pub cog: bool,
    pub adjust_positions_m: Option<f64>,
    #[serde(default)]
    pub hold_positions: bool,
    #[serde(default)]
    pub adjust_lens: bool,
    #[serde(default)]
    pub adjust_boresight: bool,
    pub attitude_sigma_deg: Option<f64>,
    pub adjust_passes: Option<usize>,
    pub ties: Option<String>,
    #[serde(default)]
    pub robust_gps: bool,
    #[serde(default)]
    pub level_ground: bool,
    #[serde(default)]
    pub gcps: Vec<PathBuf>,
    #[serde(default)]
    pub checkpoints: Vec<String>,
    pub gcp_sigma_px: Option<f64>,
    pub gcp_vertical_offset_m: Option<f64>,
}

impl PhotoArgs {
    /// From a dict of keyword arguments (None values as absent).
    pub fn from_dict(d: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let Some(d) = d else {
            return serde_json::from_str("{}").map_err(py_err);
        };
        let py = d.py();
        let text: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        serde_json::from_str(&text).map_err(|e| py_err(anyhow::anyhow!("keyword arguments: {e}")))
    }

    /// The largest ortho, `max_output_px` or the default.
    pub fn max_output_px(&self) -> u64 {
        self.max_output_px.unwrap_or(DEFAULT_MAX_OUTPUT_PX)
    }

    /// The georeferencing request these arguments make.
    fn request(&self) -> anyhow::Result<PhotoRequest> {
        let warp = WarpOptions {
            interp: match &self.interp {
                None => aerorect::raster::Interp::Bilinear,
                Some(t) => parse_interp(t)?,
            },
            nodata: self.nodata,
            alpha: self.alpha,
            prefilter: true,
            ..WarpOptions::default()
        };
        let sensefly_roll = match self.sensefly_roll.as_deref() {
            None | Some("auto") => SenseflyRoll::Auto,
            Some("as_recorded") => SenseflyRoll::AsRecorded,
            Some("flipped") => SenseflyRoll::Flipped,
            Some(other) => anyhow::bail!(
                "sensefly_roll='{other}': expected 'auto', 'as_recorded' or 'flipped'"
            ),
        };
        Ok(PhotoRequest {
            gsd_m: self.gsd_m,
            ground_height_m: self.ground_height_m,
            vertical_offset_m: self.vertical_offset_m,
            strict: self.strict,
            occlusion: self.occlusion,
            crs: self.crs.clone(),
            camera: self.camera.clone(),
            poses: self.poses.clone(),
            pose: self.pose,
            geo: self.geo.clone(),
            dem: self.dem.clone(),
            boresight_deg: self.boresight_deg,
            lever_arm_m: self.lever_arm_m,
            sensefly_roll,
            limits: RectifyLimits {
                max_output_px: self.max_output_px(),
            },
            warp,
            cog: self.cog,
        })
    }

    /// The options of one photo (`file`: the photo a `pose` is for).
    pub fn options(&self, file: Option<&Path>) -> anyhow::Result<DroneOptions> {
        Ok(self.request()?.resolve(file)?)
    }

    /// The options every frame of a flight shares, with the flight's checks; the warnings go
    /// to Python's `warnings`.
    pub fn flight_frames(&self, paths: &[PathBuf]) -> anyhow::Result<(DroneOptions, Vec<String>)> {
        Ok(self.request()?.resolve_flight(paths)?)
    }

    /// The adjustment's options.
    pub fn flight_options(&self) -> anyhow::Result<aerorect::flight::FlightOptions> {
        FlightRequest {
            adjust_positions_m: self.adjust_positions_m,
            hold_positions: self.hold_positions,
            adjust_lens: self.adjust_lens,
            adjust_boresight: self.adjust_boresight,
            attitude_sigma_deg: self.attitude_sigma_deg,
            adjust_passes: self.adjust_passes,
            ties: self.ties.clone(),
            robust_gps: self.robust_gps,
            level_ground: self.level_ground,
            gcps: self.gcps.clone(),
            checkpoints: self.checkpoints.clone(),
            gcp_sigma_px: self.gcp_sigma_px,
            gcp_vertical_offset_m: self.gcp_vertical_offset_m,
        }
        .resolve()
        .map_err(Into::into)
    }
}
