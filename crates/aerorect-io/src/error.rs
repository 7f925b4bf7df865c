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
    Decode {
        source_name: String,
        reason: CodecError,
    },
    #[error("{source_name}: cannot write image: {reason}")]
    Encode {
        source_name: String,
        reason: CodecError,
    },
    /// A metadata tag (EXIF, XMP) that cannot be read.
    #[error("{source_name}: {error}")]
    Metadata {
        source_name: String,
        error: crate::metadata::error::MetadataError,
    },
    /// A photo's EXIF block that cannot be read (the exif crate's own error).
    #[error("{source_name}: EXIF: {error}")]
    Exif {
        source_name: String,
        error: Box<exif::Error>,
    },
    /// A CRS that cannot be read or written in the form asked for.
    #[error(transparent)]
    Crs(#[from] aerorect_geo::CrsError),
    /// A model read from a file that does not hold (a DEM too small, with no valid height).
    #[error(transparent)]
    Geo(#[from] aerorect_geo::GeoError),
    /// A line of a text table (a GCP or exterior-orientation file) that cannot be read.
    #[error("{source_name}: {error}")]
    Table {
        source_name: String,
        error: Box<crate::table_error::TableError>,
    },
    /// A GeoTIFF's GeoKeys that do not describe a CRS this reader builds.
    #[error("{source_name}: GeoKeyDirectory: {error}")]
    GeoKeys {
        source_name: String,
        error: Box<crate::geokeys::error::GeoKeyError>,
    },
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

    pub(crate) fn decode(path: &Path, reason: impl Into<CodecError>) -> Self {
        IoError::Decode {
            source_name: path.display().to_string(),
            reason: reason.into(),
        }
    }

    pub(crate) fn encode(path: &Path, reason: impl Into<CodecError>) -> Self {
        IoError::Encode {
            source_name: path.display().to_string(),
            reason: reason.into(),
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

    pub(crate) fn table(source_name: impl ToString, error: crate::table_error::TableError) -> Self {
        IoError::Table {
            source_name: source_name.to_string(),
            error: Box::new(error),
        }
    }

    pub(crate) fn field(source_name: impl ToString, message: impl ToString) -> Self {
        IoError::Field {
            source_name: source_name.to_string(),
            message: message.to_string(),
        }
    }
}

/// Why an image could not be decoded or encoded: the codec's or the writer's own error, kept as
/// its type (its text is the message), or one of the readers' and writers' own checks.
#[derive(Debug, Error)]
pub enum CodecError {
    #[error(transparent)]
    Tiff(#[from] tiff::TiffError),
    #[error(transparent)]
    Image(#[from] image::ImageError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Raster(#[from] aerorect_raster::RasterError),
    #[error(transparent)]
    Crs(#[from] aerorect_geo::CrsError),
    /// A CRS with no WKT for the `.prj` beside an image.
    #[error("no WKT for the .prj: {0}")]
    NoWkt(aerorect_geo::CrsError),
    /// COG options that do not suit the image.
    #[error(transparent)]
    Cog(#[from] crate::cog::option_error::CogOptionError),
    /// The GeoKeys of a CRS that cannot be written.
    #[error(transparent)]
    GeoKeys(Box<IoError>),
    /// A check of the reader or writer itself (a layout TIFF cannot hold, an unknown format).
    #[error("{0}")]
    Check(String),
}

impl From<IoError> for CodecError {
    fn from(e: IoError) -> Self {
        CodecError::GeoKeys(Box::new(e))
    }
}

impl From<String> for CodecError {
    fn from(text: String) -> Self {
        CodecError::Check(text)
    }
}

impl From<&str> for CodecError {
    fn from(text: &str) -> Self {
        CodecError::Check(text.to_string())
    }
}
