//! `aerorect._aerorect`: the Python face of the aerorect facade. NumPy arrays in and out
//! (`(bands, rows, cols)`, u8/u16/f32), the GIL released around every heavy call, errors raised
//! as `aerorect.AerorectError` (a `ValueError`: bad input) or `aerorect.AerorectFileError` (an
//! `OSError`: a file that could not be read or written) with the CLI's messages.
//! `aerorect/__init__.py` re-exports both.

mod arrays;
mod batch;
mod camera;
mod flight;
mod mosaic;
mod options;
mod photo;

use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _aerorect,
    AerorectError,
    PyValueError,
    "An aerorect error: bad input, a bad value in a file, a geometry with no answer. The message is the CLI's."
);

create_exception!(
    _aerorect,
    AerorectFileError,
    PyOSError,
    "A file aerorect could not read or write (missing, no permission, disk full). The message is the CLI's."
);

/// `e` as the CLI prints it (the context chain joined by ': '): an `AerorectFileError` when its
/// cause is a file that could not be read or written, else an `AerorectError`.
pub(crate) fn py_err(e: impl Into<anyhow::Error>) -> PyErr {
    let e = e.into();
    let text = format!("{e:#}");
    if is_file_error(&e) {
        AerorectFileError::new_err(text)
    } else {
        AerorectError::new_err(text)
    }
}

/// Whether a cause in `e`'s chain is an I/O error on a file (not a bad value read from one).
fn is_file_error(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<std::io::Error>()
            || c.downcast_ref::<aerorect::Error>()
                .is_some_and(aerorect::Error::is_file_error)
            || c.downcast_ref::<aerorect::io::IoError>()
                .is_some_and(aerorect::io::IoError::is_file_error)
    })
}

/// A serialisable value as the Python object `json.loads` makes of it.
pub(crate) fn to_py<'py>(
    py: Python<'py>,
    v: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(py_err)?;
    py.import("json")?.call_method1("loads", (text,))
}

#[pymodule]
fn _aerorect(m: &Bound<'_, PyModule>) -> PyResult<()> {
    options::KEYWORDS.use_for_process();
    m.add("AerorectError", m.py().get_type::<AerorectError>())?;
    m.add("AerorectFileError", m.py().get_type::<AerorectFileError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add(
        "DEFAULT_MAX_OUTPUT_PX",
        aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX,
    )?;
    m.add_class::<camera::Camera>()?;
    m.add_class::<flight::AdjustedFlight>()?;
    m.add_class::<flight::FlightPlan>()?;
    m.add_class::<mosaic::MosaicTiles>()?;
    m.add_function(wrap_pyfunction!(photo::rectify_photo, m)?)?;
    m.add_function(wrap_pyfunction!(photo::rectify_photo_to_file, m)?)?;
    m.add_function(wrap_pyfunction!(photo::read_photo_metadata, m)?)?;
    m.add_function(wrap_pyfunction!(camera::rectify, m)?)?;
    m.add_function(wrap_pyfunction!(camera::warp, m)?)?;
    m.add_function(wrap_pyfunction!(camera::undistort, m)?)?;
    m.add_function(wrap_pyfunction!(camera::shift, m)?)?;
    m.add_function(wrap_pyfunction!(camera::calibrate, m)?)?;
    m.add_function(wrap_pyfunction!(batch::batch, m)?)?;
    m.add_function(wrap_pyfunction!(flight::adjust_flight, m)?)?;
    m.add_function(wrap_pyfunction!(flight::write_adjusted_batch, m)?)?;
    m.add_function(wrap_pyfunction!(flight::mosaic, m)?)?;
    m.add_function(wrap_pyfunction!(mosaic::plan_mosaic, m)?)?;
    Ok(())
}
