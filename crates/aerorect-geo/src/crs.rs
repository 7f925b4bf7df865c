//! Projections through proj4rs, and grid convergence derived numerically from the projection
//! (so it holds for any projected CRS, not just UTM).

use crate::GeoError;
use aerorect_core::Mat3;

/// A CRS given by its PROJ definition.
#[derive(Debug, Clone)]
pub struct Projection {
    proj: proj4rs::Proj,
    definition: String,
}

impl PartialEq for Projection {
    fn eq(&self, other: &Self) -> bool {
        self.definition == other.definition
    }
}

impl Projection {
    /// Parses a PROJ string ("+proj=utm +zone=51 +datum=WGS84 +units=m").
    pub fn new(definition: &str) -> Result<Self, GeoError> {
        let proj = proj4rs::Proj::from_proj_string(definition).map_err(|e| GeoError::Crs {
            definition: definition.to_string(),
            reason: e.to_string(),
        })?;
        Ok(Self {
            proj,
            definition: definition.to_string(),
        })
    }

    /// Longitude and latitude on WGS84.
    pub fn wgs84() -> Self {
        Self::new("+proj=longlat +datum=WGS84 +no_defs").expect("a fixed, valid PROJ string")
    }

    /// The UTM zone of a WGS84 position: (definition, EPSG code).
    pub fn utm_for(lon_deg: f64, lat_deg: f64) -> Result<(Self, u16), GeoError> {
        if !(lat_deg.abs() <= 84.0 && lon_deg.abs() <= 180.0) {
            return Err(GeoError::Crs {
                definition: "UTM".into(),
                reason: format!("({lat_deg}, {lon_deg}) is outside UTM (|lat| <= 84)"),
            });
        }
        let zone = (((lon_deg + 180.0) / 6.0).floor() as i64).clamp(0, 59) as u16 + 1;
        let south = lat_deg < 0.0;
        let def = format!(
            "+proj=utm +zone={zone}{} +datum=WGS84 +units=m +no_defs",
            if south { " +south" } else { "" }
        );
        let epsg = if south { 32700 } else { 32600 } + zone;
        Ok((Self::new(&def)?, epsg))
    }

    pub fn definition(&self) -> &str {
        &self.definition
    }

    pub fn is_geographic(&self) -> bool {
        self.proj.is_latlong()
    }

    /// Transforms (x, y) of `self` into `to`. Geographic coordinates are in degrees
    /// (longitude, latitude).
    pub fn transform(&self, to: &Projection, x: f64, y: f64) -> Result<[f64; 2], GeoError> {
        let scale_in = if self.is_geographic() {
            1f64.to_radians()
        } else {
            1.0
        };
        let mut p = (x * scale_in, y * scale_in, 0.0);
        let fail = |reason: String| GeoError::Transform {
            x,
            y,
            from: self.definition.clone(),
            to: to.definition.clone(),
            reason,
        };
        proj4rs::transform::transform(&self.proj, &to.proj, &mut p)
            .map_err(|e| fail(e.to_string()))?;
        let scale_out = if to.is_geographic() {
            1f64.to_degrees()
        } else {
            1.0
        };
        let r = [p.0 * scale_out, p.1 * scale_out];
        if r[0].is_finite() && r[1].is_finite() {
            Ok(r)
        } else {
            Err(fail("not finite".into()))
        }
    }

    /// Projected coordinates of a WGS84 longitude and latitude (degrees).
    pub fn from_lon_lat(&self, lon_deg: f64, lat_deg: f64) -> Result<[f64; 2], GeoError> {
        Projection::wgs84().transform(self, lon_deg, lat_deg)
    }
}

/// Meridian convergence at a WGS84 position in `crs`: the angle (degrees) from true north to
/// grid north, clockwise positive (PROJ's `meridian_convergence`; about (lon - lon_0) sin(lat)
/// for transverse Mercator). Derived from two projected points 10 m apart along the meridian.
pub fn convergence_deg(crs: &Projection, lon_deg: f64, lat_deg: f64) -> Result<f64, GeoError> {
    let dlat = 10.0 / 111_000.0;
    let a = crs.from_lon_lat(lon_deg, lat_deg - dlat / 2.0)?;
    let b = crs.from_lon_lat(lon_deg, lat_deg + dlat / 2.0)?;
    // True north's direction in grid axes, clockwise from grid north, is minus the convergence.
    Ok(-(b[0] - a[0]).atan2(b[1] - a[1]).to_degrees())
}

/// The rotation taking local east-north-up vectors at a position to the CRS's grid axes
/// (easting, northing, up): a turn about the vertical by the meridian convergence.
pub fn grid_from_enu(crs: &Projection, lon_deg: f64, lat_deg: f64) -> Result<Mat3, GeoError> {
    let g = convergence_deg(crs, lon_deg, lat_deg)?.to_radians();
    // True north (0, 1) lands at (-sin g, cos g) in the grid, true east (1, 0) at (cos g, sin g).
    let (s, c) = g.sin_cos();
    Ok(Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0))
}
