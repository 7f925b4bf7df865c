//! One function per subcommand.

use crate::args::{RectifyArgs, coordinates, warp_options, write_image_and_report};
use crate::outputs::Files;
use aerorect::core::{AltitudeScale, RectifyLimits, SixAngleAttitude, attitude::SixAngleDegrees};
use aerorect::io::{
    CameraFile, StagedOutputs, image_files, read_attitude, read_checkpoints, read_image,
};
use aerorect::raster::{Interp, WarpOptions};
use aerorect::rectify::RectifyPlan;
use aerorect::sensitivity::{SensitivityConfig, SensitivityRow};
use aerorect::simulate::SimulatePlan;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;

fn altitude(h1: Option<f64>, h: Option<f64>) -> Result<Option<AltitudeScale>> {
    match (h1, h) {
        (None, None) => Ok(None),
        (Some(a), Some(b)) => Ok(Some(
            AltitudeScale::new(a, b).context("altitude normalisation")?,
        )),
        _ => bail!("--altitude-m and --base-altitude-m go together"),
    }
}

/// What rectify reads and writes (from metadata the output is georeferenced: a PNG gets
/// sidecars).
fn rectify_files(a: &RectifyArgs) -> Files {
    let mut files = Files::new()
        .input("INPUT", Some(&a.input))
        .input("--camera", a.camera.as_deref())
        .input_if_file("--attitude", a.attitude.as_deref())
        .input("--geo", a.geo.geo_file.as_deref())
        .input("--dem", a.geo.dem.as_deref());
    for p in image_files(&a.output, a.attitude.is_none()) {
        files = files.output("OUTPUT", Some(&p));
    }
    files.output("--report", a.report.as_deref())
}

pub fn rectify(a: RectifyArgs) -> Result<()> {
    rectify_files(&a).check()?;
    let Some(attitude) = &a.attitude else {
        return crate::drone_cmds::rectify_from_metadata(&a);
    };
    let Some(camera) = &a.camera else {
        bail!("--attitude needs --camera (or give neither to use the photo's metadata)");
    };
    let cam = CameraFile::read(camera)?;
    let attitude = read_attitude(attitude)?;
    let alt = altitude(a.altitude_m, a.base_altitude_m)?;
    let image = read_image(&a.input)?;
    let camera = cam.camera(Some(image.size()))?;
    let mut warp = warp_options(a.interp, !a.no_prefilter, a.nodata, a.alpha, &image)?;
    warp.coordinates = coordinates(a.exact_coordinates);
    let limits = RectifyLimits {
        max_output_px: a.max_output_px,
    };
    let plan = RectifyPlan::new(camera, attitude, alt, limits, warp).with_context(|| {
        format!(
            "{}: cannot rectify with this camera and attitude",
            a.input.display()
        )
    })?;
    let (out, seconds) = plan.run(&image)?;
    let report = plan.report(
        &a.input.display().to_string(),
        &a.output.display().to_string(),
        seconds,
    );
    let json = serde_json::to_string_pretty(&report)?;
    write_image_and_report(&a.output, &out, a.report.as_deref(), &json)?;
    let g = &plan.geometry;
    outln!(
        "{} -> {}: {} x {} px, standard origin ({}, {}){}, {} warp {:.1} ms",
        a.input.display(),
        a.output.display(),
        g.output_size.width,
        g.output_size.height,
        g.standard_origin[0],
        g.standard_origin[1],
        if g.clipped {
            ", clipped near the horizon"
        } else {
            ""
        },
        a.interp.name(),
        seconds * 1e3
    );
    Ok(())
}

#[derive(Args)]
pub struct SimulateArgs {
    /// The nadir standard image of the scene (its centre sits at the principal point).
    ortho: PathBuf,
    /// The simulated oblique frame (.tif or .png), of the camera file's image_size_px.
    output: PathBuf,
    #[arg(long)]
    camera: PathBuf,
    #[arg(long)]
    attitude: String,
    /// Resampling: nearest, bilinear, bicubic, or average (the area-weighted mean of the source
    /// pixels under each output pixel, GDAL's -r average, OpenCV's INTER_AREA).
    #[arg(long, default_value = "bicubic")]
    interp: Interp,
    /// Bilinear and bicubic: keep the plain kernel where the output is more than twice coarser
    /// than the source (by default such regions read a 2 x 2 box-reduced level, which stops aliasing).
    #[arg(long)]
    no_prefilter: bool,
    #[arg(long, default_value_t = 0.0)]
    nodata: f64,
    /// Number of check points to write (spread over the frame, on the ground).
    #[arg(long, requires = "checkpoints_out")]
    checkpoints: Option<usize>,
    /// Check-point CSV (u_oblique,v_oblique,u_standard,v_standard).
    #[arg(long, requires = "checkpoints")]
    checkpoints_out: Option<PathBuf>,
}

pub fn simulate(a: SimulateArgs) -> Result<()> {
    Files::new()
        .input("ORTHO", Some(&a.ortho))
        .input("--camera", Some(&a.camera))
        .input_if_file("--attitude", Some(&a.attitude))
        .output("OUTPUT", Some(&a.output))
        .output("--checkpoints-out", a.checkpoints_out.as_deref())
        .check()?;
    let camera = CameraFile::read(&a.camera)?.camera(None)?;
    let frame = camera.size;
    let attitude = read_attitude(&a.attitude)?;
    let ortho = read_image(&a.ortho)?;
    let plan = SimulatePlan::new(camera, &attitude, ortho.size());
    if let Some(n) = a.checkpoints {
        plan.check_checkpoint_count(n)?;
    }
    let warp = WarpOptions {
        interp: a.interp,
        nodata: a.nodata,
        alpha: false,
        prefilter: !a.no_prefilter,
        ..WarpOptions::default()
    };
    let frame_img = plan.render(&ortho, &warp)?;
    let points = match a.checkpoints {
        Some(n) => plan.checkpoints(n),
        None => vec![],
    };
    if let Some(n) = a.checkpoints
        && points.len() < n
    {
        bail!(
            "only {} of {n} check points see the scene inside ORTHO",
            points.len()
        );
    }
    let mut staged = StagedOutputs::new();
    staged.image(&a.output, &frame_img, None)?;
    if let Some(p) = &a.checkpoints_out {
        staged.csv(p, &points)?;
    }
    staged.commit()?;
    outln!(
        "{} -> {}: {} x {} frame, {} check points",
        a.ortho.display(),
        a.output.display(),
        frame.width,
        frame.height,
        points.len()
    );
    Ok(())
}

#[derive(Args)]
pub struct EvaluateArgs {
    #[arg(long)]
    camera: PathBuf,
    #[arg(long)]
    attitude: String,
    /// Check-point CSV (u_oblique,v_oblique,u_standard,v_standard).
    #[arg(long)]
    checkpoints: PathBuf,
    /// Print JSON with keys du_max, dv_max, urms, vrms, rmse.
    #[arg(long)]
    json: bool,
}

pub fn evaluate(a: EvaluateArgs) -> Result<()> {
    let camera = CameraFile::read(&a.camera)?.camera(None)?;
    let attitude = read_attitude(&a.attitude)?;
    let points = read_checkpoints(&a.checkpoints)?;
    let s = aerorect::evaluate::evaluate(&camera, &attitude, &points)
        .with_context(|| a.checkpoints.display().to_string())?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&s)?);
    } else {
        outln!("check points  du_max    dv_max    URMS      VRMS      RMSE   (pixels)");
        outln!(
            "{:>12}  {:<9.4} {:<9.4} {:<9.4} {:<9.4} {:<9.4}",
            s.n,
            s.du_max,
            s.dv_max,
            s.urms,
            s.vrms,
            s.rmse
        );
    }
    Ok(())
}

#[derive(Args)]
pub struct SensitivityArgs {
    /// Camera file; default: 512 x 512, fx = fy = 1000 px (28.7 degree field of view).
    #[arg(long)]
    camera: Option<PathBuf>,
    /// Nominal attitude; default: the demo's (azimuth 20, elevation 20, image_rotation 2, pitch 3, roll -2, yaw 15).
    #[arg(long)]
    attitude: Option<String>,
    /// One-sigma error of every angle, arc-minutes.
    #[arg(long, default_value_t = 3.0)]
    sigma_arcmin: f64,
    #[arg(long, default_value_t = 2000)]
    draws: usize,
    /// Check points on a k x k grid.
    #[arg(long, default_value_t = 5)]
    grid: usize,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long)]
    json: bool,
}

pub const SENSITIVITY_CAMERA: &str = "fx_px = 1000.0\nfy_px = 1000.0\nimage_size_px = [512, 512]\n";

pub fn sensitivity(a: SensitivityArgs) -> Result<()> {
    let cam = match &a.camera {
        Some(p) => CameraFile::read(p)?,
        None => CameraFile::parse(SENSITIVITY_CAMERA, "default camera")?,
    };
    let camera = cam.camera(None)?;
    let frame = camera.size;
    let attitude = match &a.attitude {
        Some(s) => read_attitude(s)?,
        None => SixAngleAttitude::from_degrees(&aerorect::demo::ATTITUDE)?,
    };
    let cfg = SensitivityConfig {
        camera,
        attitude,
        sigma_arcmin: a.sigma_arcmin,
        draws: a.draws,
        grid: a.grid,
        seed: a.seed,
    };
    let row = aerorect::sensitivity::run(&cfg)?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&row)?);
    } else {
        print_sensitivity(&row, &attitude.to_degrees(), frame.width, frame.height);
    }
    Ok(())
}

pub fn print_sensitivity(r: &SensitivityRow, att: &SixAngleDegrees, w: usize, h: usize) {
    outln!(
        "{w} x {h} frame, field of view {:.1} x {:.1} deg, {} check points, every angle N(0, {}') over {} draws",
        r.fov_deg[0],
        r.fov_deg[1],
        r.checkpoints,
        r.sigma_arcmin,
        r.draws
    );
    // Rounded to 1e-9 degree: the degrees -> radians -> degrees round trip leaves float noise.
    let rd = |v: f64| (v * 1e9).round() / 1e9;
    outln!(
        "attitude (deg): azimuth {} elevation {} image_rotation {} pitch {} roll {} yaw {}",
        rd(att.azimuth),
        rd(att.elevation),
        rd(att.image_rotation),
        rd(att.pitch),
        rd(att.roll),
        rd(att.yaw),
    );
    outln!(
        "method                          du_max   dv_max   URMS     VRMS     RMSE   (pixels, means over draws)"
    );
    outln!("paper, six-angle model (Tab. 1) 1.6785   2.2546   0.7157   0.9315   1.1747");
    outln!(
        "aerorect, six-angle model       {:<8.4} {:<8.4} {:<8.4} {:<8.4} {:<8.4}",
        r.du_max,
        r.dv_max,
        r.urms,
        r.vrms,
        r.rmse
    );
    outln!(
        "sqrt(mean RMSE^2) {:.4} px; first-order prediction {:.4} px",
        r.rms_of_rmse,
        r.predicted_rms_of_rmse
    );
}

#[derive(Args)]
pub struct DemoArgs {
    /// Where to write the demo's files.
    #[arg(long, default_value = "out/demo")]
    out_dir: PathBuf,
}

pub fn demo(a: DemoArgs) -> Result<()> {
    Files::new().folder("--out-dir", Some(&a.out_dir)).check()?;
    let s = aerorect::demo::run(&a.out_dir)?;
    let d = a.out_dir.display();
    outln!("aerorect demo: OpenCV's aero1.jpg (a real aerial photo) as the nadir scene");
    outln!(
        "camera: 6 mm lens, 15 um pixels, 320 x 240; attitude (deg): azimuth 20, elevation 20, image_rotation 2, pitch 3, roll -2, yaw 15"
    );
    outln!(
        "1. simulated the oblique frame        -> {d}/oblique.png, 25 check points -> {d}/checkpoints.csv"
    );
    outln!(
        "2. rectified it ({} x {} px{})         -> {d}/rectified_bilinear.png, {d}/rectified_bicubic.png",
        s.output_size[0],
        s.output_size[1],
        if s.clipped { ", clipped" } else { "" }
    );
    outln!(
        "   PSNR against the scene: bilinear {:.2} dB, bicubic {:.2} dB over {} pixel samples",
        s.psnr_bilinear_db.0,
        s.psnr_bicubic_db.0,
        s.psnr_bicubic_db.1
    );
    outln!(
        "3. check points (eq. 19-20), exact attitude:      RMSE {:.2e} px (du_max {:.2e}, dv_max {:.2e})",
        s.exact.rmse,
        s.exact.du_max,
        s.exact.dv_max
    );
    outln!(
        "   every angle off by +3 arc-minutes:             RMSE {:.4} px (URMS {:.4}, VRMS {:.4})",
        s.off_by_3_arcmin.rmse,
        s.off_by_3_arcmin.urms,
        s.off_by_3_arcmin.vrms
    );
    outln!(
        "4. random 3' errors on all six angles, {} draws: mean RMSE {:.4} px for this {:.1} deg camera (`aerorect sensitivity` runs the paper's 512 x 512 case)",
        s.sensitivity.draws,
        s.sensitivity.rmse,
        s.sensitivity.fov_deg[0]
    );
    outln!(
        "warp time {:.2} ms; everything, with reports, in {d}/ (summary.json)",
        s.warp_seconds * 1e3
    );
    outln!(
        "try: aerorect rectify {d}/oblique.png {d}/mine.tif --camera {d}/camera.toml --attitude {d}/attitude.toml --report {d}/mine.json"
    );
    Ok(())
}
