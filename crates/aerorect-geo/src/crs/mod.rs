//! Coordinate reference systems: what a user or a file gave (an EPSG code, a WKT text or a PROJ
//! string) together with the projection proj4rs builds from it, so one value is both written
//! back as given (`.prj`, GeoKeys, reports) and used to transform points.
//!
//! Every CRS is built when it is made, so one that would not project is refused where it is
//! read, naming the text. Grid convergence is derived numerically from the projection
//! (`grid.rs`), so it holds for any projected CRS, not just UTM.

mod grid;
#[cfg(test)]
mod tests;
mod text;

pub use grid::{convergence_deg, grid_from_enu};
pub(crate) use text::short;
pub use text::{TmParams, proj_params, tm_params};

use crate::{CrsError, GeoError};
use serde::Serialize;
use std::fmt;

/// The form a CRS was given in.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum CrsForm {
    /// An EPSG code, e.g. 32635 for WGS 84 / UTM zone 35N.
    Epsg(u16),
    /// OGC or ESRI WKT (WKT1 or WKT2).
    Wkt(String),
    /// A PROJ string, e.g. "+proj=tmerc +lon_0=25 +datum=WGS84 +units=m".
    Proj(String),
}

/// A coordinate reference system: the form it was given in, its PROJ definition and the
/// projection built from that.
///
/// Two CRSs are equal (`==`) when given alike; [`Crs::same_as`] also matches an EPSG code with
/// the WKT of its `.prj`. It prints, serialises and debug-prints as given.
#[derive(Clone)]
pub struct Crs {
    form: CrsForm,
    definition: String,
    proj: proj4rs::Proj,
}

impl Crs {
    /// The CRS of an EPSG code; an error for a code not in the EPSG table this build carries.
    pub fn from_epsg(code: u16) -> Result<Crs, CrsError> {
        Crs::from_form(CrsForm::Epsg(code))
    }

    /// The CRS of an OGC or ESRI WKT text.
    pub fn from_wkt(wkt: impl Into<String>) -> Result<Crs, CrsError> {
        Crs::from_form(CrsForm::Wkt(wkt.into()))
    }

    /// The CRS of a PROJ string ("+proj=utm +zone=51 +datum=WGS84 +units=m").
    pub fn from_proj_string(definition: impl Into<String>) -> Result<Crs, CrsError> {
        Crs::from_form(CrsForm::Proj(definition.into()))
    }

    /// The CRS of a form: its PROJ definition, built by proj4rs.
    pub fn from_form(form: CrsForm) -> Result<Crs, CrsError> {
        let definition = text::definition_of(&form)?;
        let proj = proj4rs::Proj::from_proj_string(&definition).map_err(|e| CrsError::Proj {
            definition: definition.clone(),
            reason: e.to_string(),
        })?;
        Ok(Crs {
            form,
            definition,
            proj,
        })
    }

    /// Reads a CRS from user input: "EPSG:32651" (any case), a "+proj=..." string, or WKT
    /// (PROJCS, PROJCRS, GEOGCS, GEOGCRS, COMPD_CS, ...).
    pub fn parse(text: &str) -> Result<Crs, CrsError> {
        Crs::from_form(text::form_of_text(text)?)
    }

    /// Longitude and latitude on WGS84.
    pub fn wgs84() -> Crs {
        Crs::from_proj_string("+proj=longlat +datum=WGS84 +no_defs")
            .expect("a fixed, valid PROJ string")
    }

    /// The WGS84 UTM zone of a WGS84 position (its EPSG code is [`Crs::epsg`]).
    pub fn utm_for(lon_deg: f64, lat_deg: f64) -> Result<Crs, GeoError> {
        let fail = |reason: String| GeoError::Crs {
            definition: "UTM".into(),
            reason,
        };
        if !(lat_deg.abs() <= 84.0 && lon_deg.abs() <= 180.0) {
            return Err(fail(format!(
                "({lat_deg}, {lon_deg}) is outside UTM (|lat| <= 84)"
            )));
        }
        let zone = (((lon_deg + 180.0) / 6.0).floor() as i64).clamp(0, 59) as u16 + 1;
        let epsg = if lat_deg < 0.0 { 32700 } else { 32600 } + zone;
        // The table's definition of each zone is "+proj=utm +zone=Z [+south] +datum=WGS84
        // +units=m +no_defs" (tested).
        Crs::from_epsg(epsg).map_err(|e| fail(e.to_string()))
    }

    /// The form this CRS was given in.
    pub fn form(&self) -> &CrsForm {
        &self.form
    }

    /// The EPSG code, when the CRS is given by one.
    pub fn epsg(&self) -> Option<u16> {
        match self.form {
            CrsForm::Epsg(c) => Some(c),
            _ => None,
        }
    }

    /// The PROJ definition this CRS is built from.
    pub fn definition(&self) -> &str {
        &self.definition
    }

    /// True for a longitude/latitude CRS.
    pub fn is_geographic(&self) -> bool {
        self.proj.is_latlong()
    }

    /// Whether `other` is built from the same PROJ definition (points need no transform
    /// between them).
    pub fn same_definition(&self, other: &Crs) -> bool {
        self.definition == other.definition
    }

    /// Whether `other` is this CRS: the same text, or the same PROJ parameters (an EPSG code
    /// and the WKT of a `.prj` written for it).
    pub fn same_as(&self, other: &Crs) -> bool {
        if self.form == other.form {
            return true;
        }
        if let (Some(a), Some(b)) = (
            text::epsg_equivalent(&self.form),
            text::epsg_equivalent(&other.form),
        ) {
            return a == b;
        }
        proj_params(&self.definition) == proj_params(&other.definition)
    }

    /// OGC WKT1 of this CRS (for `.prj` and `.aux.xml` sidecars). PROJ strings are converted
    /// for longlat, tmerc and utm only.
    pub fn to_wkt(&self) -> Result<String, CrsError> {
        text::wkt_of(&self.form)
    }

    /// Transforms (x, y) of `self` into `to`. Geographic coordinates are in degrees
    /// (longitude, latitude).
    pub fn transform(&self, to: &Crs, x: f64, y: f64) -> Result<[f64; 2], GeoError> {
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

    /// Coordinates in this CRS of a WGS84 longitude and latitude (degrees).
    pub fn from_lon_lat(&self, lon_deg: f64, lat_deg: f64) -> Result<[f64; 2], GeoError> {
        Crs::wgs84().transform(self, lon_deg, lat_deg)
    }
}

impl PartialEq for Crs {
    /// Given alike (the definition and projection follow from the form).
    fn eq(&self, other: &Self) -> bool {
        self.form == other.form
    }
}

impl fmt::Debug for Crs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.form.fmt(f)
    }
}

impl fmt::Display for Crs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.form {
            CrsForm::Epsg(c) => write!(f, "EPSG:{c}"),
            CrsForm::Wkt(w) => write!(f, "{w}"),
            CrsForm::Proj(p) => write!(f, "{p}"),
        }
    }
}

impl Serialize for Crs {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.form.serialize(s)
    }
}
