//! `aerorect batch` from Python: the facade's run (`aerorect::batch::run_batch`), the same
//! frames, skips and report; failures raise, naming every failed photo.

use crate::flight::warn_all;
use crate::options::PhotoArgs;
use crate::{py_err, to_py};
use aerorect::batch::{BatchRequest, FrameOutcome, run_batch};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde::Serialize;
use std::path::PathBuf;

/// One photo's outcome as Python sees it.
#[derive(Serialize)]
struct Outcome {
    input: String,
    /// `done`, `skipped` or `failed`.
    status: &'static str,
    /// Why it was skipped or failed.
    why: Option<String>,
    /// The frame's report when done.
    report: Option<aerorect::drone::PhotoResult>,
}

/// Rectifies every photo to OUT_DIR/STEM.tif (or .png) as `aerorect batch` does; returns
/// `{"frames": [...], "seconds": s}`.
#[pyfunction]
#[pyo3(signature = (paths, out_dir, opts=None, jobs=2, force=false, format="tif", report_html=None))]
#[allow(clippy::too_many_arguments)]
pub fn batch<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    out_dir: PathBuf,
    opts: Option<&Bound<'py, PyDict>>,
    jobs: usize,
    force: bool,
    format: &str,
    report_html: Option<PathBuf>,
) -> PyResult<Bound<'py, PyAny>> {
    let args = PhotoArgs::from_dict(opts)?;
    let req = BatchRequest {
        out_dir,
        format: format.to_string(),
        jobs,
        force,
        report_html,
    };
    req.validate(args.cog).map_err(py_err)?;
    let (summary, warnings) = py
        .detach(|| -> anyhow::Result<_> {
            let (o, warnings) = args.flight_frames(&paths)?;
            let s = run_batch(&paths, &req, &o, &|_, _| {})?;
            if let Some(p) = &req.report_html {
                s.write_report(p)?;
            }
            Ok((s, warnings))
        })
        .map_err(py_err)?;
    warn_all(py, &warnings)?;
    let failed = summary.listed(true);
    if !failed.is_empty() {
        let each: Vec<String> = failed.iter().map(|(f, w)| format!("{f}: {w}")).collect();
        return Err(py_err(anyhow::anyhow!(
            "{} of {} frames failed: {}",
            failed.len(),
            summary.outcomes.len(),
            each.join("; ")
        )));
    }
    let frames: Vec<Outcome> = summary
        .outcomes
        .into_iter()
        .map(|(input, o)| {
            let input = input.display().to_string();
            match o {
                FrameOutcome::Done(r) => Outcome {
                    input,
                    status: "done",
                    why: None,
                    report: Some(*r),
                },
                FrameOutcome::Skipped(why) => Outcome {
                    input,
                    status: "skipped",
                    why: Some(why),
                    report: None,
                },
                FrameOutcome::Failed(why) => Outcome {
                    input,
                    status: "failed",
                    why: Some(why),
                    report: None,
                },
            }
        })
        .collect();
    to_py(
        py,
        &serde_json::json!({ "frames": frames, "seconds": summary.seconds }),
    )
}
