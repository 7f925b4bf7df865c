//! Why COG options do not suit an image (checked by `CogOptions::validate`).

use thiserror::Error;

/// COG options that do not suit the image; each names the value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CogOptionError {
    #[error("COG tile size {0}: use a multiple of 16 from 16 to 4096")]
    Tile(usize),
    #[error("Deflate level {0}: use 1 to 9")]
    DeflateLevel(u32),
    #[error("COG output holds 1 to 4 bands, this image has {0}")]
    Bands(usize),
    #[error("COG mask from the alpha band: the image has {0} bands, not 2 or 4")]
    NoAlpha(usize),
    #[error("COG mask has {values} values, the image {width} x {height} pixels")]
    MaskSize {
        values: usize,
        width: usize,
        height: usize,
    },
    #[error("COG with both nodata {0} and a mask: choose one")]
    NodataAndMask(f64),
    #[error("nodata {nodata} is not a {sample} value")]
    Nodata { nodata: f64, sample: &'static str },
    #[error(
        "JPEG COG takes 8-bit images of 1 or 3 bands (an alpha band as the mask), this one is {sample} with {bands} bands: use Deflate"
    )]
    JpegImage { sample: &'static str, bands: usize },
    #[error("JPEG quality {0}: use 1 to 100")]
    JpegQuality(u8),
    #[error(
        "JPEG COG with a nodata value: JPEG changes the values; use a mask (CogMask) or Deflate"
    )]
    JpegNodata,
}
