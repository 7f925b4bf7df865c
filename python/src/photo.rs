//! Drone photos from their own metadata: the ortho in memory with a rasterio profile, or
//! written as `aerorect rectify PHOTO OUT` writes it.

use crate::arrays::{array_from_raster, dtype_name};
use crate::options::PhotoArgs;
use crate::{py_err, to_py};
use aerorect::io::GeoReference;
use aerorect::raster::AnyRaster;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;

/// rasterio's profile of an ortho: crs, transform (Affine's a, b, c, d, e, f), nodata, size,
/// band count, dtype, and the GeoTIFF driver.
fn profile<'py>(
    py: Python<'py>,
    image: &AnyRaster,
    geo: &GeoReference,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let size = image.size();
    d.set_item("driver", "GTiff")?;
    d.set_item("crs", geo.crs.to_string())?;
    let [px, py_] = geo.pixel_size;
    let [x0, y0] = geo.top_left;
    let [b, dd] = geo.rotation;
    d.set_item("transform", PyTuple::new(py, [px, b, x0, dd, -py_, y0])?)?;
    d.set_item("nodata", geo.nodata)?;
    d.set_item("width", size.width)?;
    d.set_item("height", size.height)?;
    d.set_item("count", image.bands())?;
    d.set_item("dtype", dtype_name(image))?;
    Ok(d)
}

/// The ortho of a photo from its metadata: `(array, profile, report)`.
#[pyfunction]
#[pyo3(signature = (path, opts=None))]
pub fn rectify_photo<'py>(
    py: Python<'py>,
    path: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let args = PhotoArgs::from_dict(opts)?;
    let (image, r) = py
        .detach(|| -> anyhow::Result<_> {
            let o = args.options(Some(&path))?;
            Ok(aerorect::drone::ortho_photo(&path, &o, None)?)
        })
        .map_err(py_err)?;
    let prof = profile(py, &image, &r.info.geo)?;
    let array = array_from_raster(py, &image)?;
    PyTuple::new(py, [array, prof.into_any(), to_py(py, &r)?])
}

/// Rectifies a photo from its metadata and writes `out` (GeoTIFF, COG, or PNG + world file)
/// as the CLI does; returns the report.
#[pyfunction]
#[pyo3(signature = (path, out, opts=None))]
pub fn rectify_photo_to_file<'py>(
    py: Python<'py>,
    path: PathBuf,
    out: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let args = PhotoArgs::from_dict(opts)?;
    let r = py
        .detach(|| -> anyhow::Result<_> {
            let o = args.options(Some(&path))?;
            Ok(aerorect::drone::rectify_photo(&path, &out, &o, None)?)
        })
        .map_err(py_err)?;
    to_py(py, &r)
}

/// What a photo's EXIF and XMP say (camera, position, DJI gimbal and flight angles...).
#[pyfunction]
pub fn read_photo_metadata<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let m = py
        .detach(|| aerorect::io::read_photo_metadata(&path))
        .map_err(py_err)?;
    to_py(py, &m)
}
