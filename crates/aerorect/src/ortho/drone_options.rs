//! The options of a drone photo's plan that do not come from the photo itself: the shared
//! type of the photo pipeline (`drone`), the metadata readers (`photo_source`) and the flight,
//! apart from all of them so that none of them imports another for it.

use crate::Error;
use crate::sane::{check_gsd_m, check_height_m, check_lever_arm_m};
use aerorect_core::RectifyLimits;
use aerorect_geo::{Crs, Mounting};
use aerorect_io::{CameraFile, PoseRecord};
use aerorect_raster::WarpOptions;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// How senseFly's roll is read. Peer tools disagree (ODM flips its sign, OpenSfM and Orthority
/// do not) and nothing records how the camera sits in the airframe, so by default the images
/// decide (CONVENTIONS.md, "senseFly roll").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SenseflyRoll {
    /// A flight's first round is adjusted under both readings and the one its ties turn the
    /// frames less from is kept (`aerorect::flight`, `sensefly_roll` in its report); a photo
    /// on its own is read as recorded.
    #[default]
    Auto,
    /// The recorded roll, as Pix4D's convention reads it (OpenSfM, Orthority).
    AsRecorded,
    /// The recorded roll negated (ODM).
    Flipped,
}

/// Inputs to [`crate::drone::plan_from_metadata`] that do not come from the photo.
#[derive(Debug, Clone, Default)]
pub struct DroneOptions {
    /// Output ground sample distance; default: the frame's own at nadir (H / f).
    pub gsd_m: Option<f64>,
    pub ground_height_m: Option<f64>,
    /// Terrain: camera heights from AbsoluteAltitude + `vertical_offset_m` against it.
    pub dem: Option<Arc<aerorect_geo::Dem>>,
    pub vertical_offset_m: f64,
    /// DEM holes or gaps are errors instead of a warning and the level fallback.
    pub strict: bool,
    /// Over a DEM, leave ground hidden behind nearer terrain empty.
    pub occlusion: bool,
    /// Output CRS (default: the UTM zone of the position).
    pub crs: Option<Crs>,
    /// Overrides the camera from metadata (sized for each photo as it is read).
    pub camera: Option<CameraFile>,
    /// Exterior orientations by file name or stem: frames listed here take their pose from the
    /// table instead of their metadata.
    pub poses: Option<Arc<BTreeMap<String, PoseRecord>>>,
    pub mounting: Mounting,
    /// External orientations (`--geo`, positions in WGS84): a listed photo takes its position,
    /// height and angles (where the file has them) from it; an unlisted photo is an error.
    pub geo: Option<Arc<aerorect_io::EoTable>>,
    /// GPS-track headings of the photos without attitude, by file name
    /// (`photo_source::track_headings`).
    pub track_headings: Option<Arc<BTreeMap<String, f64>>>,
    /// How senseFly's roll is read.
    pub sensefly_roll: SenseflyRoll,
    pub limits: RectifyLimits,
    pub warp: WarpOptions,
    /// Write each frame as a cloud-optimised GeoTIFF with these options instead of the strip
    /// GeoTIFF (the output must be .tif).
    pub cog: Option<aerorect_io::CogOptions>,
}

impl DroneOptions {
    /// Refuses options outside their sane ranges: the GSD, the ground height, the vertical
    /// offset and the lever arm.
    pub fn validate(&self) -> Result<(), Error> {
        if let Some(g) = self.gsd_m {
            check_gsd_m(g)?;
        }
        if let Some(z) = self.ground_height_m {
            check_height_m("ground height", z)?;
        }
        check_height_m("vertical offset", self.vertical_offset_m)?;
        check_lever_arm_m(self.mounting.lever_arm_m)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_refuses_an_absurd_gsd_and_passes_the_defaults() {
        let opts = DroneOptions {
            gsd_m: Some(1e308),
            ..DroneOptions::default()
        };
        assert!(opts.validate().is_err());
        assert!(DroneOptions::default().validate().is_ok());
    }
}
