//! Digital elevation models read from a single-band GeoTIFF: heights as f32 (integer and
//! double DEMs converted), nodata as NaN, with the grid and CRS. Sampling is done elsewhere.

use crate::error::IoError;
use crate::geotiff::{GeoReference, read_georeference};
use crate::tiff_file;
use aerorect_core::ImageSize;
use std::path::Path;

/// A DEM: `heights[r * width + c]` is the height at the centre of pixel (c, r), NaN where the
/// file has no data.
#[derive(Debug, Clone, PartialEq)]
pub struct Dem {
    pub size: ImageSize,
    pub heights: Vec<f32>,
    /// The grid and CRS; `geo.nodata` keeps the file's GDAL_NODATA value (already NaN in
    /// `heights`).
    pub geo: GeoReference,
}

impl Dem {
    /// The height at pixel (c, r); `None` outside the grid or on nodata.
    pub fn height_at(&self, c: usize, r: usize) -> Option<f32> {
        if c >= self.size.width || r >= self.size.height {
            return None;
        }
        let h = self.heights[r * self.size.width + c];
        (!h.is_nan()).then_some(h)
    }
}

/// Reads a single-band GeoTIFF DEM. Refused, naming the file: a file that is not a TIFF, more
/// than one band, no georeferencing, and no valid height at all.
pub fn read_dem(path: &Path) -> Result<Dem, IoError> {
    let geo = read_georeference(path)?.ok_or_else(|| {
        IoError::field(
            path.display(),
            "DEM has no georeferencing (no GeoKeyDirectory, tag 34735)",
        )
    })?;
    let decoded = tiff_file::decode(path)?;
    if decoded.bands != 1 {
        return Err(IoError::field(
            path.display(),
            format!("DEM has {} bands, not one", decoded.bands),
        ));
    }
    let mut heights = tiff_file::samples_f32(decoded.samples);
    if let Some(nd) = geo.nodata.filter(|v| !v.is_nan()) {
        // Compared as the f32 the samples became, so 1e30-style nodata matches too.
        let nd = nd as f32;
        for h in heights.iter_mut().filter(|h| **h == nd) {
            *h = f32::NAN;
        }
    }
    for h in heights.iter_mut().filter(|h| h.is_infinite()) {
        *h = f32::NAN;
    }
    if heights.iter().all(|h| h.is_nan()) {
        return Err(IoError::field(
            path.display(),
            format!("DEM {} has no valid height", path.display()),
        ));
    }
    Ok(Dem {
        size: decoded.size,
        heights,
        geo,
    })
}
