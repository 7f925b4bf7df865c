//! The image-motion subcommands: shift, motion-sim, velocity, track.

use crate::outputs::Files;
use aerorect::io::{StagedOutputs, read_image};
use aerorect::motion::{Displacement, Method, MotionSimConfig, gray, motion_sim};
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};

mod track;
mod velocity;

pub use track::{TrackArgs, track};
pub use velocity::{VelocityArgs, velocity};

#[derive(Args)]
pub struct ShiftArgs {
    /// Reference frame (gray; RGB is converted to luma).
    reference: PathBuf,
    /// Current frame, same size.
    current: PathBuf,
    /// jtc (the paper's processing, Gaussian peak fit), jtc-centroid (the paper's centroid),
    /// jtc-parabola, jtc-linear (not binarised: the fast cross-spectrum form), jtc-plain, phase,
    /// xcorr.
    #[arg(long, default_value = "jtc")]
    method: String,
    /// Print JSON with keys dx, dy, confidence.
    #[arg(long)]
    json: bool,
}

fn read_gray(path: &Path) -> Result<aerorect::raster::Raster<f32>> {
    let img = read_image(path)?;
    gray(&img).with_context(|| path.display().to_string())
}

pub fn shift(a: ShiftArgs) -> Result<()> {
    let method = Method::parse(&a.method)?;
    let (r, c) = (read_gray(&a.reference)?, read_gray(&a.current)?);
    if r.size() != c.size() {
        bail!(
            "{} is {} x {} but {} is {} x {}",
            a.reference.display(),
            r.width(),
            r.height(),
            a.current.display(),
            c.width(),
            c.height()
        );
    }
    let mut est = method.plan(r.size())?;
    let e = est
        .estimate(r.plane(0), c.plane(0))
        .with_context(|| format!("{} -> {}", a.reference.display(), a.current.display()))?;
    if a.json {
        outln!(
            "{}",
            serde_json::json!({"dx": e.dx, "dy": e.dy, "confidence": e.confidence})
        );
    } else {
        outln!(
            "dx {:.4} dy {:.4} confidence {:.3}",
            e.dx,
            e.dy,
            e.confidence
        );
    }
    Ok(())
}

#[derive(Args)]
pub struct MotionSimArgs {
    /// Scene images (real aerial photos); each gives a centred window per trial.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// SNR values in dB (10 log10 of signal variance over noise variance); write
    /// `--snr-db=-2,4` when the list starts with a negative value.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "-2,0,2,4,6,8,10,15,20",
        allow_negative_numbers = true
    )]
    snr_db: Vec<f64>,
    #[arg(long, default_value_t = 50)]
    trials: usize,
    /// Frame side in pixels; default: the largest power of two up to 256 that every scene holds
    /// with the shift margin.
    #[arg(long)]
    size: Option<usize>,
    /// Methods, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "jtc,jtc-centroid,phase,xcorr"
    )]
    method: Vec<String>,
    /// Shifts are uniform in [-max, max] pixels on both axes.
    #[arg(long, default_value_t = 2.5)]
    max_shift: f64,
    /// Make the displaced copies by a Fourier shift instead of linear interpolation.
    #[arg(long)]
    fourier: bool,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The error-vs-SNR plot (SVG).
    #[arg(long, default_value = "motion-sim.svg")]
    plot: PathBuf,
    /// Also write the table as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write every noisy pair and a manifest here (for bench/shift_vs_peers.py).
    #[arg(long)]
    dump_dir: Option<PathBuf>,
}

/// The largest power of two (16 to 256) that fits every scene with the margin the displacement
/// reads around the window (linear: max shift + 2 px on each side; Fourier: twice the side).
fn default_frame_side(
    scenes: &[(String, aerorect::raster::Raster<f32>)],
    max_shift: f64,
    fourier: bool,
) -> usize {
    let smallest = scenes
        .iter()
        .map(|(_, s)| s.width().min(s.height()))
        .min()
        .unwrap_or(0);
    let fits = |n: usize| {
        if fourier {
            2 * n <= smallest
        } else {
            n + 2 * (max_shift.max(0.0).ceil() as usize + 2) <= smallest
        }
    };
    [256, 128, 64, 32, 16]
        .into_iter()
        .find(|&n| fits(n))
        .unwrap_or(16)
}

pub fn motion_sim_cmd(a: MotionSimArgs) -> Result<()> {
    let manifest = a.dump_dir.as_ref().map(|d| d.join("manifest.csv"));
    let mut files = Files::new();
    for p in &a.images {
        files = files.input("IMAGES", Some(p));
    }
    files
        .output("--plot", Some(&a.plot))
        .output("--json", a.json.as_deref())
        .output("--dump-dir", manifest.as_deref())
        .folder("--dump-dir", a.dump_dir.as_deref())
        .check()?;
    let scenes = a
        .images
        .iter()
        .map(|p| {
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            Ok((name, read_gray(p)?))
        })
        .collect::<Result<Vec<_>>>()?;
    let methods = a
        .method
        .iter()
        .map(|m| Ok((m.clone(), Method::parse(m)?)))
        .collect::<Result<Vec<_>>>()?;
    if let Some(d) = &a.dump_dir {
        std::fs::create_dir_all(d).with_context(|| d.display().to_string())?;
        let header = std::iter::once("scene,snr_db,trial,dx,dy".to_string())
            .chain(
                a.method
                    .iter()
                    .map(|m| format!("{m}_dx,{m}_dy,{m}_seconds")),
            )
            .collect::<Vec<_>>()
            .join(",");
        std::fs::write(d.join("manifest.csv"), header + "\n")
            .with_context(|| d.display().to_string())?;
    }
    let cfg = MotionSimConfig {
        size: a
            .size
            .unwrap_or_else(|| default_frame_side(&scenes, a.max_shift, a.fourier)),
        snr_db: a.snr_db.clone(),
        trials: a.trials,
        max_shift: a.max_shift,
        displacement: if a.fourier {
            Displacement::Fourier
        } else {
            Displacement::Linear
        },
        methods,
        seed: a.seed,
        dump_dir: a.dump_dir.clone(),
    };
    let rows = motion_sim(&scenes, &cfg)?;
    outln!(
        "{} x {} frames, {} trials per cell, shifts uniform in [-{m}, {m}] px by {}, SNR = 10 log10(var s / var n)",
        cfg.size,
        cfg.size,
        a.trials,
        if a.fourier {
            "Fourier shift"
        } else {
            "linear interpolation"
        },
        m = a.max_shift
    );
    outln!(
        "{:<14} {:>7} {:<14} {:>10} {:>10} {:>8} {:>9}",
        "scene",
        "SNR dB",
        "method",
        "RMS px",
        "CRLB px",
        "RMS/CRLB",
        "ms/pair"
    );
    for r in &rows {
        outln!(
            "{:<14} {:>7} {:<14} {:>10.4} {:>10.4} {:>8.1} {:>9.2}",
            r.scene,
            r.snr_db,
            r.method,
            r.error_rms_px,
            r.crlb_rms_px,
            r.error_rms_px / r.crlb_rms_px,
            r.median_seconds * 1e3
        );
    }
    let mut staged = StagedOutputs::new();
    staged.text(&a.plot, &crate::plot::error_vs_snr(&a.plot, &rows)?)?;
    if let Some(j) = &a.json {
        staged.text(j, &serde_json::to_string_pretty(&rows)?)?;
    }
    staged.commit()?;
    outln!("plot: {}", a.plot.display());
    Ok(())
}
