//! `aerorect demo`: simulate an oblique frame of a bundled real aerial photo, rectify it,
//! evaluate it, and write everything into one folder.

use crate::Error;
use crate::evaluate::{evaluate, rectified_psnr};
use crate::rectify::RectifyPlan;
use crate::sensitivity::{SensitivityConfig, SensitivityRow};
use crate::simulate::SimulatePlan;
use aerorect_core::attitude::SixAngleDegrees;
use aerorect_core::{CheckPointStats, RectifyLimits, SixAngleAttitude};
use aerorect_io::{CameraFile, StagedOutputs, decode_image_bytes};
use aerorect_raster::{Interp, WarpOptions};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// OpenCV's aero1.jpg (Debian opencv-doc), used as the nadir standard scene.
pub const SCENE_JPEG: &[u8] = include_bytes!("../../../../data/aero1.jpg");

/// The demo camera: 6 mm lens, 15 um pixels, 320 x 240 (fx = fy = 400 px, 43.6 x 33.4 degrees).
pub const CAMERA_TOML: &str =
    "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [320, 240]\n";

/// The demo attitude, in degrees.
pub const ATTITUDE: SixAngleDegrees = SixAngleDegrees {
    azimuth: 20.0,
    elevation: 20.0,
    image_rotation: 2.0,
    pitch: 3.0,
    roll: -2.0,
    yaw: 15.0,
};

/// What the demo measured.
#[derive(Debug, Clone, Serialize)]
pub struct DemoSummary {
    pub out_dir: PathBuf,
    pub files: Vec<String>,
    pub output_size: [usize; 2],
    pub clipped: bool,
    pub warp_seconds: f64,
    /// Check points evaluated with the exact attitude.
    pub exact: CheckPointStats,
    /// The same check points with every angle off by +3 arc-minutes.
    pub off_by_3_arcmin: CheckPointStats,
    /// PSNR of the rectified frame against the scene, bilinear and bicubic (dB, pixels compared).
    pub psnr_bilinear_db: (f64, usize),
    pub psnr_bicubic_db: (f64, usize),
    pub sensitivity: SensitivityRow,
}

/// Runs the demo into `out_dir` (created if needed).
pub fn run(out_dir: &Path) -> Result<DemoSummary, Error> {
    std::fs::create_dir_all(out_dir).map_err(Error::file(out_dir))?;
    let scene = decode_image_bytes(SCENE_JPEG, "embedded aero1.jpg")?;
    let camera = CameraFile::parse(CAMERA_TOML, "demo camera")?.camera(None)?;
    let attitude =
        SixAngleAttitude::from_degrees(&ATTITUDE).map_err(Error::geometry("demo attitude"))?;

    let sim = SimulatePlan::new(camera.clone(), &attitude, scene.size());
    let oblique = sim.render(
        &scene,
        &WarpOptions {
            interp: Interp::Bicubic,
            ..Default::default()
        },
    )?;
    let points = sim.checkpoints(25);

    let mut files = vec![];
    let mut put = |name: &str| -> PathBuf {
        files.push(name.to_string());
        out_dir.join(name)
    };
    // Every file lands at the end, together, or none does.
    let mut staged = StagedOutputs::new();
    staged.image(&put("standard_scene.png"), &scene, None)?;
    staged.text(&put("camera.toml"), CAMERA_TOML)?;
    staged.text(&put("attitude.toml"), &attitude_toml(&ATTITUDE))?;
    staged.image(&put("oblique.png"), &oblique, None)?;
    staged.csv(&put("checkpoints.csv"), &points)?;

    let mut psnr = [(0.0, 0); 2];
    let mut last = None;
    for (k, interp) in [Interp::Bicubic, Interp::Bilinear].into_iter().enumerate() {
        let warp = WarpOptions {
            interp,
            nodata: 0.0,
            alpha: true,
            prefilter: true,
            ..WarpOptions::default()
        };
        let limits = RectifyLimits::default();
        let plan = RectifyPlan::new(camera.clone(), attitude, None, limits, warp)?;
        let (rectified, seconds) = plan.run(&oblique)?;
        psnr[1 - k] = rectified_psnr(&rectified, &plan.geometry, &camera, &scene, 2.0)
            .ok_or_else(|| Error::Invalid("no pixel to compare".into()))?;
        let name = format!("rectified_{}.png", interp.name());
        let report = plan.report("oblique.png", &name, seconds);
        staged.image(&put(&name), &rectified, None)?;
        staged.text(
            &put(&format!("rectify_{}_report.json", interp.name())),
            &to_json(&report)?,
        )?;
        last = Some((plan, seconds));
    }
    let (plan, warp_seconds) = last.ok_or_else(|| Error::Invalid("no rectification".into()))?;

    let exact = evaluate(&camera, &attitude, &points)?;
    let off = SixAngleAttitude::from_degrees(&SixAngleDegrees {
        azimuth: ATTITUDE.azimuth + 0.05,
        elevation: ATTITUDE.elevation + 0.05,
        image_rotation: ATTITUDE.image_rotation + 0.05,
        pitch: ATTITUDE.pitch + 0.05,
        roll: ATTITUDE.roll + 0.05,
        yaw: ATTITUDE.yaw + 0.05,
    })
    .map_err(Error::geometry("perturbed attitude"))?;
    let off_by_3_arcmin = evaluate(&camera, &off, &points)?;
    let sensitivity = crate::sensitivity::run(&SensitivityConfig {
        camera,
        attitude,
        sigma_arcmin: 3.0,
        draws: 2000,
        grid: 5,
        seed: 1,
    })?;
    files.push("summary.json".into());
    let summary = DemoSummary {
        out_dir: out_dir.to_path_buf(),
        files,
        output_size: [
            plan.geometry.output_size.width,
            plan.geometry.output_size.height,
        ],
        clipped: plan.geometry.clipped,
        warp_seconds,
        exact,
        off_by_3_arcmin,
        psnr_bilinear_db: psnr[0],
        psnr_bicubic_db: psnr[1],
        sensitivity,
    };
    staged.text(&out_dir.join("summary.json"), &to_json(&summary)?)?;
    staged.commit()?;
    Ok(summary)
}

fn attitude_toml(d: &SixAngleDegrees) -> String {
    SixAngleDegrees::FIELDS
        .iter()
        .zip(d.values())
        .map(|(k, v)| format!("{k} = {v:?}\n"))
        .collect()
}

fn to_json<T: Serialize>(v: &T) -> Result<String, Error> {
    serde_json::to_string_pretty(v).map_err(Error::from)
}

/// Writes text atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), Error> {
    use std::io::Write;
    aerorect_io::write_atomically(path, |w| {
        w.write_all(text.as_bytes())
            .map_err(|e| aerorect_io::IoError::Io {
                source_name: path.display().to_string(),
                error: e,
            })
    })?;
    Ok(())
}
