//! Digital elevation models read from a single-band GeoTIFF into the terrain model the planner
//! samples ([`aerorect_geo::Dem`]): heights as f32 (integer and double DEMs converted), nodata as
//! NaN, the north-up grid and its CRS. Sampling is done there.

use crate::error::IoError;
use crate::geotiff::read_georeference;
use crate::tiff_file;
use aerorect_geo::Dem;
use std::path::Path;

/// Reads a single-band GeoTIFF DEM (any CRS the file states); `Dem::name` is the path. Refused,
/// naming the file: a file that is not a TIFF, more than one band, no georeferencing, no valid
/// height at all, a rotated grid, and what [`Dem::validate`] refuses (fewer than 2 x 2 cells, a
/// height beyond the sane range).
pub fn read_dem(path: &Path) -> Result<Dem, IoError> {
    let name = path.display().to_string();
    let geo = read_georeference(path)?.ok_or_else(|| {
        IoError::field(
            &name,
            "DEM has no georeferencing (no GeoKeyDirectory, tag 34735)",
        )
    })?;
    let decoded = tiff_file::decode(path)?;
    if decoded.bands != 1 {
        return Err(IoError::field(
            &name,
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
            &name,
            format!("DEM {name} has no valid height"),
        ));
    }
    if geo.rotation != [0.0, 0.0] {
        return Err(IoError::field(
            format!("DEM {name}"),
            format!(
                "a rotated grid (geotransform terms {:?}) is not supported",
                geo.rotation
            ),
        ));
    }
    let dem = Dem {
        name,
        values: heights,
        width: decoded.size.width,
        height: decoded.size.height,
        top_left: geo.top_left,
        cell_size: geo.pixel_size,
        crs: geo.crs,
    };
    dem.validate()?;
    Ok(dem)
}
