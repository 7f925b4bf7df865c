//! Georeferencing: coordinate reference systems (read from EPSG codes, WKT and PROJ strings,
//! built by proj4rs) and the rotation from local east-north-up to a CRS's grid
//! axes (grid convergence), exterior orientation, terrain heights, and the ground-to-image map
//! an orthophoto is resampled through.
//!
//! World frame: a projected CRS's easting, northing and height (metres), treated as Cartesian
//! (as photogrammetric tools do); local frame: east, north, up at the camera. Camera frame as
//! in `aerorect_core::intrinsics`: x right, y up, z backwards.

mod crs;
mod error;
mod occlusion;
mod ortho;
mod pose;
mod terrain;
#[cfg(target_arch = "x86_64")]
mod terrain_avx2;

pub use crs::{Crs, CrsForm, TmParams, convergence_deg, grid_from_enu, proj_params, tm_params};
pub use error::{CrsError, GeoError};
pub use occlusion::{Visible, occlusion_mask};
pub use ortho::{GroundMap, OrthoGrid, common_window, march_to_ground};
pub use pose::{Mounting, Pose};
pub use terrain::{Dem, HeightGrid, Sampling, Terrain};
