//! Lens subcommands: calibrate, undistort.

use crate::outputs::Files;
use aerorect::core::ImageSize;
use aerorect::core::distortion::Distortion;
use aerorect::io::{CameraFile, StagedOutputs, camera_toml, read_image, write_image};
use aerorect::raster::Interp;
use aerorect::solve::calib::{CalibrationOptions, CalibrationReport, calibrate};
use aerorect::undistort::UndistortPlan;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct CalibrateArgs {
    /// Control points: CSV `image,X,Y,Z,u,v` (one observation a row; `image` an id).
    #[arg(long, conflicts_with = "images", required_unless_present = "images")]
    points: Option<PathBuf>,
    /// Chessboard photos, all of one size; a photo without the whole board is listed with the
    /// reason and skipped (at least 3 must remain).
    #[arg(long, num_args = 1.., required_unless_present = "points", requires_all = ["board", "square_m"])]
    images: Vec<PathBuf>,
    /// The chessboard's inner corners COLSxROWS (OpenCV's patternSize), e.g. 9x6.
    #[arg(long, requires = "images")]
    board: Option<String>,
    /// The chessboard's square size in metres.
    #[arg(long, requires = "images")]
    square_m: Option<f64>,
    /// Write the corners found (CSV `image,X,Y,Z,u,v`, the `--points` input).
    #[arg(long, requires = "images")]
    save_corners: Option<PathBuf>,
    /// Refine every corner in a (2 N + 1)-pixel window, as OpenCV's cornerSubPix with
    /// winSize (N, N): the default 11 is what OpenCV's calibration sample uses, so corners and
    /// calibration agree with OpenCV's; `auto` narrows the window (N at most 11) where it would
    /// reach past the corner's four squares (small or foreshortened squares: more accurate on
    /// steep boards, where OpenCV's fixed window takes in other squares' edges).
    #[arg(long, requires = "images", default_value = "11", value_parser = parse_corner_window)]
    corner_window: CornerWindow,
    /// Image size WxH, e.g. 640x480 (with --images: taken from the photos, and checked if given).
    #[arg(long)]
    image_size: Option<String>,
    /// tsai, brown, improved, opencv (k1, k2, p1, p2, k3: OpenCV's default), opencv-rational
    /// (+ k4..k6), opencv-thin-prism (+ s1..s4) or opencv-rational-thin-prism.
    #[arg(long)]
    model: String,
    /// Parameters held at their start, comma-separated (fx, fy, cx, cy, skew, k1, ...).
    #[arg(long, value_delimiter = ',')]
    fix: Vec<String>,
    /// Free the skew (zero otherwise).
    #[arg(long)]
    skew: bool,
    /// Hold fx = fy.
    #[arg(long)]
    fix_aspect: bool,
    /// Stop when every update moves every point by less than this many pixels.
    #[arg(long, default_value_t = 0.01)]
    stop_px: f64,
    #[arg(long, default_value_t = 200)]
    max_iterations: usize,
    /// The full report as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// A camera file (intrinsics in pixels and `[distortion]`) for undistort and rectify.
    #[arg(long)]
    camera_out: Option<PathBuf>,
    /// The points' coverage of the image as an SVG heat map (8 x 6 cells; the JSON report has
    /// the counts as `coverage`).
    #[arg(long)]
    coverage_svg: Option<PathBuf>,
}

/// `--corner-window`: OpenCV's fixed half-window, or sized per corner.
#[derive(Debug, Clone, Copy)]
enum CornerWindow {
    Fixed(usize),
    Auto,
}

fn parse_corner_window(s: &str) -> Result<CornerWindow, String> {
    match s.trim() {
        "auto" => Ok(CornerWindow::Auto),
        t => match t.parse::<usize>() {
            Ok(n) if n > 0 => Ok(CornerWindow::Fixed(n)),
            _ => Err(format!(
                "'{s}': expected a half-window N > 0 (pixels) or auto"
            )),
        },
    }
}

pub(crate) fn parse_size(s: &str) -> Result<ImageSize> {
    let parse = || -> Option<(u64, u64)> {
        let (w, h) = s.split_once(['x', 'X'])?;
        Some((w.trim().parse().ok()?, h.trim().parse().ok()?))
    };
    match parse() {
        Some((w, h)) if w > 0 && h > 0 => {
            ImageSize::validate_sides(w, h).with_context(|| format!("--image-size '{s}'"))?;
            Ok(ImageSize::new(w as usize, h as usize))
        }
        _ => bail!("--image-size '{s}': expected WxH with positive integers, e.g. 640x480"),
    }
}

pub fn calibrate_cmd(a: CalibrateArgs) -> Result<()> {
    let files = a
        .images
        .iter()
        .fold(Files::new(), |f, p| f.input("--images", Some(p)));
    files
        .input("--points", a.points.as_deref())
        .output("--json", a.json.as_deref())
        .output("--camera-out", a.camera_out.as_deref())
        .output("--coverage-svg", a.coverage_svg.as_deref())
        .output("--save-corners", a.save_corners.as_deref())
        .check()?;
    let given = a.image_size.as_deref().map(parse_size).transpose()?;
    let model = Distortion::zero(&a.model).with_context(|| {
        format!(
            "--model '{}': expected one of {}",
            a.model,
            Distortion::NAMES.join(", ")
        )
    })?;
    if !(a.stop_px.is_finite() && a.stop_px > 0.0) {
        bail!("--stop-px {}: must be a finite number > 0", a.stop_px);
    }
    let mut staged = StagedOutputs::new();
    let (obs, size, source) = match &a.points {
        Some(points) => {
            let size = given.context("--image-size WxH is required with --points")?;
            let obs = aerorect::calibration::read_observations(points)?;
            (obs, size, points.display().to_string())
        }
        None => {
            let found = crate::board_cmds::board_observations(
                &a.images,
                &a.board,
                a.square_m,
                match a.corner_window {
                    CornerWindow::Fixed(n) => Some(n),
                    CornerWindow::Auto => None,
                },
            )?;
            if let Some(g) = given.filter(|g| *g != found.size) {
                bail!(
                    "--image-size {}x{}: the photos are {}x{}",
                    g.width,
                    g.height,
                    found.size.width,
                    found.size.height
                );
            }
            if let Some(p) = &a.save_corners {
                staged.csv(p, &found.control_points())?;
            }
            (
                found.observations,
                found.size,
                "the chessboard photos".to_string(),
            )
        }
    };
    let mut opts = CalibrationOptions::new(model, size);
    opts.fix = a
        .fix
        .iter()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .collect();
    opts.skew = a.skew;
    opts.fixed_aspect = a.fix_aspect.then_some(1.0);
    opts.stop_px = a.stop_px;
    opts.max_iterations = a.max_iterations;
    let r = calibrate(&obs, &opts).with_context(|| source.clone())?;
    print_report(&r, obs.len());
    if let Some(j) = &a.json {
        staged.text(j, &serde_json::to_string_pretty(&report_json(&r)?)?)?;
    }
    if let Some(c) = &a.camera_out {
        let text = camera_toml(&r.camera(size)?)?;
        let header = format!("# written by aerorect calibrate (RMS {:.4} px)\n", r.rms_px);
        staged.text(c, &(header + &text))?;
    }
    if let Some(p) = &a.coverage_svg {
        staged.text(p, &crate::plot::coverage_svg(p, &r.coverage, size)?)?;
    }
    staged.commit()?;
    Ok(())
}

fn print_report(r: &CalibrationReport, n: usize) {
    outln!(
        "{} points in {} images, model {}; {} iterations, stopped: {:?}",
        n,
        r.views.len(),
        r.distortion.kind(),
        r.iterations,
        r.stop_reason
    );
    for p in &r.parameters {
        match p.std {
            Some(s) => outln!("  {:<6} {:>14.6} +- {:.6}", p.name, p.value, s),
            None => outln!("  {:<6} {:>14.6}   (fixed)", p.name, p.value),
        }
    }
    outln!(
        "RMS {:.5} px, mean error {:.5} px, distortion {:.4} %",
        r.rms_px,
        r.mean_error_px,
        r.distortion_percent
    );
    for v in &r.views {
        outln!(
            "  image {:<14} {:>4} points  RMS {:.4} px",
            v.image,
            v.points,
            v.rms_px
        );
    }
    for h in &r.held_fixed {
        outln!("note: {h}");
    }
    for w in r.warnings.iter().chain(&r.correlation_warnings) {
        outln!("warning: {w}");
    }
}

/// The JSON report: fx, fy, cx, cy, skew, the coefficients by name at the top level, rms_px,
/// per-image RMS and poses, standard deviations, stop reason, and the rest of the report.
fn report_json(r: &CalibrationReport) -> Result<serde_json::Value> {
    let mut v = serde_json::to_value(r)?;
    let obj = v.as_object_mut().context("report is an object")?;
    let model = r.distortion.model();
    for (name, value) in model.names().iter().zip(model.params()) {
        obj.insert(name.to_string(), value.into());
    }
    obj.insert("model".into(), r.distortion.kind().into());
    let std: serde_json::Map<String, serde_json::Value> = r
        .parameters
        .iter()
        .map(|p| {
            (
                p.name.clone(),
                p.std.map_or(serde_json::Value::Null, Into::into),
            )
        })
        .collect();
    obj.insert("std".into(), std.into());
    Ok(v)
}

#[derive(Args)]
pub struct UndistortArgs {
    input: PathBuf,
    output: PathBuf,
    /// Camera file with lens terms (any format `camera convert` reads).
    #[arg(long)]
    camera: PathBuf,
    /// Resampling: nearest, bilinear, bicubic, or average (the area-weighted mean of the source
    /// pixels under each output pixel, GDAL's -r average, OpenCV's INTER_AREA).
    #[arg(long, default_value = "bilinear")]
    interp: Interp,
    /// Bilinear and bicubic: keep the plain kernel where the output is more than twice coarser
    /// than the source (by default such regions read a 2 x 2 box-reduced level, which stops aliasing).
    #[arg(long)]
    no_prefilter: bool,
    /// Grow the output to hold every valid pixel (same focal lengths) instead of keeping the size.
    #[arg(long)]
    fit: bool,
    #[arg(long, default_value_t = 0.0)]
    nodata: f64,
    #[arg(long)]
    alpha: bool,
}

pub fn undistort_cmd(a: UndistortArgs) -> Result<()> {
    Files::new()
        .input("INPUT", Some(&a.input))
        .input("--camera", Some(&a.camera))
        .output("OUTPUT", Some(&a.output))
        .check()?;
    let cam = CameraFile::read(&a.camera)?;
    if cam.distortion.is_none() && cam.dewarp_text.is_none() {
        bail!(
            "{}: no [distortion] table: nothing to undistort",
            a.camera.display()
        );
    }
    let img = read_image(&a.input)?;
    let camera = cam.camera(Some(img.size()))?;
    if camera.distortion.is_none() {
        bail!(
            "{}: no lens terms: nothing to undistort",
            a.camera.display()
        );
    }
    let warp = crate::args::warp_options(a.interp, !a.no_prefilter, a.nodata, a.alpha, &img)?;
    let plan =
        UndistortPlan::new(&camera, a.fit).with_context(|| a.camera.display().to_string())?;
    let t = std::time::Instant::now();
    let out = plan.run(&img, &warp)?;
    let secs = t.elapsed().as_secs_f64();
    write_image(&a.output, &out)?;
    let (o, size) = (plan.output.intrinsics, plan.output.size);
    outln!(
        "{} -> {}: {} x {}, principal point ({:.2}, {:.2}), {} in {:.1} ms",
        a.input.display(),
        a.output.display(),
        size.width,
        size.height,
        o.cx,
        o.cy,
        a.interp.name(),
        secs * 1e3
    );
    Ok(())
}

#[derive(Args)]
pub struct CompareArgs {
    /// Measurement noise of the synthetic control points, pixels (one sigma per axis).
    #[arg(long, default_value_t = 0.1)]
    noise_px: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long)]
    json: bool,
}

pub fn compare_cmd(a: CompareArgs) -> Result<()> {
    if !(a.noise_px.is_finite() && a.noise_px > 0.0) {
        bail!("--noise-px {}: must be a finite number > 0", a.noise_px);
    }
    let rows = aerorect::lens_compare::compare(a.noise_px, a.seed)?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    outln!(
        "one image of a 3-D test field, 800 x 800, f = 1000 px; lens: k1 -0.15, k2 0.05, p1 3e-3, p2 -2e-3; noise {} px",
        a.noise_px
    );
    outln!(
        "{:<10} {:>6} {:>16} {:>14} {:>18} {:>10}",
        "model",
        "params",
        "mean error px",
        "distortion %",
        "check mean err px",
        "iters"
    );
    for r in &rows {
        outln!(
            "{:<10} {:>6} {:>16.4} {:>14.4} {:>18.4} {:>10}",
            r.model,
            r.parameters,
            r.mean_error_px,
            r.distortion_percent,
            r.check_mean_error_px,
            r.iterations
        );
    }
    Ok(())
}
