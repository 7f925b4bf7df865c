//! Grid convergence derived numerically from a CRS's projection, so it holds for any projected
//! CRS, not just UTM.

use super::Crs;
use crate::GeoError;
use aerorect_core::Mat3;

/// Meridian convergence at a WGS84 position in `crs`: the angle (degrees) from true north to
/// grid north, clockwise positive (PROJ's `meridian_convergence`; about (lon - lon_0) sin(lat)
/// for transverse Mercator). Derived from two projected points 10 m apart along the meridian.
pub fn convergence_deg(crs: &Crs, lon_deg: f64, lat_deg: f64) -> Result<f64, GeoError> {
    let dlat = 10.0 / 111_000.0;
    let a = crs.from_lon_lat(lon_deg, lat_deg - dlat / 2.0)?;
    let b = crs.from_lon_lat(lon_deg, lat_deg + dlat / 2.0)?;
    // True north's direction in grid axes, clockwise from grid north, is minus the convergence.
    Ok(-(b[0] - a[0]).atan2(b[1] - a[1]).to_degrees())
}

/// The rotation taking local east-north-up vectors at a position to the CRS's grid axes
/// (easting, northing, up): a turn about the vertical by the meridian convergence.
pub fn grid_from_enu(crs: &Crs, lon_deg: f64, lat_deg: f64) -> Result<Mat3, GeoError> {
    let g = convergence_deg(crs, lon_deg, lat_deg)?.to_radians();
    // True north (0, 1) lands at (-sin g, cos g) in the grid, true east (1, 0) at (cos g, sin g).
    let (s, c) = g.sin_cos();
    Ok(Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0))
}
