//! The georeferencing options of `rectify PHOTO`, `batch` and `mosaic`, from the keyword
//! arguments of the Python functions (the same checks and messages as the CLI's flags).

use crate::py_err;
use aerorect::core::RectifyLimits;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::drone::DroneOptions;
use aerorect::geo::{Crs, Mounting};
use aerorect::georef::load_dem;
use aerorect::io::{CameraFile, PoseRecord};
use aerorect::raster::{Interp, WarpOptions};
use anyhow::{Context, Result, bail};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Deserialize;
use std::path::Path;
use std::sync::Arc;

/// The keyword arguments, by the CLI's flag names (underscores for dashes).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotoArgs {
    pub gsd_m: Option<f64>,
    pub dem: Option<String>,
    pub ground_height_m: Option<f64>,
    #[serde(default)]
    pub vertical_offset_m: f64,
    #[serde(default)]
    pub strict: bool,
    #[serde(default)]
    pub occlusion: bool,
    pub crs: Option<String>,
    pub camera: Option<String>,
    pub boresight_deg: Option<[f64; 3]>,
    pub lever_arm_m: Option<[f64; 3]>,
    /// A pose table (CSV `filename,x,y,z,omega,phi,kappa`).
    pub poses: Option<String>,
    /// One frame's pose: x, y, z, omega, phi, kappa.
    pub pose: Option<[f64; 6]>,
    pub interp: Option<String>,
    #[serde(default)]
    pub nodata: f64,
    #[serde(default)]
    pub alpha: bool,
    pub max_output_px: Option<u64>,
    #[serde(default)]
    pub cog: bool,
    /// With `adjust`: correct positions with this prior standard deviation (m).
    pub adjust_positions_m: Option<f64>,
    /// With `adjust`: keep every recorded position.
    #[serde(default)]
    pub hold_positions: bool,
    /// With `adjust`: the recorded attitudes' standard deviation (degrees).
    pub attitude_sigma_deg: Option<f64>,
    /// With `adjust`: the most matching rounds.
    pub adjust_passes: Option<usize>,
    /// With `adjust`: where tie points come from (`both`, `features`, `correlation`).
    pub ties: Option<String>,
    /// With `adjust`: ground control points (one file, or Pix4D's coordinates and marks files).
    #[serde(default)]
    pub gcps: Vec<std::path::PathBuf>,
    /// With `gcps`: points kept out of the solve and reported as check points.
    #[serde(default)]
    pub checkpoints: Vec<String>,
    /// With `gcps`: an image mark's standard deviation (px).
    pub gcp_sigma_px: Option<f64>,
    /// With `gcps`: added to the points' heights (the ground's vertical datum).
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

    pub fn warp(&self) -> Result<WarpOptions> {
        let interp = match &self.interp {
            None => Interp::Bilinear,
            Some(t) => t
                .parse::<Interp>()
                .map_err(|e| anyhow::anyhow!("--interp '{t}': {e}"))?,
        };
        Ok(WarpOptions {
            interp,
            nodata: self.nodata,
            alpha: self.alpha,
            prefilter: true,
            ..WarpOptions::default()
        })
    }

    /// The options every frame shares, as the CLI's `ortho_options` builds them.
    pub fn options(&self, file: Option<&Path>) -> Result<DroneOptions> {
        if !self.vertical_offset_m.is_finite() {
            bail!(
                "--vertical-offset-m {}: not a finite number",
                self.vertical_offset_m
            );
        }
        for (flag, v) in [
            ("boresight-deg", self.boresight_deg),
            ("lever-arm-m", self.lever_arm_m),
        ] {
            if let Some(t) = v
                && !t.iter().all(|x| x.is_finite())
            {
                bail!(
                    "--{flag} '{},{},{}': expected three finite numbers",
                    t[0],
                    t[1],
                    t[2]
                );
            }
        }
        let mounting = Mounting::from_angles(
            self.boresight_deg.unwrap_or([0.0; 3]),
            self.lever_arm_m.unwrap_or([0.0; 3]),
        );
        let crs_text = match (&self.crs, &self.poses) {
            (Some(c), _) => Some(c.clone()),
            (None, Some(p)) => std::fs::read_to_string(Path::new(p).with_extension("prj"))
                .ok()
                .map(|t| t.trim().to_string()),
            (None, None) => None,
        };
        let crs = crs_text.map(|t| crs_of(&t)).transpose()?;
        let mut poses = self
            .poses
            .as_deref()
            .map(|p| -> Result<_> {
                let rows = aerorect::io::read_poses(Path::new(p))?;
                Ok(Arc::new(
                    rows.into_iter().map(|r| (r.filename.clone(), r)).collect(),
                ))
            })
            .transpose()?;
        if let Some(v) = self.pose {
            poses = Some(Arc::new(one_pose(v, file)?));
        }
        let limits = RectifyLimits {
            max_output_px: self.max_output_px.unwrap_or(DEFAULT_MAX_OUTPUT_PX),
        };
        Ok(DroneOptions {
            gsd_m: self.gsd_m,
            ground_height_m: self.ground_height_m,
            dem: self
                .dem
                .as_deref()
                .map(|d| load_dem(Path::new(d)))
                .transpose()?
                .map(Arc::new),
            vertical_offset_m: self.vertical_offset_m,
            strict: self.strict,
            occlusion: self.occlusion,
            crs,
            camera: self
                .camera
                .as_deref()
                .map(|c| CameraFile::read(Path::new(c)))
                .transpose()?,
            poses,
            mounting,
            // External-orientation files and GPS-track headings are the CLI's for now.
            geo: None,
            track_headings: None,
            sensefly_roll: Default::default(),
            limits,
            warp: self.warp()?,
            cog: self
                .cog
                .then(|| aerorect::io::CogOptions::masked_by_alpha(self.alpha)),
        })
    }

    /// The adjustment's options, as `--adjust-positions-m`, `--hold-positions`,
    /// `--attitude-sigma-deg` and `--adjust-passes` give them (the CLI's defaults).
    pub fn flight_options(&self) -> Result<aerorect::flight::FlightOptions> {
        use aerorect::flight::{FlightOptions, PositionPrior};
        let d = FlightOptions::default();
        let sigma = self.attitude_sigma_deg.unwrap_or(d.attitude_sigma_deg);
        for (flag, v) in [
            ("--adjust-positions-m", self.adjust_positions_m),
            ("--attitude-sigma-deg", Some(sigma)),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0)) {
                bail!("{flag} {v}: must be a finite number > 0");
            }
        }
        if self.hold_positions && self.adjust_positions_m.is_some() {
            bail!("--adjust-positions-m and --hold-positions exclude each other");
        }
        let passes = self.adjust_passes.unwrap_or(d.passes);
        if passes == 0 {
            bail!("--adjust-passes 0: at least one matching round");
        }
        Ok(FlightOptions {
            positions: match (self.hold_positions, self.adjust_positions_m) {
                (true, _) => PositionPrior::Hold,
                (false, Some(s)) => PositionPrior::Sigma(s),
                (false, None) => PositionPrior::Recorded,
            },
            attitude_sigma_deg: sigma,
            passes,
            ties: match &self.ties {
                Some(t) => aerorect::flight::TieSource::from_name(t)
                    .with_context(|| format!("ties={t:?}"))?,
                None => d.ties,
            },
            control: self.control()?,
            ..d
        })
    }

    /// The ground control `gcps` names (read and checked), if any.
    fn control(&self) -> Result<Option<aerorect::flight::ControlOptions>> {
        use aerorect::flight::ControlOptions;
        if self.gcps.is_empty() {
            return Ok(None);
        }
        let read = ControlOptions::read(&self.gcps)?;
        let co = ControlOptions {
            checkpoints: self.checkpoints.clone(),
            mark_sigma_px: self.gcp_sigma_px.unwrap_or(read.mark_sigma_px),
            vertical_offset_m: self.gcp_vertical_offset_m.unwrap_or(0.0),
            ..read
        };
        co.validate().context("gcps")?;
        Ok(Some(co))
    }
}

/// A projected CRS from user text, as `--crs` takes it.
fn crs_of(t: &str) -> Result<Crs> {
    Ok(Crs::projected_from_text(t, &format!("--crs '{t}'"))?)
}

/// The pose table of `--pose X,Y,Z,OMEGA,PHI,KAPPA` for one photo.
fn one_pose(
    v: [f64; 6],
    file: Option<&Path>,
) -> Result<std::collections::BTreeMap<String, PoseRecord>> {
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        bail!("--pose: {bad} is not a finite number");
    }
    let Some(file) = file else {
        bail!("pose= is for one photo; give a flight's poses as a table (poses=)");
    };
    let name = file
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or("")
        .to_string();
    let [x, y, z, omega, phi, kappa] = v;
    let rec = PoseRecord {
        filename: name.clone(),
        x,
        y,
        z,
        omega,
        phi,
        kappa,
    };
    Ok([(name, rec)].into_iter().collect())
}
