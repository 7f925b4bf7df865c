//! A flight: the joint adjustment (`batch --adjust`) and the mosaic.

use crate::options::PhotoArgs;
use crate::{py_err, to_py};
use aerorect::batch::run_adjusted_batch;
use aerorect::drone::DroneOptions;
use aerorect::io::StagedOutputs;
use aerorect::mosaic::{check_mosaic_name, mosaic_adjusted, mosaic_options, run_mosaic};
use anyhow::Result;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

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
    let (flight, warnings) = py
        .detach(|| -> Result<_> {
            let (o, warnings) = args.flight_frames(&paths)?;
            // The Python flight has no overview: its frames are not rendered again for one.
            let fo = args.flight_options()?;
            let flight = aerorect::flight::adjust_flight_for(&paths, &o, &fo, false)?;
            Ok((AdjustedFlight { flight, opts: o }, warnings))
        })
        .map_err(py_err)?;
    warn_all(py, &warnings)?;
    Ok(flight)
}

/// Each warning through Python's `warnings.warn` (the CLI prints them).
pub(crate) fn warn_all(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    let w = py.import("warnings")?;
    for text in warnings {
        w.call_method1("warn", (text,))?;
    }
    Ok(())
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
        let max = self.opts.limits.max_output_px;
        let mopts = mosaic_options(blend, feather_px, max).map_err(py_err)?;
        check_mosaic_name(&out).map_err(py_err)?;
        let r = py
            .detach(|| mosaic_adjusted(&self.flight, &out, (&self.opts, &mopts, cog)))
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
    /// `sensefly_roll_choice`: what `choose_sensefly_roll` decided (another process's plan),
    /// so this plan reads the roll that way and reports the choice.
    #[new]
    #[pyo3(signature = (paths, opts=None, sensefly_roll_choice=None))]
    fn new(
        py: Python<'_>,
        paths: Vec<PathBuf>,
        opts: Option<&Bound<'_, PyDict>>,
        sensefly_roll_choice: Option<&str>,
    ) -> PyResult<Self> {
        let args = PhotoArgs::from_dict(opts)?;
        py.detach(|| -> Result<_> {
            // The warnings were the caller's when it adjusted or planned the flight first.
            let (o, _) = args.flight_frames(&paths)?;
            let mut plan = aerorect::flight::FlightPlan::new(&paths, &o, &args.flight_options()?)?;
            if let Some(choice) = sensefly_roll_choice {
                plan = plan.with_sensefly_roll(aerorect::flight::from_exact_json(choice)?)?;
            }
            // A Dask worker's memory limit is its own: the least budget, as before it took a
            // share of the machine's memory.
            let plan = plan.with_cache_budget(aerorect::memory::MIN_CACHE_BYTES);
            Ok(Self { plan, opts: o })
        })
        .map_err(py_err)
    }

    /// The reading of senseFly's roll the first round's feature matches (`first_round`'s)
    /// agree with, as exact JSON for `FlightPlan(..., sensefly_roll_choice=)`; `None` when
    /// the flight does not leave the reading to its images.
    fn choose_sensefly_roll(
        &self,
        py: Python<'_>,
        matches: Vec<String>,
    ) -> PyResult<Option<String>> {
        py.detach(|| -> Result<_> {
            let matched = matches
                .iter()
                .map(|m| aerorect::flight::from_exact_json(m))
                .collect::<Result<Vec<_>, _>>()?;
            match self.plan.choose_sensefly_roll(&matched)? {
                Some(c) => Ok(Some(aerorect::flight::exact_json(&c)?)),
                None => Ok(None),
            }
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

    /// Which step matches each of `feature_pairs` (1 or 2): the second step's pairs are
    /// matched after `step_guide`, guided by it.
    fn feature_steps(&self, py: Python<'_>) -> PyResult<Vec<u8>> {
        py.detach(|| -> Result<_> {
            let pairs = self.plan.feature_pairs()?;
            Ok(self.plan.feature_steps(&pairs)?)
        })
        .map_err(py_err)
    }

    /// The first step's solve from its matches (`feature_match`'s JSON, the first step's
    /// pairs in `feature_pairs`' order), as exact JSON; `None` when it guides nothing.
    fn step_guide(&self, py: Python<'_>, first: Vec<String>) -> PyResult<Option<String>> {
        py.detach(|| -> Result<_> {
            let matched = first
                .iter()
                .map(|m| aerorect::flight::from_exact_json(m))
                .collect::<Result<Vec<_>, _>>()?;
            match self.plan.step_guide(&matched) {
                Some(g) => Ok(Some(g.to_json()?)),
                None => Ok(None),
            }
        })
        .map_err(py_err)
    }

    /// Frame k's features (`frame_features`' JSON) with their ground positions by the first
    /// step's solve (`step_guide`'s JSON) where it placed the frame: what the second step
    /// matches.
    fn step_features(
        &self,
        py: Python<'_>,
        k: usize,
        features: &str,
        guide: &str,
    ) -> PyResult<String> {
        py.detach(|| -> Result<_> {
            let mut f: aerorect::features::FrameFeatures =
                aerorect::flight::from_exact_json(features)?;
            let g = aerorect::flight::StepGuide::from_json(guide, self.plan.len())?;
            self.plan.step_features(&g, k, &mut f);
            Ok(aerorect::flight::exact_json(&f)?)
        })
        .map_err(py_err)
    }

    /// Frames i and j matched by their features (`frame_features`' JSON, or
    /// `step_features`' in the second step, with its `guide`): the tie points (exact JSON).
    /// `first_step`: the pair is in the first of two steps (`feature_steps` gives some 2),
    /// where a pair the priors cannot guide is matched on the strongest keypoints.
    #[pyo3(signature = (i, j, first, second, guide=None, first_step=false))]
    #[allow(clippy::too_many_arguments)]
    fn feature_match(
        &self,
        py: Python<'_>,
        i: usize,
        j: usize,
        first: &str,
        second: &str,
        guide: Option<&str>,
        first_step: bool,
    ) -> PyResult<String> {
        py.detach(|| -> Result<_> {
            let a = aerorect::flight::from_exact_json(first)?;
            let b = aerorect::flight::from_exact_json(second)?;
            let g = guide
                .map(|g| aerorect::flight::StepGuide::from_json(g, self.plan.len()))
                .transpose()?;
            let basis = match (&g, first_step) {
                (Some(g), _) => aerorect::flight::Basis::Stepped(g),
                (None, true) => aerorect::flight::Basis::FirstStep,
                (None, false) => aerorect::flight::Basis::Recorded,
            };
            let m = self.plan.feature_match(basis, (i, &a), (j, &b))?;
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
    /// adjusted poses as `adjusted_poses.csv`). The first round (no `progress`) starts from
    /// the first step's solve when given (`step_guide`'s JSON), as `adjust_flight` does.
    #[pyo3(signature = (progress, matches, guide=None))]
    fn adjust(
        &self,
        py: Python<'_>,
        progress: Option<&str>,
        matches: Vec<String>,
        guide: Option<&str>,
    ) -> PyResult<(String, bool, String, String)> {
        py.detach(|| -> Result<_> {
            let mut p = match (progress, guide) {
                (None, Some(g)) => {
                    let g = aerorect::flight::StepGuide::from_json(g, self.plan.len())?;
                    self.plan.first_progress(Some(&g))
                }
                _ => progress_from(progress)?,
            };
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
            let mut staged = StagedOutputs::new();
            self.plan
                .write_frame_staged(k, &p, &out, &self.opts, &mut staged)?;
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
#[pyo3(signature = (paths, out_paths, out_dir, opts=None, jobs=2))]
pub fn write_adjusted_batch<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    out_paths: Vec<PathBuf>,
    out_dir: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
    jobs: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let args = PhotoArgs::from_dict(opts)?;
    if paths.len() != out_paths.len() {
        return Err(py_err(anyhow::anyhow!(
            "{} photos but {} outputs",
            paths.len(),
            out_paths.len()
        )));
    }
    let (report, warnings) = py
        .detach(|| -> Result<_> {
            let (o, warnings) = args.flight_frames(&paths)?;
            let fo = args.flight_options()?;
            let flight = run_adjusted_batch(
                &paths,
                &out_paths,
                (&out_dir, None, jobs),
                (&o, &fo),
                |_| {},
                |_, _| {},
            )?;
            Ok((flight.report, warnings))
        })
        .map_err(py_err)?;
    warn_all(py, &warnings)?;
    to_py(py, &report)
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
    let mopts = mosaic_options(blend, feather_px, args.max_output_px()).map_err(py_err)?;
    check_mosaic_name(&out).map_err(py_err)?;
    let (r, warnings) = py
        .detach(|| -> Result<_> {
            let (o, warnings) = args.flight_frames(&paths)?;
            let fo = adjust.then(|| args.flight_options()).transpose()?;
            let cog = o.cog.is_some();
            let r = run_mosaic(&paths, &out, (&o, &mopts, cog), fo.as_ref(), |_| {})?;
            Ok((r, warnings))
        })
        .map_err(py_err)?;
    warn_all(py, &warnings)?;
    to_py(py, &r)
}
