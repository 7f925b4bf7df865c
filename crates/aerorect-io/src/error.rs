use std::path::Path;
use thiserror::Error;

/// An I/O or format error; `source` is the file path or the command-line argument concerned.
#[derive(Debug, Error)]
pub enum IoError {
    #[error("{source_name}: {error}")]
    Io {
        source_name: String,
        error: std::io::Error,
    },
    #[error("{source_name}: cannot decode image: {reason}")]
    Decode { source_name: String, reason: String },
    #[error("{source_name}: cannot write image: {reason}")]
    Encode { source_name: String, reason: String },
    /// A metadata tag (EXIF, XMP) that cannot be read.
    #[error("{source_name}: {error}")]
    Metadata {
        source_name: String,
        error: crate::metadata::error::MetadataError,
    },
    /// A CRS that cannot be read or written in the form asked for.
    #[error(transparent)]
    Crs(#[from] aerorect_geo::CrsError),
    /// A model read from a file that does not hold (a DEM too small, with no valid height).
    #[error(transparent)]
    Geo(#[from] aerorect_geo::GeoError),
    /// A field is missing, unknown, or has a bad value.
    #[error("{source_name}: {message}")]
    Field {
        source_name: String,
        message: String,
    },
}

impl IoError {
    /// Whether the file itself could not be read or written (missing, no permission, disk
    /// full), as opposed to a bad value in it.
    pub fn is_file_error(&self) -> bool {
        matches!(self, IoError::Io { .. })
    }

    pub(crate) fn io(path: &Path, error: std::io::Error) -> Self {
        IoError::Io {
            source_name: path.display().to_string(),
            error,
        }
    }

    pub(crate) fn decode(path: &Path, reason: impl ToString) -> Self {
        IoError::Decode {
            source_name: path.display().to_string(),
            reason: reason.to_string(),
        }
    }

    pub(crate) fn encode(path: &Path, reason: impl ToString) -> Self {
        IoError::Encode {
            source_name: path.display().to_string(),
            reason: reason.to_string(),
        }
    }

    pub(crate) fn metadata(
        source_name: impl ToString,
        error: crate::metadata::error::MetadataError,
    ) -> Self {
        IoError::Metadata {
            source_name: source_name.to_string(),
            error,
        }
    }

    pub(crate) fn field(source_name: impl ToString, message: impl ToString) -> Self {
        IoError::Field {
            source_name: source_name.to_string(),
            message: message.to_string(),
        }
    }
}
