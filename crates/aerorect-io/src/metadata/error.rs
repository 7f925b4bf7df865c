//! The errors of a photo's metadata tags, before the file's name is known (`IoError::Metadata`
//! adds it).

use thiserror::Error;

/// A metadata packet or tag that cannot be read; each names the tag and its value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum MetadataError {
    /// The XMP packet is not XML (the parser's error is shown, not chained).
    #[error(
        "the XMP packet is not valid XML ({0}): its attitude and camera tags cannot be read; repair or remove the XMP"
    )]
    Xml(roxmltree::Error),
    #[error("XMP {prefix}:{tag} = '{value}' is not a number")]
    XmpNumber {
        prefix: String,
        tag: String,
        value: String,
    },
    /// A DJI height beyond 100 km (no flight; 1e308 used to reach the homography as "singular").
    #[error("XMP drone-dji:{tag} = '{value}' is outside the sane range |h| <= 100000 m")]
    Height { tag: String, value: String },
    /// GDAL's metadata tag (42112) is not XML (the parser's error is shown, not chained).
    #[error("GDAL metadata (tag 42112): {0}")]
    GdalXml(roxmltree::Error),
    #[error("GDAL metadata {item} = '{value}' is not a number")]
    GdalNumber { item: String, value: String },
}
