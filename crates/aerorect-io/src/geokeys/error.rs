//! Why a GeoTIFF's GeoKeys do not give a CRS: the key and value concerned (`IoError::GeoKeys`
//! adds the file's name).

use super::keys::{
    COORD_TRANS, GEOG_ANGULAR_UNITS, GEOG_PRIME_MERIDIAN, GEOGRAPHIC_TYPE, PROJECTION, key_name,
};
use aerorect_geo::CrsError;
use thiserror::Error;

/// A GeoKey directory this reader cannot turn into a CRS; each names the key (by name and
/// number) and its value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeoKeyError {
    #[error("GeoKeyDirectory is shorter than its header")]
    ShortDirectory,
    /// A key whose value lies past the end of the tag holding it.
    #[error("{} points past {tag}", key_name(*key))]
    PastParams { key: u16, tag: &'static str },
    #[error("{} is stored in unknown tag {tag}", key_name(*key))]
    UnknownTag { key: u16, tag: u16 },
    /// A model type, projection, coordinate transformation or unit this reader does not build.
    #[error("{} = {value} is not supported", key_name(*key))]
    Unsupported { key: u16, value: u16 },
    #[error("{} = {value} is not degrees", key_name(GEOG_ANGULAR_UNITS))]
    NotDegrees { value: u16 },
    #[error("{} = {value} is not Greenwich", key_name(GEOG_PRIME_MERIDIAN))]
    NotGreenwich { value: u16 },
    #[error("{} = {code} is not a known EPSG code", key_name(GEOGRAPHIC_TYPE))]
    UnknownGeographic { code: u16 },
    #[error("the geographic CRS has no EPSG code, datum, ellipsoid or GeogSemiMajorAxisGeoKey")]
    NoEllipsoid,
    #[error("no {} or {}", key_name(COORD_TRANS), key_name(PROJECTION))]
    NoProjection,
    /// The keys describe a CRS that does not build (the CRS error's own text).
    #[error(transparent)]
    Crs(#[from] CrsError),
}
