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
