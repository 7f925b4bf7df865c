//! How to warp: the interpolation, the coordinates, the options.

use crate::error::RasterError;
use crate::raster::Sample;

/// How the destination pixels' source positions are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Coordinates {
    /// Every position in f64, as the map gives it.
    Exact,
    /// For projective maps (`PixelMap::projective`): per block of a row (1024 pixels, or 512
    /// or 256 where a longer block's bound is too large), the first position in f64 and the
    /// others as f32 offsets from it, where the block's own error bound is at most
    /// `FAST_MAX_ERROR` (5e-4 px; see `relative`); other blocks, other maps, and the average
    /// kernel (an area, not positions) are exact.
    #[default]
    Fast,
}

/// The interpolation kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Interp {
    Nearest,
    #[default]
    Bilinear,
    /// Keys' cubic convolution with a = -0.5.
    Bicubic,
    /// The mean of the source pixels under the destination pixel's footprint, weighted by the
    /// area they share with it (GDAL's `-r average`, OpenCV's `INTER_AREA`); see `area`.
    Average,
}

impl Interp {
    pub fn name(&self) -> &'static str {
        match self {
            Interp::Nearest => "nearest",
            Interp::Bilinear => "bilinear",
            Interp::Bicubic => "bicubic",
            Interp::Average => "average",
        }
    }
}

impl std::str::FromStr for Interp {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "nearest" => Ok(Interp::Nearest),
            "bilinear" => Ok(Interp::Bilinear),
            "bicubic" => Ok(Interp::Bicubic),
            "average" => Ok(Interp::Average),
            _ => Err(format!(
                "unknown interpolation '{s}': expected nearest, bilinear, bicubic or average"
            )),
        }
    }
}

/// How to warp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarpOptions {
    pub interp: Interp,
    /// The value written where the source has no pixel (must fit the sample type).
    pub nodata: f64,
    /// Append an alpha band: OPAQUE where the source had the pixel, 0 elsewhere.
    pub alpha: bool,
    /// Bilinear and bicubic read a 2 x 2 box-reduced pyramid level where the destination is more
    /// than twice coarser than the source, so they do not alias (see `prefilter`); false keeps
    /// the plain kernels everywhere. No effect at scales below 2 (bit for bit).
    pub prefilter: bool,
    /// Exact or fast source positions (see `Coordinates`).
    pub coordinates: Coordinates,
}

impl Default for WarpOptions {
    fn default() -> Self {
        Self {
            interp: Interp::Bilinear,
            nodata: 0.0,
            alpha: false,
            prefilter: true,
            coordinates: Coordinates::default(),
        }
    }
}

impl WarpOptions {
    /// The nodata value in the sample type, or an error when it does not fit.
    pub fn nodata_as<T: Sample>(&self) -> Result<T, RasterError> {
        T::from_f64_exact(self.nodata).ok_or(RasterError::InvalidNodata {
            value: self.nodata,
            sample: T::NAME,
        })
    }

    /// Bands of the destination for a source of `bands` bands.
    pub fn output_bands(&self, bands: usize) -> usize {
        bands + usize::from(self.alpha)
    }
}

impl WarpOptions {
    /// Checks the nodata value fits the sample type of `img`.
    pub fn nodata_as_for(&self, img: &crate::AnyRaster) -> Result<(), RasterError> {
        match img {
            crate::AnyRaster::U8(_) => self.nodata_as::<u8>().map(|_| ()),
            crate::AnyRaster::U16(_) => self.nodata_as::<u16>().map(|_| ()),
            crate::AnyRaster::F32(_) => self.nodata_as::<f32>().map(|_| ()),
        }
    }
}
