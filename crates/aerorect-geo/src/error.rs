use thiserror::Error;

/// Errors of georeferencing, each naming what it was about and the value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeoError {
    #[error("CRS '{definition}': {reason}")]
    Crs { definition: String, reason: String },
    #[error("cannot project ({x}, {y}) from '{from}' to '{to}': {reason}")]
    Transform {
        x: f64,
        y: f64,
        from: String,
        to: String,
        reason: String,
    },
    #[error("DEM: {0}")]
    Dem(String),
    #[error(transparent)]
    Geometry(#[from] aerorect_core::GeometryError),
}

/// A CRS that cannot be read, built or written in the form asked for.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CrsError {
    /// Text that names no CRS this build reads (not EPSG:<code>, PROJ or WKT; an unknown EPSG
    /// code; a WKT that does not convert), or a CRS with no WKT or GeoKeys form.
    #[error("CRS: {0}")]
    Text(String),
    /// A PROJ definition proj4rs does not build.
    #[error("CRS: '{}' does not parse: {reason}", crate::crs::short(.definition))]
    Proj { definition: String, reason: String },
}
