//! Calibration input from files.

use crate::Error;
use aerorect_solve::calib::Observation;
use std::path::Path;

/// Control points (CSV `image,X,Y,Z,u,v`) as calibration observations.
pub fn read_observations(path: &Path) -> Result<Vec<Observation>, Error> {
    Ok(aerorect_io::read_control_points(path)?
        .into_iter()
        .map(|p| Observation {
            image: p.image,
            world: [p.x, p.y, p.z],
            pixel: [p.u, p.v],
        })
        .collect())
}
