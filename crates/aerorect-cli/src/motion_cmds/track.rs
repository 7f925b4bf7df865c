//! The `track` subcommand: the shift between each pair of consecutive frames, decoded ahead on
//! a thread of their own, with corrected velocities when the flight is given.

use super::read_gray;
use super::velocity::check_flight;
use aerorect::core::ImageSize;
use aerorect::core::motion::{CcdAxes, FlightState, corrected, predict};
use aerorect::motion::{Method, Tracker};
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};

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
