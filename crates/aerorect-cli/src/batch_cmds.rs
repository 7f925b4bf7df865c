//! `batch`: every photo of a flight to its own georeferenced frame (or, with --adjust, every
//! frame from one adjustment of the whole flight). The runs are the facade's
//! (`aerorect::batch`); this file turns flags into their requests and prints.

use crate::drone_cmds::{FlightArgs, result_line};
use crate::flight_print::print_adjustment;
use crate::outputs::Files;
use aerorect::batch::{BatchRequest, BatchSummary, FrameOutcome, run_adjusted_batch, run_batch};
use aerorect::core::RectifyLimits;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::drone::{DroneOptions, PhotoResult};
use aerorect::io::{CogOptions, image_files};
use aerorect::raster::{Interp, WarpOptions};
use anyhow::{Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct BatchArgs {
    /// Photos of a flight (JPEG with DJI metadata, or any image with --camera and the same tags).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Where the rectified frames go (NAME.tif, or NAME.png + NAME.pgw with --format png).
    #[arg(long)]
    out_dir: PathBuf,
    #[command(flatten)]
    flight: FlightArgs,
    /// Frames processed at once (each also uses all threads for its warp).
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    /// Rewrite outputs that already exist.
    #[arg(long)]
    force: bool,
    /// tif (GeoTIFF) or png (with a world file).
    #[arg(long, default_value = "tif")]
    format: String,
    /// Resampling: nearest, bilinear, bicubic, or average (the area-weighted mean of the source
    /// pixels under each output pixel, GDAL's -r average, OpenCV's INTER_AREA).
    #[arg(long, default_value = "bilinear")]
    interp: Interp,
    /// Bilinear and bicubic: keep the plain kernel where the output is more than twice coarser
    /// than the source (by default such regions read a 2 x 2 box-reduced level, which stops aliasing).
    #[arg(long)]
    no_prefilter: bool,
    #[arg(long, default_value_t = 0.0)]
    nodata: f64,
    #[arg(long, default_value_t = DEFAULT_MAX_OUTPUT_PX)]
    max_output_px: u64,
    /// A self-contained HTML report: footprint map, before/after thumbnails, per-frame attitude,
    /// height, GSD and warnings.
    #[arg(long)]
    report_html: Option<PathBuf>,
    /// Write cloud-optimised GeoTIFFs (tiled, Deflate, internal overviews) instead of strip
    /// GeoTIFFs; needs --format tif.
    #[arg(long)]
    cog: bool,
}

impl BatchArgs {
    fn request(&self) -> BatchRequest {
        BatchRequest {
            out_dir: self.out_dir.clone(),
            format: self.format.clone(),
            jobs: self.jobs,
            force: self.force,
            report_html: self.report_html.clone(),
        }
    }
}

pub fn batch(a: BatchArgs) -> Result<()> {
    let req = a.request();
    req.validate(a.cog)?;
    batch_files(&a, &req)?.check()?;
    if a.flight.adjust {
        a.flight.validate_flight()?;
    }
    // One camera file and one set of options for every frame, read before the out folder
    // is made.
    let mut opts = a.flight.options(
        &a.inputs,
        RectifyLimits {
            max_output_px: a.max_output_px,
        },
        WarpOptions {
            interp: a.interp,
            nodata: a.nodata,
            alpha: false,
            prefilter: !a.no_prefilter,
            ..WarpOptions::default()
        },
    )?;
    if a.cog {
        opts.cog = Some(CogOptions::masked_by_alpha(false));
    }
    if a.flight.adjust {
        return batch_adjusted(&a, &req, &opts);
    }
    let pb =
        ProgressBar::with_draw_target(Some(a.inputs.len() as u64), ProgressDrawTarget::stderr());
    pb.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames, {elapsed} elapsed, eta {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let each = |input: &Path, outcome: &FrameOutcome| {
        let line = match outcome {
            FrameOutcome::Done(r) => with_warnings(result_line(r), r),
            FrameOutcome::Skipped(why) => format!("{}: skipped: {why}", input.display()),
            FrameOutcome::Failed(why) => format!("{}: FAILED: {why}", input.display()),
        };
        if pb.is_hidden() {
            outln!("{line}");
        } else {
            pb.println(line);
        }
        pb.inc(1);
    };
    let summary = run_batch(&a.inputs, &req, &opts, &each)?;
    pb.finish_and_clear();
    summarise(&a, &summary)
}

/// Refuses two photos that would go to one output (a/X.JPG and b/X.JPG both to OUT/X.tif).
fn refuse_collisions(a: &BatchArgs, req: &BatchRequest) -> Result<()> {
    let mut first: HashMap<PathBuf, &Path> = HashMap::new();
    for input in &a.inputs {
        let out = req.output_for(input)?;
        let key = aerorect::io::resolved_path(&out).unwrap_or_else(|| out.clone());
        // The same photo twice was refused before (refuse_duplicate_photos in batch_files).
        if let Some(other) = first.insert(key, input) {
            bail!(
                "{} and {} would both be written to {}: rename one, or rectify them in separate runs; nothing written",
                other.display(),
                input.display(),
                out.display()
            );
        }
    }
    Ok(())
}

/// Everything batch reads and writes (every frame's output with its sidecars), after the
/// name collisions between frames are refused.
fn batch_files(a: &BatchArgs, req: &BatchRequest) -> Result<Files> {
    aerorect::io::refuse_duplicate_photos(&a.inputs)?;
    refuse_collisions(a, req)?;
    let mut files = a
        .flight
        .inputs(Files::new())
        .folder("--out-dir", Some(&a.out_dir));
    for input in &a.inputs {
        files = files.input("PHOTOS", Some(input));
    }
    for input in &a.inputs {
        for out in image_files(&req.output_for(input)?, true) {
            files = files.output("--out-dir", Some(&out));
        }
    }
    let adjustment = a.flight.adjust.then(|| req.adjustment_json());
    let poses = a.flight.adjust.then(|| req.adjusted_poses_csv());
    let prj = poses.as_ref().map(|p| p.with_extension("prj"));
    let accuracy =
        (!a.flight.gcps.is_empty()).then(|| a.out_dir.join(aerorect::flight::ACCURACY_FILE));
    Ok(files
        .output("--report-html", a.report_html.as_deref())
        .output("--gcps (the accuracy report)", accuracy.as_deref())
        .output("--adjust (its report)", adjustment.as_deref())
        .output("--adjust (the adjusted poses)", poses.as_deref())
        .output("--adjust (the adjusted poses' CRS)", prj.as_deref()))
}

/// A frame's result line followed by its warnings, one indented line each.
fn with_warnings(line: String, r: &PhotoResult) -> String {
    r.info
        .warnings
        .iter()
        .fold(line, |acc, w| format!("{acc}\n  warning: {w}"))
}

fn summarise(a: &BatchArgs, s: &BatchSummary) -> Result<()> {
    let (failed, skipped) = (s.listed(true), s.listed(false));
    if let Some(p) = &a.report_html {
        if s.write_report(p)? {
            outln!("report: {}", p.display());
        } else {
            outln!(
                "report: {} kept as it was (no frame was rectified in this run)",
                p.display()
            );
        }
    }
    outln!(
        "{} frames: {} rectified, {} skipped, {} failed, {:.2} s",
        s.outcomes.len(),
        s.done().len(),
        skipped.len(),
        failed.len(),
        s.seconds
    );
    if !failed.is_empty() {
        for (f, why) in &failed {
            eprintln!("failed: {f}: {why}");
        }
        bail!(
            "{} of {} frames failed (listed above)",
            failed.len(),
            s.outcomes.len()
        );
    }
    Ok(())
}

/// `batch --adjust`: plan, match and adjust the whole flight, then write every frame with its
/// adjusted orientation and `adjustment.json`; a failed adjustment writes nothing.
fn batch_adjusted(a: &BatchArgs, req: &BatchRequest, opts: &DroneOptions) -> Result<()> {
    let fo = a.flight.flight_options()?;
    let outputs: Vec<PathBuf> = a
        .inputs
        .iter()
        .map(|input| req.output_for(input))
        .collect::<Result<_, _>>()?;
    run_adjusted_batch(
        &a.inputs,
        &outputs,
        (&req.out_dir, req.report_html.as_deref(), req.jobs),
        (opts, &fo),
        |flight| print_adjustment(&flight.report),
        |k, res| match res {
            Ok(p) => outln!("{}", result_line(p)),
            Err(e) => eprintln!("failed: {}: {}", a.inputs[k].display(), e.full_message()),
        },
    )?;
    outln!(
        "adjustment report: {}; adjusted poses: {}",
        req.adjustment_json().display(),
        req.adjusted_poses_csv().display()
    );
    Ok(())
}
