//! The building blocks: cameras, the six-angle rectification, a homography warp, lens
//! undistortion, sub-pixel shifts and calibration, on NumPy arrays.

use crate::arrays::{array_from_raster, gray_from_array, raster_from_array};
use crate::{py_err, to_py};
use aerorect::core::attitude::SixAngleDegrees;
use aerorect::core::distortion::Distortion;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::core::{
    AltitudeScale, Homography, ImageSize, Intrinsics, Mat3, RectifyLimits, SixAngleAttitude,
};
use aerorect::io::CameraFile;
use aerorect::raster::{Interp, WarpOptions};
use aerorect::rectify::RectifyPlan;
use aerorect::undistort::UndistortPlan;
use anyhow::Context;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;

/// Python's json.dumps of an object, parsed as `T`.
fn from_py<T: serde::de::DeserializeOwned>(v: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    let text: String = v
        .py()
        .import("json")?
        .call_method1("dumps", (v,))?
        .extract()?;
    serde_json::from_str(&text).map_err(|e| py_err(anyhow::anyhow!("{what}: {e}")))
}

fn warp_options(interp: &str, nodata: f64, alpha: bool) -> PyResult<WarpOptions> {
    let interp = interp
        .parse::<Interp>()
        .map_err(|e| py_err(anyhow::anyhow!("--interp '{interp}': {e}")))?;
    Ok(WarpOptions {
        interp,
        nodata,
        alpha,
        prefilter: true,
        ..WarpOptions::default()
    })
}

/// A frame camera: intrinsics in pixels of `width` x `height`, and an optional lens model.
#[pyclass(module = "aerorect", frozen)]
#[derive(Clone)]
pub struct Camera {
    pub inner: aerorect::core::Camera,
}

#[pymethods]
impl Camera {
    /// A camera file (TOML, as `--camera` takes it), sized to `image_size` = (width, height)
    /// when given (the file's `image_size_px` otherwise).
    #[staticmethod]
    #[pyo3(signature = (path, image_size=None))]
    fn from_file(path: PathBuf, image_size: Option<(usize, usize)>) -> PyResult<Self> {
        let f = CameraFile::read(&path).map_err(py_err)?;
        let size = image_size.map(|(w, h)| ImageSize::new(w, h));
        Ok(Self {
            inner: f.camera(size).map_err(py_err)?,
        })
    }

    /// The camera of a photo from its own tags (DJI DewarpData or calibration tags, the
    /// sensor database, or the 35 mm equivalent), sized to the image (from its header).
    #[staticmethod]
    fn from_metadata(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let cam = py
            .detach(|| -> anyhow::Result<_> {
                let meta = aerorect::io::read_photo_metadata(&path)?;
                let size = aerorect::io::read_image_size(&path)?;
                let file = path.display().to_string();
                Ok(aerorect::drone::camera_from_metadata(&meta, size, &file)?.camera)
            })
            .map_err(py_err)?;
        Ok(Self { inner: cam })
    }

    /// Intrinsics in pixels (principal point from the top-left pixel's centre) of an image of
    /// `width` x `height`; `distortion` a dict like a camera file's `[distortion]` table
    /// (`{"model": "opencv", "k1": ..}`).
    #[staticmethod]
    #[pyo3(signature = (fx, fy, cx, cy, width, height, distortion=None))]
    fn from_intrinsics(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        width: usize,
        height: usize,
        distortion: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let k = Intrinsics::new(fx, fy, cx, cy).map_err(py_err)?;
        let d: Option<Distortion> = distortion.map(|d| from_py(d, "distortion")).transpose()?;
        Ok(Self {
            inner: aerorect::core::Camera::new(k, d, ImageSize::new(width, height)),
        })
    }

    /// The same camera for the image resampled to `width` x `height` (same aspect ratio).
    fn resized(&self, width: usize, height: usize) -> PyResult<Self> {
        Ok(Self {
            inner: self
                .inner
                .resized(ImageSize::new(width, height))
                .map_err(py_err)?,
        })
    }

    #[getter]
    fn fx(&self) -> f64 {
        self.inner.intrinsics.fx
    }
    #[getter]
    fn fy(&self) -> f64 {
        self.inner.intrinsics.fy
    }
    #[getter]
    fn cx(&self) -> f64 {
        self.inner.intrinsics.cx
    }
    #[getter]
    fn cy(&self) -> f64 {
        self.inner.intrinsics.cy
    }
    #[getter]
    fn width(&self) -> usize {
        self.inner.size.width
    }
    #[getter]
    fn height(&self) -> usize {
        self.inner.size.height
    }
    /// The lens model as a dict (`model` and its coefficients), or None.
    #[getter]
    fn distortion<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner.distortion)
    }

    /// The camera file (TOML) of this camera.
    fn to_toml(&self) -> PyResult<String> {
        aerorect::io::camera_toml(&self.inner).map_err(py_err)
    }

    fn __repr__(&self) -> String {
        let k = &self.inner.intrinsics;
        format!(
            "Camera(fx={}, fy={}, cx={}, cy={}, width={}, height={}, distortion={})",
            k.fx,
            k.fy,
            k.cx,
            k.cy,
            self.inner.size.width,
            self.inner.size.height,
            self.inner
                .distortion
                .as_ref()
                .map_or("None".to_string(), |d| format!("'{}'", d.kind()))
        )
    }

    fn __eq__(&self, other: &Self) -> bool {
        self.inner == other.inner
    }
}

/// Six attitude angles from a dict, an inline `key=value,..` string or a TOML file's path.
fn attitude_of(a: &Bound<'_, PyAny>) -> PyResult<SixAngleAttitude> {
    if let Ok(text) = a.extract::<String>() {
        return aerorect::io::read_attitude(&text).map_err(py_err);
    }
    let d: SixAngleDegrees = from_py(a, "attitude")?;
    SixAngleAttitude::from_degrees(&d).map_err(|e| py_err(anyhow::anyhow!("attitude: {e}")))
}

/// The oblique frame rectified to the standard image from six attitude angles:
/// `(array, report)` (the report is `aerorect rectify --report`'s).
#[pyfunction]
#[pyo3(signature = (array, camera, attitude, *, interp="bilinear", nodata=0.0, alpha=false,
    altitude_m=None, base_altitude_m=None, max_output_px=DEFAULT_MAX_OUTPUT_PX))]
#[allow(clippy::too_many_arguments)]
pub fn rectify<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    camera: &Camera,
    attitude: &Bound<'py, PyAny>,
    interp: &str,
    nodata: f64,
    alpha: bool,
    altitude_m: Option<f64>,
    base_altitude_m: Option<f64>,
    max_output_px: u64,
) -> PyResult<Bound<'py, PyTuple>> {
    let image = raster_from_array(array)?;
    let att = attitude_of(attitude)?;
    let alt = match (altitude_m, base_altitude_m) {
        (None, None) => None,
        (Some(a), Some(b)) => Some(
            AltitudeScale::new(a, b)
                .context("altitude normalisation")
                .map_err(py_err)?,
        ),
        _ => {
            return Err(py_err(anyhow::anyhow!(
                "--altitude-m and --base-altitude-m go together"
            )));
        }
    };
    let warp = warp_options(interp, nodata, alpha)?;
    warp.nodata_as_for(&image)
        .map_err(|e| py_err(anyhow::anyhow!("--nodata {nodata}: {e}")))?;
    let camera = camera.inner.resized(image.size()).map_err(py_err)?;
    let limits = RectifyLimits { max_output_px };
    let (out, report) = py
        .detach(|| -> anyhow::Result<_> {
            let plan = RectifyPlan::new(camera, att, alt, limits, warp)
                .context("cannot rectify with this camera and attitude")?;
            let (out, s) = plan.run(&image)?;
            Ok((out, plan.report("array", "array", s)))
        })
        .map_err(py_err)?;
    PyTuple::new(py, [array_from_raster(py, &out)?, to_py(py, &report)?])
}

/// `array` warped through a homography: output pixel (col, row) takes the input at
/// `homography @ (col, row, 1)` (3 x 3, output -> input); `shape` = (rows, cols) of the output.
#[pyfunction]
#[pyo3(signature = (array, homography, shape, *, interp="bilinear", nodata=0.0, alpha=false))]
pub fn warp<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    homography: [[f64; 3]; 3],
    shape: (usize, usize),
    interp: &str,
    nodata: f64,
    alpha: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let image = raster_from_array(array)?;
    let m = Mat3::from_fn(|r, c| homography[r][c]);
    let h = Homography::new(m).map_err(|e| py_err(anyhow::anyhow!("homography: {e}")))?;
    let warp = warp_options(interp, nodata, alpha)?;
    let size = ImageSize::new(shape.1, shape.0);
    let out = py
        .detach(|| aerorect::warp_any(&image, &h, size, &warp))
        .map_err(py_err)?;
    array_from_raster(py, &out)
}

/// The camera's lens distortion removed: `(array, camera)`, the camera being the ideal
/// pinhole of the output (`fit`: grown to keep every valid pixel).
#[pyfunction]
#[pyo3(signature = (array, camera, *, fit=false, interp="bilinear", nodata=0.0))]
pub fn undistort<'py>(
    py: Python<'py>,
    array: &Bound<'py, PyAny>,
    camera: &Camera,
    fit: bool,
    interp: &str,
    nodata: f64,
) -> PyResult<Bound<'py, PyTuple>> {
    let image = raster_from_array(array)?;
    let camera = camera.inner.resized(image.size()).map_err(py_err)?;
    let warp = warp_options(interp, nodata, false)?;
    let (out, cam) = py
        .detach(|| -> anyhow::Result<_> {
            let plan = UndistortPlan::new(&camera, fit)?;
            Ok((plan.run(&image, &warp)?, plan.output))
        })
        .map_err(py_err)?;
    let cam = Py::new(py, Camera { inner: cam })?
        .into_bound(py)
        .into_any();
    PyTuple::new(py, [array_from_raster(py, &out)?, cam])
}

/// The sub-pixel shift of `b` relative to `a` (same shape): `{"dx", "dy", "confidence"}`.
/// `method`: jtc, jtc-centroid, jtc-parabola, jtc-plain, phase or xcorr.
#[pyfunction]
#[pyo3(signature = (a, b, method="jtc"))]
pub fn shift<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
    b: &Bound<'py, PyAny>,
    method: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let (sa, ga) = gray_from_array(a)?;
    let (sb, gb) = gray_from_array(b)?;
    if sa != sb {
        return Err(py_err(anyhow::anyhow!(
            "the arrays differ in size: {} x {} and {} x {}",
            sa.width,
            sa.height,
            sb.width,
            sb.height
        )));
    }
    let m = aerorect::motion::Method::parse(method).map_err(py_err)?;
    let e = py
        .detach(|| -> anyhow::Result<_> {
            let mut est = m.plan(sa)?;
            Ok(est.estimate(&ga, &gb)?)
        })
        .map_err(py_err)?;
    let d = PyDict::new(py);
    d.set_item("dx", e.dx)?;
    d.set_item("dy", e.dy)?;
    d.set_item("confidence", e.confidence)?;
    Ok(d)
}

/// Intrinsics and distortion from control points (a CSV path with `image,X,Y,Z,u,v`, or a list
/// of such tuples): `(camera, report)`.
#[pyfunction]
#[pyo3(signature = (points, image_size, model="opencv", *, fix=vec![], skew=false,
    fix_aspect=false, stop_px=0.01, max_iterations=200))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    image_size: (usize, usize),
    model: &str,
    fix: Vec<String>,
    skew: bool,
    fix_aspect: bool,
    stop_px: f64,
    max_iterations: usize,
) -> PyResult<Bound<'py, PyTuple>> {
    use aerorect::solve::calib::{CalibrationOptions, Observation, calibrate as solve};
    let obs: Vec<Observation> = if let Ok(p) = points.extract::<PathBuf>() {
        aerorect::calibration::read_observations(&p).map_err(py_err)?
    } else {
        let rows: Vec<(String, f64, f64, f64, f64, f64)> = points.extract()?;
        rows.into_iter()
            .map(|(image, x, y, z, u, v)| Observation {
                image,
                world: [x, y, z],
                pixel: [u, v],
            })
            .collect()
    };
    let size = ImageSize::new(image_size.0, image_size.1);
    let model = Distortion::zero(model)
        .with_context(|| format!("--model '{model}': expected tsai, brown, improved or opencv"))
        .map_err(py_err)?;
    if !(stop_px.is_finite() && stop_px > 0.0) {
        return Err(py_err(anyhow::anyhow!(
            "--stop-px {stop_px}: must be a finite number > 0"
        )));
    }
    let mut opts = CalibrationOptions::new(model, size);
    opts.fix = fix;
    opts.skew = skew;
    opts.fixed_aspect = fix_aspect.then_some(1.0);
    opts.stop_px = stop_px;
    opts.max_iterations = max_iterations;
    let (r, cam) = py
        .detach(|| -> anyhow::Result<_> {
            let r = solve(&obs, &opts)?;
            let cam = r.camera(size)?;
            Ok((r, cam))
        })
        .map_err(py_err)?;
    let cam = Py::new(py, Camera { inner: cam })?
        .into_bound(py)
        .into_any();
    PyTuple::new(py, [cam, to_py(py, &r)?])
}
