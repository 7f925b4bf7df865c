//! NumPy arrays <-> rasters: `(bands, rows, cols)` like rasterio (a 2-D array is one band).

use crate::py_err;
use aerorect::core::ImageSize;
use aerorect::raster::{AnyRaster, Raster, Sample};
use numpy::ndarray::{Array3, ArrayViewD, Axis};
use numpy::{Element, IntoPyArray, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// The planes of a 2-D or 3-D array (band-major, each row-major).
fn planes_of<T: Element + Copy>(a: ArrayViewD<'_, T>) -> PyResult<(ImageSize, Vec<Vec<T>>)> {
    let a = match a.ndim() {
        2 => a.insert_axis(Axis(0)),
        3 => a,
        n => {
            return Err(py_err(anyhow::anyhow!(
                "the array has {n} dimensions: expected (rows, cols) or (bands, rows, cols)"
            )));
        }
    };
    let shape = a.shape();
    let size = ImageSize::new(shape[2], shape[1]);
    let planes = a
        .axis_iter(Axis(0))
        .map(|p| p.iter().copied().collect())
        .collect();
    Ok((size, planes))
}

fn raster_of<T: Element + Sample + Copy>(a: ArrayViewD<'_, T>) -> PyResult<Raster<T>> {
    let (size, planes) = planes_of(a)?;
    Raster::from_planes(size, planes).map_err(py_err)
}

/// A raster from a u8, u16 or f32 array (other types are refused, naming theirs).
pub fn raster_from_array(a: &Bound<'_, PyAny>) -> PyResult<AnyRaster> {
    if let Ok(x) = a.extract::<PyReadonlyArrayDyn<'_, u8>>() {
        return Ok(AnyRaster::U8(raster_of(x.as_array())?));
    }
    if let Ok(x) = a.extract::<PyReadonlyArrayDyn<'_, u16>>() {
        return Ok(AnyRaster::U16(raster_of(x.as_array())?));
    }
    if let Ok(x) = a.extract::<PyReadonlyArrayDyn<'_, f32>>() {
        return Ok(AnyRaster::F32(raster_of(x.as_array())?));
    }
    let what = match a.cast::<numpy::PyUntypedArray>() {
        Ok(u) => format!("a {} array", u.dtype()),
        Err(_) => format!("a {}", a.get_type().name()?),
    };
    Err(py_err(anyhow::anyhow!(
        "{what}: expected a NumPy array of uint8, uint16 or float32"
    )))
}

/// One band as f32 (the shift estimators' input): a 2-D array, or the gray of a 3-D one.
pub fn gray_from_array(a: &Bound<'_, PyAny>) -> PyResult<(ImageSize, Vec<f32>)> {
    let r = raster_from_array(a)?;
    let g = aerorect::motion::gray(&r).map_err(py_err)?;
    Ok((g.size(), g.plane(0).to_vec()))
}

fn array_of<'py, T: Element + Sample + Copy>(
    py: Python<'py>,
    r: &Raster<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let s = r.size();
    let flat: Vec<T> = r.planes().iter().flatten().copied().collect();
    let a = Array3::from_shape_vec((r.bands(), s.height, s.width), flat).map_err(py_err)?;
    Ok(a.into_pyarray(py).into_any())
}

/// The `(bands, rows, cols)` array of a raster.
pub fn array_from_raster<'py>(py: Python<'py>, r: &AnyRaster) -> PyResult<Bound<'py, PyAny>> {
    match r {
        AnyRaster::U8(x) => array_of(py, x),
        AnyRaster::U16(x) => array_of(py, x),
        AnyRaster::F32(x) => array_of(py, x),
    }
}

/// NumPy's name of a raster's sample type (rasterio's `dtype`).
pub fn dtype_name(r: &AnyRaster) -> &'static str {
    match r {
        AnyRaster::U8(_) => "uint8",
        AnyRaster::U16(_) => "uint16",
        AnyRaster::F32(_) => "float32",
    }
}
