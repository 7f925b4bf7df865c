use thiserror::Error;

/// Errors of the pipelines; each carries the file or option it is about.
#[derive(Debug, Error)]
pub enum Error {
    #[error(transparent)]
    Io(#[from] aerorect_io::IoError),
    #[error("{context}: {error}")]
    Geometry {
        context: String,
        error: aerorect_core::GeometryError,
    },
    #[error(transparent)]
    Raster(#[from] aerorect_raster::RasterError),
    /// A request that cannot be carried out as asked.
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    pub fn geometry(context: impl ToString) -> impl FnOnce(aerorect_core::GeometryError) -> Error {
        move |error| Error::Geometry {
            context: context.to_string(),
            error,
        }
    }
}
