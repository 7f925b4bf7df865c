//! The image-motion subcommands: shift, motion-sim, velocity, track.

use crate::outputs::Files;
use aerorect::core::ImageSize;
use aerorect::core::motion::{
    CcdAxes, FlightState, FlightUncertainty, corrected, forward_budget, predict, swing_budget,
};
use aerorect::io::{StagedOutputs, read_image};
use aerorect::motion::{Displacement, Method, MotionSimConfig, Tracker, gray, motion_sim};
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};

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

#[derive(Args)]
pub struct VelocityArgs {
    #[arg(long)]
    focal_length_mm: f64,
    #[arg(long)]
    height_m: f64,
    #[arg(long)]
    speed_mps: f64,
    #[arg(long, allow_negative_numbers = true)]
    swing_deg: f64,
    #[arg(long, allow_negative_numbers = true)]
    swing_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    yaw_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pitch_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    roll_rate_dps: f64,
    /// One-sigma uncertainties (same units); each becomes a term of the error budgets.
    #[arg(long, default_value_t = 0.0)]
    sigma_focal_length_mm: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_height_m: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_speed_mps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_swing_deg: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_swing_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_yaw_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_pitch_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_roll_rate_dps: f64,
    #[arg(long)]
    json: bool,
}

fn flight(a: &VelocityArgs) -> Result<(FlightState, FlightUncertainty)> {
    let s = FlightState {
        focal_length_mm: a.focal_length_mm,
        height_m: a.height_m,
        speed_mps: a.speed_mps,
        swing_deg: a.swing_deg,
        swing_rate_dps: a.swing_rate_dps,
        yaw_rate_dps: a.yaw_rate_dps,
        pitch_rate_dps: a.pitch_rate_dps,
        roll_rate_dps: a.roll_rate_dps,
    };
    let u = FlightUncertainty {
        focal_length_mm: a.sigma_focal_length_mm,
        height_m: a.sigma_height_m,
        speed_mps: a.sigma_speed_mps,
        swing_deg: a.sigma_swing_deg,
        swing_rate_dps: a.sigma_swing_rate_dps,
        yaw_rate_dps: a.sigma_yaw_rate_dps,
        pitch_rate_dps: a.sigma_pitch_rate_dps,
        roll_rate_dps: a.sigma_roll_rate_dps,
    };
    check_flight(&s)?;
    for (name, v) in [
        ("--sigma-focal-length-mm", u.focal_length_mm),
        ("--sigma-height-m", u.height_m),
        ("--sigma-speed-mps", u.speed_mps),
        ("--sigma-swing-deg", u.swing_deg),
        ("--sigma-swing-rate-dps", u.swing_rate_dps),
        ("--sigma-yaw-rate-dps", u.yaw_rate_dps),
        ("--sigma-pitch-rate-dps", u.pitch_rate_dps),
        ("--sigma-roll-rate-dps", u.roll_rate_dps),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            bail!("{name} {v}: an uncertainty must be a finite number >= 0");
        }
    }
    Ok((s, u))
}

fn check_flight(s: &FlightState) -> Result<()> {
    for (name, v) in [
        ("--focal-length-mm", s.focal_length_mm),
        ("--height-m", s.height_m),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} {v}: must be a finite number > 0");
        }
    }
    for (name, v) in [
        ("--speed-mps", s.speed_mps),
        ("--swing-deg", s.swing_deg),
        ("--swing-rate-dps", s.swing_rate_dps),
        ("--yaw-rate-dps", s.yaw_rate_dps),
        ("--pitch-rate-dps", s.pitch_rate_dps),
        ("--roll-rate-dps", s.roll_rate_dps),
    ] {
        if !v.is_finite() {
            bail!("{name} {v}: must be a finite number");
        }
    }
    if s.swing_deg.abs() >= 90.0 {
        bail!(
            "--swing-deg {}: the swing angle must lie within (-90, 90)",
            s.swing_deg
        );
    }
    Ok(())
}

pub fn velocity(a: VelocityArgs) -> Result<()> {
    let (s, u) = flight(&a)?;
    let m = predict(&s);
    let (fb, sb) = (forward_budget(&s, &u), swing_budget(&s, &u));
    if a.json {
        let v = serde_json::json!({
            "v_forward_mm_s": m.v_forward_mm_s,
            "v_swing_mm_s": m.v_swing_mm_s,
            "mirror_rate_dps": m.mirror_rate_dps,
            "forward_budget": fb,
            "swing_budget": sb,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    outln!(
        "V_F (forward)  {:>12.4} mm/s   +- {:.4} (RSS), {:.4} (worst case)",
        m.v_forward_mm_s,
        fb.rss_mm_s,
        fb.worst_case_mm_s
    );
    outln!(
        "V_P (swing)    {:>12.4} mm/s   +- {:.4} (RSS), {:.4} (worst case)",
        m.v_swing_mm_s,
        sb.rss_mm_s,
        sb.worst_case_mm_s
    );
    outln!("mirror rate    {:>12.4} deg/s", m.mirror_rate_dps);
    for (label, b) in [("dV_F", &fb), ("dV_P", &sb)] {
        for t in &b.terms {
            outln!(
                "  {label} from {:<16} {:>12.6} mm/s  (partial {:.6} x sigma {})",
                t.input,
                t.contribution_mm_s,
                t.partial,
                t.sigma
            );
        }
    }
    Ok(())
}

#[derive(Args)]
pub struct TrackArgs {
    /// Consecutive frames, in order.
    #[arg(required = true)]
    frames: Vec<PathBuf>,
    #[arg(long, default_value = "jtc")]
    method: String,
    /// Time between frames; with --pixel-pitch-um and the flight parameters, corrected velocities are printed.
    #[arg(long)]
    frame_period_s: Option<f64>,
    #[arg(long)]
    pixel_pitch_um: Option<f64>,
    /// Angle from the CCD's +x axis to the swing direction (towards +y).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    ccd_angle_deg: f64,
    /// The forward direction is the swing direction turned by -90 degrees instead of +90.
    #[arg(long)]
    ccd_mirrored: bool,
    #[arg(long)]
    focal_length_mm: Option<f64>,
    #[arg(long)]
    height_m: Option<f64>,
    #[arg(long)]
    speed_mps: Option<f64>,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    swing_deg: f64,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    swing_rate_dps: f64,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw_rate_dps: f64,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pitch_rate_dps: f64,
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    roll_rate_dps: f64,
}

/// The flight state when every parameter needed for corrected velocities is given.
fn track_flight(a: &TrackArgs) -> Result<Option<(FlightState, f64, f64)>> {
    let (Some(t), Some(p), Some(f), Some(h), Some(v)) = (
        a.frame_period_s,
        a.pixel_pitch_um,
        a.focal_length_mm,
        a.height_m,
        a.speed_mps,
    ) else {
        if a.frame_period_s.is_some()
            || a.focal_length_mm.is_some()
            || a.height_m.is_some()
            || a.speed_mps.is_some()
        {
            bail!(
                "corrected velocities need --frame-period-s, --pixel-pitch-um, --focal-length-mm, --height-m and --speed-mps together"
            );
        }
        return Ok(None);
    };
    if !(t.is_finite() && t > 0.0 && p.is_finite() && p > 0.0) {
        bail!("--frame-period-s {t} and --pixel-pitch-um {p} must be finite numbers > 0");
    }
    let s = FlightState {
        focal_length_mm: f,
        height_m: h,
        speed_mps: v,
        swing_deg: a.swing_deg,
        swing_rate_dps: a.swing_rate_dps,
        yaw_rate_dps: a.yaw_rate_dps,
        pitch_rate_dps: a.pitch_rate_dps,
        roll_rate_dps: a.roll_rate_dps,
    };
    check_flight(&s)?;
    Ok(Some((s, t, p)))
}

/// A decoded frame with its path, or why it could not be read.
type Decoded<'a> = (&'a Path, Result<aerorect::raster::Raster<f32>>);

/// Runs `consume` on `paths`' frames decoded in order on a thread of their own, at most two
/// frames ahead: decoding the next frame overlaps the estimate of the last pair. When
/// `consume` returns early, decoding stops.
fn with_frames_decoded_ahead<R>(
    paths: &[PathBuf],
    consume: impl FnOnce(&mut dyn Iterator<Item = Decoded<'_>>) -> R,
) -> R {
    let (tx, rx) = std::sync::mpsc::sync_channel(2);
    std::thread::scope(|s| {
        s.spawn(move || {
            for p in paths {
                // An error means the consumer has stopped.
                if tx.send((p.as_path(), read_gray(p))).is_err() {
                    break;
                }
            }
        });
        let mut frames = rx.into_iter();
        consume(&mut frames)
    })
}

/// The corrected velocities' parameters, when given.
type Flight = Option<(FlightState, f64, f64)>;

/// One CSV line per pair of `frames`; the frames that could not be used are returned.
fn track_frames(
    frames: &mut dyn Iterator<Item = Decoded<'_>>,
    method: Method,
    flight: &Flight,
    axes: &CcdAxes,
) -> Result<Vec<PathBuf>> {
    let mut tracker: Option<(Tracker, ImageSize)> = None;
    let mut skipped = vec![];
    for (path, frame) in frames {
        if crate::stdout::closed() {
            // Nobody reads the lines any more (`track ... | head`): stop like a Unix filter.
            break;
        }
        let frame = match frame {
            Ok(f) => f,
            Err(e) => {
                eprintln!("skipped {}: {e:#}", path.display());
                skipped.push(path.to_path_buf());
                continue;
            }
        };
        let (t, size) = match &mut tracker {
            Some(t) => t,
            None => tracker.insert((Tracker::new(method, frame.size())?, frame.size())),
        };
        if frame.size() != *size {
            eprintln!(
                "skipped {}: {} x {}, the track is {} x {}",
                path.display(),
                frame.width(),
                frame.height(),
                size.width,
                size.height
            );
            skipped.push(path.to_path_buf());
            continue;
        }
        let Some(step) = t
            .push(frame.plane(0).to_vec())
            .with_context(|| path.display().to_string())?
        else {
            continue;
        };
        outln!("{}", track_line(path, &step, flight, axes));
    }
    Ok(skipped)
}

fn track_line(
    path: &Path,
    step: &aerorect::motion::TrackStep,
    flight: &Flight,
    axes: &CcdAxes,
) -> String {
    let e = step.estimate;
    let mut line = format!(
        "{},{:.4},{:.4},{:.3},{:.3}",
        path.display(),
        e.dx,
        e.dy,
        e.confidence,
        step.seconds * 1e3
    );
    if let Some((s, period, pitch)) = flight {
        let (vp, vf) = corrected(&predict(s), (e.dx, e.dy), *pitch, *period, axes);
        line += &format!(",{vp:.4},{vf:.4}");
    }
    line
}

pub fn track(a: TrackArgs) -> Result<()> {
    let method = Method::parse(&a.method)?;
    let flight = track_flight(&a)?;
    let axes = CcdAxes {
        angle_deg: a.ccd_angle_deg,
        mirrored: a.ccd_mirrored,
    };
    let mut header = "frame,dx,dy,confidence,ms".to_string();
    if flight.is_some() {
        header += ",v_swing_mm_s,v_forward_mm_s";
    }
    outln!("{header}");
    let skipped = with_frames_decoded_ahead(&a.frames, |frames| {
        track_frames(frames, method, &flight, &axes)
    })?;
    if !skipped.is_empty() {
        bail!(
            "{} frame(s) skipped: {}",
            skipped.len(),
            skipped
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
