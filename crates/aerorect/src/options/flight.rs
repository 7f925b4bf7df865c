//! The adjustment's options (`--adjust`, Python's `adjust_flight`) as a front end was given
//! them, checked and turned into [`FlightOptions`].

use super::OptionError;
use crate::Error;
use crate::flight::{
    ControlOptions, FlightOptions, MAX_ATTITUDE_SIGMA_DEG, PositionPrior, TieSource,
};
use crate::sane::MAX_HEIGHT_M;
use std::path::PathBuf;

/// The adjustment's options; `None` takes [`FlightOptions::default`]'s.
#[derive(Debug, Clone, Default)]
pub struct FlightRequest {
    /// Correct positions with this prior standard deviation (m) for every frame.
    pub adjust_positions_m: Option<f64>,
    /// Keep every recorded position.
    pub hold_positions: bool,
    /// Also solve each camera's radial distortion k1, k2.
    pub adjust_lens: bool,
    /// Also solve a boresight rotation per camera.
    pub adjust_boresight: bool,
    /// The recorded attitudes' standard deviation, degrees.
    pub attitude_sigma_deg: Option<f64>,
    /// The most matching rounds.
    pub adjust_passes: Option<usize>,
    /// Where tie points come from: `both`, `features` or `correlation`.
    pub ties: Option<String>,
    /// Take each GPS fix robustly about the block's common shift.
    pub robust_gps: bool,
    /// Without a DEM, render over the level ground, not the tie points' surface.
    pub level_ground: bool,
    /// Ground control: one file, or a Pix4D coordinates file and its marks file.
    pub gcps: Vec<PathBuf>,
    /// Points kept out of the solve and reported as check points.
    pub checkpoints: Vec<String>,
    /// An image mark's standard deviation, px.
    pub gcp_sigma_px: Option<f64>,
    /// Added to the points' heights (the ground's vertical datum).
    pub gcp_vertical_offset_m: Option<f64>,
}

impl FlightRequest {
    /// Refuses values outside their ranges, reading no file.
    pub fn validate(&self) -> Result<(), Error> {
        if self.hold_positions && self.adjust_positions_m.is_some() {
            return Err(Error::advice(
                "`adjust_positions_m` and `hold_positions` exclude each other",
            ));
        }
        let sigma = self.attitude_sigma_deg;
        for (key, v, max) in [
            ("adjust_positions_m", self.adjust_positions_m, MAX_HEIGHT_M),
            ("attitude_sigma_deg", sigma, MAX_ATTITUDE_SIGMA_DEG),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0 && *v <= max)) {
                let why = format!("must be a finite number > 0 and at most {max}");
                return Err(OptionError::number(key, v, why).into());
            }
        }
        if self.adjust_passes == Some(0) {
            let why = Error::Invalid("at least one matching round".into());
            return Err(OptionError::value("adjust_passes", 0, why).into());
        }
        if let Some(t) = &self.ties {
            TieSource::from_name(t).map_err(|e| OptionError::value("ties", t, e))?;
        }
        Ok(())
    }

    /// The adjustment's options: the values checked, then the ground control files read.
    pub fn resolve(&self) -> Result<FlightOptions, Error> {
        self.validate()?;
        let d = FlightOptions::default();
        Ok(FlightOptions {
            positions: match (self.hold_positions, self.adjust_positions_m) {
                (true, _) => PositionPrior::Hold,
                (false, Some(s)) => PositionPrior::Sigma(s),
                (false, None) => PositionPrior::Recorded,
            },
            attitude_sigma_deg: self.attitude_sigma_deg.unwrap_or(d.attitude_sigma_deg),
            passes: self.adjust_passes.unwrap_or(d.passes),
            ties: match &self.ties {
                Some(t) => TieSource::from_name(t)?,
                None => d.ties,
            },
            refine_radial: self.adjust_lens,
            refine_boresight: self.adjust_boresight,
            control: self.control()?,
            robust_gps: self.robust_gps,
            tie_surface: !self.level_ground,
            ..d
        })
    }

    /// The ground control `gcps` names (read and checked), if any.
    fn control(&self) -> Result<Option<ControlOptions>, Error> {
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
        co.validate()
            .map_err(|e| OptionError::value("gcps", "", e))?;
        Ok(Some(co))
    }
}
