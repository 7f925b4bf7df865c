//! The COG options checked against the image before anything is written: tile size, Deflate
//! level, bands, mask, nodata and JPEG's limits.

use super::option_error::CogOptionError;
use super::{CogCompression, CogMask, CogOptions};
use crate::geotiff::GeoReference;
use aerorect_raster::{AnyRaster, Sample};

impl CogOptions {
    /// Checks the options against the image (`geo` may carry the nodata value).
    pub fn validate(
        &self,
        raster: &AnyRaster,
        geo: Option<&GeoReference>,
    ) -> Result<(), CogOptionError> {
        let t = self.tile;
        if !(16..=4096).contains(&t) || !t.is_multiple_of(16) {
            return Err(CogOptionError::Tile(t));
        }
        if !(1..=9).contains(&self.deflate_level) {
            return Err(CogOptionError::DeflateLevel(self.deflate_level));
        }
        let bands = raster.bands();
        if !(1..=4).contains(&bands) {
            return Err(CogOptionError::Bands(bands));
        }
        let out_bands = self.output_bands(raster)?;
        let nodata = self.nodata.or(geo.and_then(|g| g.nodata));
        if let Some(nd) = nodata {
            check_nodata(nd, raster, &self.mask)?;
        }
        if let CogCompression::Jpeg { quality } = self.compression {
            if !matches!(raster, AnyRaster::U8(_)) || !(out_bands == 1 || out_bands == 3) {
                return Err(CogOptionError::JpegImage {
                    sample: raster.sample_name(),
                    bands: out_bands,
                });
            }
            if !(1..=100).contains(&quality) {
                return Err(CogOptionError::JpegQuality(quality));
            }
            if nodata.is_some() {
                return Err(CogOptionError::JpegNodata);
            }
        }
        Ok(())
    }

    /// The image bands written, the mask apart.
    fn output_bands(&self, raster: &AnyRaster) -> Result<usize, CogOptionError> {
        let (bands, size) = (raster.bands(), raster.size());
        match &self.mask {
            CogMask::None => Ok(bands),
            CogMask::AlphaBand if bands == 2 || bands == 4 => Ok(bands - 1),
            CogMask::AlphaBand => Err(CogOptionError::NoAlpha(bands)),
            CogMask::Plane(m) if m.len() != size.width * size.height => {
                Err(CogOptionError::MaskSize {
                    values: m.len(),
                    width: size.width,
                    height: size.height,
                })
            }
            CogMask::Plane(_) => Ok(bands),
        }
    }
}

/// Nodata beside no mask, and a value of the image's sample type.
fn check_nodata(nd: f64, raster: &AnyRaster, mask: &CogMask) -> Result<(), CogOptionError> {
    if *mask != CogMask::None {
        return Err(CogOptionError::NodataAndMask(nd));
    }
    let exact = match raster {
        AnyRaster::U8(_) => u8::from_f64_exact(nd).is_some(),
        AnyRaster::U16(_) => u16::from_f64_exact(nd).is_some(),
        AnyRaster::F32(_) => f32::from_f64_exact(nd).is_some(),
    };
    if exact {
        Ok(())
    } else {
        Err(CogOptionError::Nodata {
            nodata: nd,
            sample: raster.sample_name(),
        })
    }
}
