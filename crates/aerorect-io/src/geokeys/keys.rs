//! The GeoKey ids and tags this reader and writer use (GeoTIFF 1.0 / OGC 19-008), and their
//! names in messages.

pub(crate) const GEO_KEY_DIRECTORY: u16 = 34735;
pub(crate) const GEO_DOUBLE_PARAMS: u16 = 34736;
pub(crate) const GEO_ASCII_PARAMS: u16 = 34737;

pub(crate) const USER_DEFINED: u16 = 32767;
pub(crate) const ESRI_PE: &str = "ESRI PE String = ";

// GeoKey ids (GeoTIFF 1.0 / OGC 19-008).
pub(crate) const MODEL_TYPE: u16 = 1024;
pub(crate) const RASTER_TYPE: u16 = 1025;
pub(crate) const GT_CITATION: u16 = 1026;
pub(crate) const GEOGRAPHIC_TYPE: u16 = 2048;
pub(crate) const GEOG_DATUM: u16 = 2050;
pub(crate) const GEOG_PRIME_MERIDIAN: u16 = 2051;
pub(crate) const GEOG_ANGULAR_UNITS: u16 = 2054;
pub(crate) const GEOG_ELLIPSOID: u16 = 2056;
pub(crate) const GEOG_SEMI_MAJOR: u16 = 2057;
pub(crate) const GEOG_SEMI_MINOR: u16 = 2058;
pub(crate) const GEOG_INV_FLATTENING: u16 = 2059;
pub(crate) const PROJECTED_TYPE: u16 = 3072;
pub(crate) const PCS_CITATION: u16 = 3073;
pub(crate) const PROJECTION: u16 = 3074;
pub(crate) const COORD_TRANS: u16 = 3075;
pub(crate) const LINEAR_UNITS: u16 = 3076;
pub(crate) const STD_PARALLEL_1: u16 = 3078;
pub(crate) const STD_PARALLEL_2: u16 = 3079;
pub(crate) const NAT_ORIGIN_LONG: u16 = 3080;
pub(crate) const NAT_ORIGIN_LAT: u16 = 3081;
pub(crate) const FALSE_EASTING: u16 = 3082;
pub(crate) const FALSE_NORTHING: u16 = 3083;
pub(crate) const FALSE_ORIGIN_LONG: u16 = 3084;
pub(crate) const FALSE_ORIGIN_LAT: u16 = 3085;
pub(crate) const FALSE_ORIGIN_EASTING: u16 = 3086;
pub(crate) const FALSE_ORIGIN_NORTHING: u16 = 3087;
pub(crate) const CENTER_LONG: u16 = 3088;
pub(crate) const CENTER_LAT: u16 = 3089;
pub(crate) const SCALE_AT_NAT_ORIGIN: u16 = 3092;

/// The name of a key in messages: "ProjCoordTransGeoKey (3075)".
pub(crate) fn key_name(id: u16) -> String {
    let name = match id {
        MODEL_TYPE => "GTModelTypeGeoKey",
        RASTER_TYPE => "GTRasterTypeGeoKey",
        GEOGRAPHIC_TYPE => "GeographicTypeGeoKey",
        GEOG_DATUM => "GeogGeodeticDatumGeoKey",
        GEOG_PRIME_MERIDIAN => "GeogPrimeMeridianGeoKey",
        GEOG_ANGULAR_UNITS => "GeogAngularUnitsGeoKey",
        GEOG_ELLIPSOID => "GeogEllipsoidGeoKey",
        PROJECTED_TYPE => "ProjectedCSTypeGeoKey",
        PROJECTION => "ProjectionGeoKey",
        COORD_TRANS => "ProjCoordTransGeoKey",
        LINEAR_UNITS => "ProjLinearUnitsGeoKey",
        _ => "GeoKey",
    };
    format!("{name} ({id})")
}
