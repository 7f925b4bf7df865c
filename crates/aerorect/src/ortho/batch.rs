//! `batch`: every photo of a flight rectified to its own georeferenced frame, several at once,
//! or (adjusted) every frame from one adjustment of the whole flight. The CLI and Python run
//! these; they only print.

use crate::Error;
use crate::drone::{DroneOptions, PhotoResult, rectify_photo};
use crate::flight::{AdjustedFlight, FlightOptions, adjust_flight_for};
use crate::options::Spelling;
use crate::report_html::{FlightSection, render};
use aerorect_io::StagedOutputs;
use aerorect_raster::AnyRaster;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Where and how a batch writes.
#[derive(Debug, Clone)]
pub struct BatchRequest {
    /// The folder every frame goes to (NAME.tif, or NAME.png with its world file).
    pub out_dir: PathBuf,
    /// `tif` (GeoTIFF) or `png` (with a world file).
    pub format: String,
    /// Frames processed at once.
    pub jobs: usize,
    /// Rewrite outputs that already exist.
    pub force: bool,
    /// A self-contained HTML report.
    pub report_html: Option<PathBuf>,
}

impl Default for BatchRequest {
    fn default() -> Self {
        Self {
            out_dir: PathBuf::new(),
            format: "tif".into(),
            jobs: 2,
            force: false,
            report_html: None,
        }
    }
}

/// What became of one input.
#[derive(Debug)]
pub enum FrameOutcome {
    Done(Box<PhotoResult>),
    /// Not redone, and why (its output exists).
    Skipped(String),
    /// The message, without the input's name.
    Failed(String),
}

/// Every input's outcome, in input order, and the time taken.
#[derive(Debug)]
pub struct BatchSummary {
    pub outcomes: Vec<(PathBuf, FrameOutcome)>,
    pub seconds: f64,
}

impl BatchRequest {
    /// Refuses an unknown format, no jobs, and COGs as PNG (`cog`: the frames are COGs).
    pub fn validate(&self, cog: bool) -> Result<(), Error> {
        use crate::options::OptionError;
        if self.format != "tif" && self.format != "png" {
            let why = Error::Invalid("expected tif or png".into());
            return Err(OptionError::value("format", format!("'{}'", self.format), why).into());
        }
        check_jobs(self.jobs)?;
        if cog && self.format != "tif" {
            return Err(Error::advice(format!(
                "`cog` writes cloud-optimised GeoTIFFs: it needs `format` tif, not '{}'",
                self.format
            )));
        }
        Ok(())
    }

    /// Where `input`'s frame is written: OUT_DIR/STEM.FORMAT.
    pub fn output_for(&self, input: &Path) -> Result<PathBuf, Error> {
        let stem = input
            .file_stem()
            .ok_or_else(|| Error::Invalid(format!("{}: no file name", input.display())))?;
        Ok(self.out_dir.join(stem).with_extension(&self.format))
    }

    /// Where an adjusted batch writes the adjustment's report.
    pub fn adjustment_json(&self) -> PathBuf {
        self.out_dir.join("adjustment.json")
    }

    /// Where an adjusted batch writes the adjusted exterior orientation (with its `.prj`).
    pub fn adjusted_poses_csv(&self) -> PathBuf {
        self.out_dir.join("adjusted_poses.csv")
    }
}

/// Rectifies every input, `req.jobs` at once (each frame's warp also uses every thread), into
/// `req.out_dir`; `each` sees every outcome as it comes (from the worker threads). An existing
/// whole output is skipped unless `req.force`; a broken one is redone with a warning. The
/// HTML report, if asked, is written after the frames.
pub fn run_batch(
    inputs: &[PathBuf],
    req: &BatchRequest,
    opts: &DroneOptions,
    each: &(dyn Fn(&Path, &FrameOutcome) + Sync),
) -> Result<BatchSummary, Error> {
    create_dir(&req.out_dir)?;
    let started = std::time::Instant::now();
    let queue = Mutex::new(inputs.iter().enumerate());
    let outcomes: Mutex<Vec<(usize, FrameOutcome)>> = Mutex::new(Vec::new());
    // `jobs` workers take frames from one queue: at most `jobs` frames are in memory at once.
    std::thread::scope(|s| {
        for _ in 0..req.jobs.min(inputs.len()) {
            s.spawn(|| {
                loop {
                    let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                    let Some((k, input)) = next else { break };
                    let outcome = process(req, input, opts);
                    each(input, &outcome);
                    if let Ok(mut o) = outcomes.lock() {
                        o.push((k, outcome));
                    }
                }
            });
        }
    });
    let mut outcomes = outcomes.into_inner().unwrap_or_default();
    outcomes.sort_by_key(|(k, _)| *k);
    let summary = BatchSummary {
        outcomes: outcomes
            .into_iter()
            .map(|(k, o)| (inputs[k].clone(), o))
            .collect(),
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok(summary)
}

/// Makes the output folder (and its parents).
fn create_dir(dir: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|error| {
        aerorect_io::IoError::Io {
            source_name: format!("{}: cannot create", dir.display()),
            error,
        }
        .into()
    })
}

fn process(req: &BatchRequest, input: &Path, opts: &DroneOptions) -> FrameOutcome {
    let output = match req.output_for(input) {
        Ok(o) => o,
        Err(e) => return failure(input, e),
    };
    // An existing output counts as done only when it is a whole image; else it is redone.
    let mut broken = None;
    if output.exists() && !req.force {
        match aerorect_io::check_image_whole(&output) {
            Ok(()) => {
                return FrameOutcome::Skipped(format!(
                    "{} exists (use {} to rewrite)",
                    output.display(),
                    Spelling::current().name("force")
                ));
            }
            Err(e) => broken = Some(e),
        }
    }
    let thumbs = req.report_html.as_ref().map(|_| 320);
    match rectify_photo(input, &output, opts, thumbs) {
        Ok(mut r) => {
            if let Some(e) = broken {
                let redone =
                    format!("the existing output was not a whole image ({e}): rectified again");
                r.info.warnings.insert(0, redone);
            }
            FrameOutcome::Done(Box::new(r))
        }
        Err(e) => failure(input, e),
    }
}

/// A failed frame; the input's name is said once (the line starts with it), not again from
/// the error's own context.
fn failure(input: &Path, e: Error) -> FrameOutcome {
    let text = e.full_message();
    let name = format!("{}: ", input.display());
    FrameOutcome::Failed(text.strip_prefix(&name).unwrap_or(&text).to_string())
}

impl BatchSummary {
    /// The frames rectified.
    pub fn done(&self) -> Vec<&PhotoResult> {
        self.outcomes
            .iter()
            .filter_map(|(_, o)| match o {
                FrameOutcome::Done(r) => Some(r.as_ref()),
                _ => None,
            })
            .collect()
    }

    /// The inputs skipped (`failed` false) or failed, with why.
    pub fn listed(&self, failed: bool) -> Vec<(String, String)> {
        self.outcomes
            .iter()
            .filter_map(|(input, o)| match (o, failed) {
                (FrameOutcome::Failed(w), true) | (FrameOutcome::Skipped(w), false) => {
                    Some((input.display().to_string(), w.clone()))
                }
                _ => None,
            })
            .collect()
    }

    /// Writes the HTML report to `path`, except over an earlier one when no frame was
    /// rectified in this run (a re-run that skips every frame would replace the flight's
    /// report with an empty one). Returns whether it was written.
    pub fn write_report(&self, path: &Path) -> Result<bool, Error> {
        let done = self.done();
        if done.is_empty() && path.exists() {
            return Ok(false);
        }
        let html = render(
            &done,
            &self.listed(false),
            &self.listed(true),
            self.seconds,
            None,
        );
        crate::demo::write_text(path, &html)?;
        Ok(true)
    }
}

/// Refuses no jobs: at least one frame must be in flight.
fn check_jobs(jobs: usize) -> Result<(), Error> {
    if jobs == 0 {
        let why = Error::Invalid("at least one frame must be in flight".into());
        return Err(crate::options::OptionError::value("jobs", 0, why).into());
    }
    Ok(())
}

/// An adjusted batch: the flight adjusted once (`adjusted` sees its report before any frame
/// is written), then every frame `k` written to `outputs[k]` with its adjusted orientation,
/// the adjustment's files in `out_dir` and, if asked, the HTML report, all landing together
/// (none when a frame fails), `jobs` frames at once. `each` sees every frame's result in
/// frame order.
pub fn run_adjusted_batch(
    inputs: &[PathBuf],
    outputs: &[PathBuf],
    (out_dir, report_html, jobs): (&Path, Option<&Path>, usize),
    (opts, flight_opts): (&DroneOptions, &FlightOptions),
    adjusted: impl FnOnce(&AdjustedFlight),
    each: impl FnMut(usize, &Result<PhotoResult, Error>),
) -> Result<AdjustedFlight, Error> {
    check_jobs(jobs)?;
    create_dir(out_dir)?;
    let flight = adjust_flight_for(inputs, opts, flight_opts, report_html.is_some())?;
    adjusted(&flight);
    let mut staged = StagedOutputs::new();
    let started = std::time::Instant::now();
    let done = flight.stage_batch(outputs, (out_dir, jobs), opts, &mut staged, each)?;
    // The frames are written several at a time: their own seconds add up to more than this.
    let frames_seconds = started.elapsed().as_secs_f64();
    if let Some(p) = report_html {
        let overview = flight.overview()?;
        let section = FlightSection {
            report: &flight.report,
            ties: &flight.ties,
            overview_png: Some(aerorect_io::thumbnail_png(
                &AnyRaster::U8(overview),
                800,
                "the flight's overview",
            )?),
        };
        let done: Vec<&PhotoResult> = done.iter().collect();
        let seconds = flight.report.seconds + frames_seconds;
        let html = render(&done, &[], &[], seconds, Some(&section));
        staged.text(p, &html)?;
    }
    staged.commit()?;
    Ok(flight)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No jobs is refused as plain `batch` refuses it, naming the option, before any photo is
    /// read or any folder made (the photo here does not exist).
    #[test]
    fn an_adjusted_batch_with_no_jobs_is_refused_before_anything_is_done() {
        let dir = tempfile::tempdir().expect("temporary folder");
        let out = dir.path().join("out");
        let photos = [dir.path().join("missing.jpg")];
        let opts = (&DroneOptions::default(), &FlightOptions::default());
        let got = run_adjusted_batch(
            &photos,
            &[out.join("a.tif")],
            (&out, None, 0),
            opts,
            |_| {},
            |_, _| {},
        );
        let Err(e) = got else {
            panic!("no jobs was accepted");
        };
        let plain = BatchRequest {
            jobs: 0,
            ..BatchRequest::default()
        };
        let want = plain
            .validate(false)
            .expect_err("plain batch refuses no jobs");
        assert_eq!(e.to_string(), want.to_string());
        assert!(e.to_string().contains("jobs"), "{e}");
        assert!(!out.exists());
    }
}
