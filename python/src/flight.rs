//! A flight: the joint adjustment (`batch --adjust`) and the mosaic.

use crate::options::PhotoArgs;
use crate::{py_err, to_py};
use aerorect::drone::DroneOptions;
use aerorect::io::StagedOutputs;
use aerorect::mosaic::{Blend, MosaicOptions, frames_from_photos, mosaic as build, mosaic_cog};
use anyhow::{Result, bail};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};

/// A flight made consistent from its overlaps: each frame's adjusted pose and camera.
#[pyclass(module = "aerorect")]
pub struct AdjustedFlight {
    flight: aerorect::flight::AdjustedFlight,
    opts: DroneOptions,
}

/// Plans, matches and adjusts a flight as `batch --adjust` does.
#[pyfunction]
#[pyo3(signature = (paths, opts=None))]
pub fn adjust_flight(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    opts: Option<&Bound<'_, PyDict>>,
) -> PyResult<AdjustedFlight> {
    let args = PhotoArgs::from_dict(opts)?;
    py.detach(|| -> Result<_> {
        let o = args.options(None)?;
        let flight = aerorect::flight::adjust_flight(&paths, &o, &args.flight_options()?)?;
        Ok(AdjustedFlight { flight, opts: o })
    })
    .map_err(py_err)
}

#[pymethods]
impl AdjustedFlight {
    /// The matching and adjustment report (`adjustment.json`).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.flight.report)
    }

    fn __len__(&self) -> usize {
        self.flight.len()
    }

    /// Writes frame `k` with its adjusted orientation to `out` (as `batch --adjust` does);
    /// returns its report.
    fn write_frame<'py>(
        &self,
        py: Python<'py>,
        k: usize,
        out: PathBuf,
    ) -> PyResult<Bound<'py, PyAny>> {
        if k >= self.flight.len() {
            return Err(py_err(anyhow::anyhow!(
                "frame {k}: the flight has {} frames",
                self.flight.len()
            )));
        }
        let r = py
            .detach(|| self.flight.write_frame(k, &out, &self.opts))
            .map_err(py_err)?;
        to_py(py, &r)
    }

    /// The mosaic of the adjusted frames (`mosaic --adjust`); returns its report.
    #[pyo3(signature = (out, blend="feather", feather_px=16, cog=false))]
    fn mosaic<'py>(
        &self,
        py: Python<'py>,
        out: PathBuf,
        blend: &str,
        feather_px: usize,
        cog: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mopts = mosaic_options(blend, feather_px, Some(&out)).map_err(py_err)?;
        let r = py
            .detach(|| -> Result<_> {
                let frames = self.flight.mosaic_frames(&self.opts)?;
                write_mosaic(frames, self.flight.crs().clone(), &out, &mopts, cog)
            })
            .map_err(py_err)?;
        to_py(py, &r)
    }
}

/// A flight planned for matching, its adjustment in steps that can run apart (a pair on each
/// worker: `aerorect.distributed`): every step gives what `adjust_flight` gives. A round's
/// progress (orientation, summaries) and a pair's matches travel as exact JSON strings.
#[pyclass(module = "aerorect", frozen)]
pub struct FlightPlan {
    plan: aerorect::flight::FlightPlan,
    opts: DroneOptions,
}

fn progress_from(json: Option<&str>) -> Result<aerorect::flight::FlightProgress> {
    Ok(match json {
        Some(j) => aerorect::flight::FlightProgress::from_json(j)?,
        None => aerorect::flight::FlightProgress::default(),
    })
}

#[pymethods]
impl FlightPlan {
    /// Reads every frame's metadata and plans it on the matching grid (`opts`: as
    /// `adjust_flight`'s).
    #[new]
    #[pyo3(signature = (paths, opts=None))]
    fn new(
        py: Python<'_>,
        paths: Vec<PathBuf>,
        opts: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let args = PhotoArgs::from_dict(opts)?;
        py.detach(|| -> Result<_> {
            let o = args.options(None)?;
            let plan = aerorect::flight::FlightPlan::new(&paths, &o, &args.flight_options()?)?;
            Ok(Self { plan, opts: o })
        })
        .map_err(py_err)
    }

    fn __len__(&self) -> usize {
        self.plan.len()
    }

    /// The pairs (i, j) whose matching grids overlap with the progress' orientation (none:
    /// the recorded one), in the order `adjust` takes their matches.
    #[pyo3(signature = (progress=None))]
    fn pairs(&self, py: Python<'_>, progress: Option<&str>) -> PyResult<Vec<(usize, usize)>> {
        py.detach(|| -> Result<_> {
            let p = progress_from(progress)?;
            Ok(self.plan.pairs(p.orientation.as_ref())?)
        })
        .map_err(py_err)
    }

    /// Frames i and j rendered with the progress' orientation and matched: the tie points
    /// (exact JSON).
    #[pyo3(signature = (i, j, progress=None))]
    fn pair_match(
        &self,
        py: Python<'_>,
        i: usize,
        j: usize,
        progress: Option<&str>,
    ) -> PyResult<String> {
        py.detach(|| -> Result<_> {
            let p = progress_from(progress)?;
            let m = self.plan.pair_match(i, j, p.orientation.as_ref())?;
            Ok(aerorect::flight::exact_json(&m)?)
        })
        .map_err(py_err)
    }

    /// The pairs (i, j) to match by features for the first round (none when the ties come
    /// from correlation alone).
    fn feature_pairs(&self, py: Python<'_>) -> PyResult<Vec<(usize, usize)>> {
        py.detach(|| self.plan.feature_pairs()).map_err(py_err)
    }

    /// Frame k decoded, reduced and described (exact JSON).
    fn frame_features(&self, py: Python<'_>, k: usize) -> PyResult<String> {
        py.detach(|| -> Result<_> {
            Ok(aerorect::flight::exact_json(&self.plan.frame_features(k)?)?)
        })
        .map_err(py_err)
    }

    /// Frames i and j matched by their features (`frame_features`' JSON): the tie points
    /// (exact JSON).
    fn feature_match(
        &self,
        py: Python<'_>,
        i: usize,
        j: usize,
        first: &str,
        second: &str,
    ) -> PyResult<String> {
        py.detach(|| -> Result<_> {
            let a = aerorect::flight::from_exact_json(first)?;
            let b = aerorect::flight::from_exact_json(second)?;
            let m = self.plan.feature_match((i, &a), (j, &b))?;
            Ok(aerorect::flight::exact_json(&m)?)
        })
        .map_err(py_err)
    }

    /// The feature matches (in `feature_pairs`' order) as the first round takes them: all of
    /// them when any pair ties, else none.
    #[staticmethod]
    fn first_round(matches: Vec<String>) -> PyResult<Vec<String>> {
        let matched = matches
            .iter()
            .map(|m| aerorect::flight::from_exact_json(m))
            .collect::<Result<Vec<_>, _>>()
            .map_err(py_err)?;
        aerorect::flight::FlightPlan::first_round_of(matched)
            .iter()
            .map(aerorect::flight::exact_json)
            .collect::<Result<Vec<_>, _>>()
            .map_err(py_err)
    }

    /// One round's adjustment from every pair's matches (in `pairs`' order): (the new
    /// progress, whether the rounds are done, the report as `adjustment.json` holds it, the
    /// adjusted poses as `adjusted_poses.csv`).
    #[pyo3(signature = (progress, matches))]
    fn adjust(
        &self,
        py: Python<'_>,
        progress: Option<&str>,
        matches: Vec<String>,
    ) -> PyResult<(String, bool, String, String)> {
        py.detach(|| -> Result<_> {
            let mut p = progress_from(progress)?;
            let matched = matches
                .iter()
                .map(|m| aerorect::flight::from_exact_json(m))
                .collect::<Result<Vec<_>, _>>()?;
            let report = self.plan.adjust(&mut p, matched)?;
            let json = serde_json::to_string_pretty(&report)?;
            Ok((p.to_json()?, p.done, json, report.poses_csv()))
        })
        .map_err(py_err)
    }

    /// Frame k rectified with the progress' orientation to `out` (written atomically).
    fn write_frame(&self, py: Python<'_>, k: usize, progress: &str, out: PathBuf) -> PyResult<()> {
        py.detach(|| -> Result<_> {
            let p = progress_from(Some(progress))?;
            let Some(o) = &p.orientation else {
                bail!("the progress has no adjusted orientation yet");
            };
            let mut staged = StagedOutputs::new();
            self.plan
                .write_frame_staged(k, o, &out, &self.opts, &mut staged)?;
            staged.commit()?;
            Ok(())
        })
        .map_err(py_err)
    }

    /// The flight's CRS as WKT (`adjusted_poses.prj`).
    fn crs_wkt(&self) -> PyResult<String> {
        self.plan.crs().to_wkt().map_err(py_err)
    }
}

/// `batch --adjust` without the printing: the flight adjusted, every frame written with its
/// adjusted orientation to `out_paths` and `aerorect::flight::adjustment_files` to
/// `out_dir`, all landing together (none when a frame fails). Returns the adjustment report.
#[pyfunction]
#[pyo3(signature = (paths, out_paths, out_dir, opts=None))]
pub fn write_adjusted_batch<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    out_paths: Vec<PathBuf>,
    out_dir: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyAny>> {
    let args = PhotoArgs::from_dict(opts)?;
    if paths.len() != out_paths.len() {
        return Err(py_err(anyhow::anyhow!(
            "{} photos but {} outputs",
            paths.len(),
            out_paths.len()
        )));
    }
    let report = py
        .detach(|| -> Result<_> {
            let o = args.options(None)?;
            let flight = aerorect::flight::adjust_flight(&paths, &o, &args.flight_options()?)?;
            let mut staged = StagedOutputs::new();
            flight.stage_batch(&out_paths, &out_dir, &o, &mut staged, |_, _| {})?;
            staged.commit()?;
            Ok(flight.report)
        })
        .map_err(py_err)?;
    to_py(py, &report)
}

/// The mosaic's options, and (given) its output's name checked: a .tif or .tiff.
pub(crate) fn mosaic_options(
    blend: &str,
    feather_px: usize,
    out: Option<&Path>,
) -> Result<MosaicOptions> {
    let blend: Blend = blend.parse().map_err(anyhow::Error::msg)?;
    let m = MosaicOptions {
        blend,
        feather_px,
        ..MosaicOptions::default()
    };
    m.validate()?;
    let Some(out) = out else { return Ok(m) };
    let ext = out.extension().and_then(|e| e.to_str());
    if !ext.is_some_and(|e| e.eq_ignore_ascii_case("tif") || e.eq_ignore_ascii_case("tiff")) {
        bail!(
            "--out {}: the mosaic is a GeoTIFF: give a .tif or .tiff name",
            out.display()
        );
    }
    Ok(m)
}

fn write_mosaic(
    frames: Vec<aerorect::mosaic::MosaicFrame>,
    crs: aerorect::geo::Crs,
    out: &Path,
    mopts: &MosaicOptions,
    cog: bool,
) -> Result<aerorect::mosaic::MosaicReport> {
    Ok(if cog {
        let c = aerorect::io::CogOptions::masked_by_alpha(mopts.alpha);
        mosaic_cog(frames, crs, out, mopts, &c)?
    } else {
        build(frames, crs, out, mopts)?
    })
}

/// One mosaic of a flight on one grid (`aerorect mosaic`): returns its report.
#[pyfunction]
#[pyo3(signature = (paths, out, opts=None, adjust=false, blend="feather", feather_px=16))]
pub fn mosaic<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    out: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
    adjust: bool,
    blend: &str,
    feather_px: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let args = PhotoArgs::from_dict(opts)?;
    let mopts = mosaic_options(blend, feather_px, Some(&out)).map_err(py_err)?;
    let r = py
        .detach(|| -> Result<_> {
            let mut o = args.options(None)?;
            // The mosaic's frames are planned without nodata; the alpha band marks coverage.
            o.warp.nodata = 0.0;
            o.warp.alpha = false;
            let cog = o.cog.take().is_some();
            let (frames, crs) = if adjust {
                let f = aerorect::flight::adjust_flight(&paths, &o, &args.flight_options()?)?;
                (f.mosaic_frames(&o)?, f.crs().clone())
            } else {
                frames_from_photos(&paths, &o)?
            };
            write_mosaic(frames, crs, &out, &mopts, cog)
        })
        .map_err(py_err)?;
    to_py(py, &r)
}
