//! The paper's baselines: `gcp` (polynomial correction), `register` (to a reference image) and
//! `compare` (Table 1).

use crate::args::{warp_options, write_image_and_report};
use crate::outputs::Files;
use aerorect::compare::{CompareConfig, CompareResult};
use aerorect::core::error::Num;
use aerorect::core::{ImageSize, RectifyLimits, SixAngleAttitude, rectify::DEFAULT_MAX_OUTPUT_PX};
use aerorect::gcp::{GcpPlan, GcpResidual};
use aerorect::io::{CameraFile, StagedOutputs, read_attitude, read_gcps, read_image};
use aerorect::motion::gray;
use aerorect::raster::Interp;
use aerorect::register::{RegisterOptions, Registration, TieModel, register};
use aerorect::solve::gcp::GcpModel;
use aerorect::warp_any;
use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args)]
pub struct GcpArgs {
    /// The image to correct (PNG, JPEG or TIFF).
    input: PathBuf,
    /// The corrected image, in the reference frame's pixels (.tif or .png).
    output: PathBuf,
    /// GCP table: CSV with the header u_image,v_image,u_ref,v_ref.
    #[arg(long)]
    gcps: PathBuf,
    /// bilinear, quadratic, cubic or projective.
    #[arg(long, default_value = "quadratic")]
    model: String,
    /// Output grid in reference pixels, X0,Y0,WIDTH,HEIGHT; default: the image's footprint.
    #[arg(long)]
    grid: Option<String>,
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
    #[arg(long)]
    alpha: bool,
    #[arg(long, default_value_t = DEFAULT_MAX_OUTPUT_PX)]
    max_output_px: u64,
    /// JSON report: coefficients, per-GCP residuals, residual_rms_px, output grid.
    #[arg(long)]
    report: Option<PathBuf>,
}

#[derive(Serialize)]
struct GcpReport<'a> {
    input: String,
    output: String,
    model: &'static str,
    gcp_count: usize,
    /// u_image / v_image as functions of (u, v) = reference pixel.
    coefficients: aerorect::gcp::Coefficients,
    /// Measured minus fitted image position, pixels.
    residuals: &'a [GcpResidual],
    residual_rms_px: f64,
    output_origin: [i64; 2],
    output_size: [usize; 2],
    interp: &'static str,
    seconds: f64,
}

fn parse_grid(s: &str) -> Result<([i64; 2], ImageSize)> {
    let v: Vec<i64> = s
        .split(',')
        .map(|t| t.trim().parse::<i64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--grid '{s}': expected X0,Y0,WIDTH,HEIGHT integers"))?;
    match v[..] {
        [x0, y0, w, h] if w > 0 && h > 0 => Ok(([x0, y0], ImageSize::new(w as usize, h as usize))),
        _ => bail!("--grid '{s}': expected X0,Y0,WIDTH,HEIGHT with positive width and height"),
    }
}

pub fn gcp(a: GcpArgs) -> Result<()> {
    Files::new()
        .input("INPUT", Some(&a.input))
        .input("--gcps", Some(&a.gcps))
        .output("OUTPUT", Some(&a.output))
        .output("--report", a.report.as_deref())
        .check()?;
    let model = GcpModel::parse(&a.model).with_context(|| {
        format!(
            "--model '{}': expected bilinear, quadratic, cubic or projective",
            a.model
        )
    })?;
    let grid = a.grid.as_deref().map(parse_grid).transpose()?;
    let gcps = read_gcps(&a.gcps)?;
    let image = read_image(&a.input)?;
    let warp = warp_options(a.interp, !a.no_prefilter, a.nodata, a.alpha, &image)?;
    let limits = RectifyLimits {
        max_output_px: a.max_output_px,
    };
    let t = Instant::now();
    let plan = GcpPlan::fit(&gcps, model, image.size(), grid, limits)
        .with_context(|| format!("{}: {} GCPs", a.gcps.display(), gcps.len()))?;
    let out = plan.run(&image, &warp)?;
    let seconds = t.elapsed().as_secs_f64();
    let report = GcpReport {
        input: a.input.display().to_string(),
        output: a.output.display().to_string(),
        model: model.name(),
        gcp_count: gcps.len(),
        coefficients: plan.coefficients(),
        residuals: &plan.residuals,
        residual_rms_px: plan.residual_rms_px(),
        output_origin: plan.output_origin,
        output_size: [plan.output_size.width, plan.output_size.height],
        interp: a.interp.name(),
        seconds,
    };
    let json = serde_json::to_string_pretty(&report)?;
    write_image_and_report(&a.output, &out, a.report.as_deref(), &json)?;
    outln!(
        "{} -> {}: {} fit to {} GCPs, residual RMS {:.4} px, {} x {} px at reference ({}, {}), {:.1} ms",
        a.input.display(),
        a.output.display(),
        model.name(),
        gcps.len(),
        report.residual_rms_px,
        plan.output_size.width,
        plan.output_size.height,
        plan.output_origin[0],
        plan.output_origin[1],
        seconds * 1e3
    );
    Ok(())
}

/// Each out-of-range option named alone, with its value and its range.
fn check_register_ranges(a: &RegisterArgs) -> Result<()> {
    if a.patch < 16 {
        bail!("--patch {}: must be at least 16", a.patch);
    }
    if !(a.ransac_px.is_finite() && a.ransac_px > 0.0) {
        bail!(
            "--ransac-px {}: must be a finite number > 0",
            Num(a.ransac_px)
        );
    }
    // Beyond 10 the coarse search only grows (1e300 ran for minutes): 64 px patches of frames
    // ten times apart in scale share no texture to correlate.
    if !(1.0..=10.0).contains(&a.max_scale) {
        bail!("--max-scale {}: must be from 1 to 10", Num(a.max_scale));
    }
    Ok(())
}

#[derive(Args)]
pub struct RegisterArgs {
    /// The frame to register.
    input: PathBuf,
    /// The reference image (for example an orthoimage); the output takes its grid.
    reference: PathBuf,
    /// The registered frame (.tif or .png).
    output: PathBuf,
    /// projective or piecewise (affine over the Delaunay triangulation of the inliers).
    #[arg(long, default_value = "projective")]
    model: String,
    /// Side of the matched patches, pixels.
    #[arg(long, default_value_t = 64)]
    patch: usize,
    /// RANSAC inlier distance, pixels of the frame.
    #[arg(long, default_value_t = 2.0)]
    ransac_px: f64,
    /// Coarse search: rotations this many degrees apart (full circle).
    #[arg(long, default_value_t = 5.0)]
    rotation_step_deg: f64,
    /// Coarse search: scales from 1/S to S.
    #[arg(long, default_value_t = 2.0)]
    max_scale: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
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
    #[arg(long)]
    alpha: bool,
    /// JSON report: tie points (with inlier flags and residuals), the transform, timing.
    #[arg(long)]
    report: Option<PathBuf>,
}

#[derive(Serialize)]
struct RegisterReport<'a> {
    input: String,
    reference: String,
    output: String,
    model: TieModel,
    /// image_from_ref, row-major: the inliers' least-squares homography.
    homography_image_from_ref: [[f64; 3]; 3],
    coarse: aerorect::register::CoarseAlignment,
    tie_points: usize,
    inliers: usize,
    inlier_rms_px: f64,
    ties: &'a [aerorect::register::TiePoint],
    seconds: f64,
}

fn register_report(a: &RegisterArgs, reg: &Registration, seconds: f64) -> Result<String> {
    let m = reg.homography.row_major();
    let report = RegisterReport {
        input: a.input.display().to_string(),
        reference: a.reference.display().to_string(),
        output: a.output.display().to_string(),
        model: reg.model,
        homography_image_from_ref: m.map(|r| r.map(|x| x / m[2][2])),
        coarse: reg.coarse,
        tie_points: reg.ties.len(),
        inliers: reg.inliers(),
        inlier_rms_px: reg.inlier_rms_px(),
        ties: &reg.ties,
        seconds,
    };
    Ok(serde_json::to_string_pretty(&report)?)
}

pub fn register_cmd(a: RegisterArgs) -> Result<()> {
    Files::new()
        .input("INPUT", Some(&a.input))
        .input("REFERENCE", Some(&a.reference))
        .output("OUTPUT", Some(&a.output))
        .output("--report", a.report.as_deref())
        .check()?;
    let opts = RegisterOptions {
        model: TieModel::parse(&a.model)?,
        patch: a.patch,
        ransac_px: a.ransac_px,
        rotation_step_deg: a.rotation_step_deg,
        max_scale: a.max_scale,
        seed: a.seed,
        ..RegisterOptions::default()
    };
    check_register_ranges(&a)?;
    let image = read_image(&a.input)?;
    let reference = read_image(&a.reference)?;
    let warp = warp_options(a.interp, !a.no_prefilter, a.nodata, a.alpha, &image)?;
    let t = Instant::now();
    let reg = register(&gray(&image)?, &gray(&reference)?, &opts)
        .with_context(|| format!("{} -> {}", a.input.display(), a.reference.display()))?;
    let out = warp_any(&image, &reg.image_from_ref, reference.size(), &warp)?;
    let seconds = t.elapsed().as_secs_f64();
    let json = register_report(&a, &reg, seconds)?;
    write_image_and_report(&a.output, &out, a.report.as_deref(), &json)?;
    outln!(
        "{} -> {}: {} tie points, {} inliers, inlier RMS {:.3} px, coarse rotation {:.0} deg scale {:.2}, {:.2} s",
        a.input.display(),
        a.output.display(),
        reg.ties.len(),
        reg.inliers(),
        reg.inlier_rms_px(),
        reg.coarse.rotation_deg,
        reg.coarse.scale,
        seconds
    );
    Ok(())
}

#[derive(Args)]
pub struct CompareArgs {
    /// The reference orthoimage the frame is simulated from (the paper: an airport,
    /// ../shared/data/aerial/sipi_5.3.02.tiff).
    reference: PathBuf,
    /// Camera file; default: 512 x 512, fx = fy = 500 px (54 degree field of view).
    #[arg(long)]
    camera: Option<PathBuf>,
    /// True attitude; default: azimuth 20, elevation 30, image_rotation 2, pitch 3, roll -2, yaw 15.
    #[arg(long)]
    attitude: Option<String>,
    /// One-sigma attitude error of the six-angle row, arc-minutes.
    #[arg(long, default_value_t = 3.0)]
    attitude_noise_arcmin: f64,
    #[arg(long, default_value_t = 30)]
    gcps: usize,
    #[arg(long, default_value_t = 25)]
    checkpoints: usize,
    /// One-sigma measurement error of every GCP and check-point coordinate, pixels.
    #[arg(long, default_value_t = 0.3)]
    point_noise_px: f64,
    /// One-sigma sensor noise of the simulated frame, gray levels.
    #[arg(long, default_value_t = 2.0)]
    image_noise: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write the table as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also write the simulated frame here (.tif or .png).
    #[arg(long)]
    frame_out: Option<PathBuf>,
}

pub fn compare(a: CompareArgs) -> Result<()> {
    Files::new()
        .input("REFERENCE", Some(&a.reference))
        .input("--camera", a.camera.as_deref())
        .input_if_file("--attitude", a.attitude.as_deref())
        .output("--json", a.json.as_deref())
        .output("--frame-out", a.frame_out.as_deref())
        .check()?;
    let cam = match &a.camera {
        Some(p) => CameraFile::read(p)?,
        None => CameraFile::parse(aerorect::compare::CAMERA_TOML, "default camera")?,
    };
    let camera = cam.camera(None)?;
    let attitude = match &a.attitude {
        Some(s) => read_attitude(s)?,
        None => SixAngleAttitude::from_degrees(&aerorect::compare::ATTITUDE)?,
    };
    let reference = read_image(&a.reference)?;
    let cfg = CompareConfig {
        camera,
        attitude,
        attitude_noise_arcmin: a.attitude_noise_arcmin,
        gcps: a.gcps,
        checkpoints: a.checkpoints,
        point_noise_px: a.point_noise_px,
        image_noise: a.image_noise,
        seed: a.seed,
        register: RegisterOptions::default(),
    };
    let result = aerorect::compare::compare(&reference, &cfg)
        .with_context(|| format!("{}: Table 1", a.reference.display()))?;
    let mut staged = StagedOutputs::new();
    if let Some(p) = &a.frame_out {
        staged.image(p, &result.frame, None)?;
    }
    if let Some(p) = &a.json {
        staged.text(p, &serde_json::to_string_pretty(&result)?)?;
    }
    staged.commit()?;
    print_table(&result, &a);
    Ok(())
}

fn print_table(r: &CompareResult, a: &CompareArgs) {
    outln!(
        "{} x {} frame simulated from {} ({} x {}); {} GCPs, {} check points, point noise {} px, attitude N(0, {}'), {} tie points ({} inliers)",
        r.frame_size[0],
        r.frame_size[1],
        a.reference.display(),
        r.reference_size[0],
        r.reference_size[1],
        r.gcps,
        r.checkpoints,
        a.point_noise_px,
        a.attitude_noise_arcmin,
        r.tie_points,
        r.tie_inliers
    );
    outln!(
        "{:<13} {:>8} {:>8} {:>8} {:>8} {:>8} {:>9} | paper: {:>7} {:>7} {:>7}",
        "method",
        "du_max",
        "dv_max",
        "URMS",
        "VRMS",
        "RMSE",
        "time s",
        "RMSE",
        "time s",
        ""
    );
    for row in &r.rows {
        let s = &row.stats;
        outln!(
            "{:<13} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>8.4} {:>9.3} | paper: {:>7.4} {:>7.2}",
            row.method,
            s.du_max,
            s.dv_max,
            s.urms,
            s.vrms,
            s.rmse,
            row.seconds,
            row.paper[4],
            row.paper[5]
        );
    }
}
