//! Drone photos from their own metadata: `rectify` without --attitude, and `batch`.

use crate::args::{GeoArgs, RectifyArgs};
use crate::outputs::Files;
use aerorect::core::RectifyLimits;
use aerorect::core::error::Num;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::demo::write_text;
use aerorect::drone::{DroneOptions, PhotoResult, rectify_photo, rectify_photo_staged};
use aerorect::geo::{Crs, Mounting};
use aerorect::georef::load_dem;
use aerorect::io::{CameraFile, CogOptions, PoseRecord, StagedOutputs, image_files};
use aerorect::raster::{AnyRaster, Interp, WarpOptions};
use aerorect::sane;
use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::Mutex;

/// Three comma-separated finite numbers of a flag.
fn triple(flag: &str, text: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--{flag} '{text}': expected three numbers"))?;
    match v[..] {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([a, b, c]),
        _ => bail!("--{flag} '{text}': expected three finite numbers"),
    }
}

/// The options every frame of a command shares.
pub(crate) fn ortho_options(
    geo: &GeoArgs,
    common: (Option<f64>, Option<f64>, Option<&Path>),
    limits: RectifyLimits,
    warp: WarpOptions,
    poses: Option<&Path>,
) -> Result<DroneOptions> {
    let (gsd_m, ground_height_m, camera) = common;
    check_ranges(geo, gsd_m, ground_height_m)?;
    let geo_format = geo
        .geo_file
        .as_deref()
        .map(|p| -> Result<_> {
            let text = aerorect::io::read_text(p)
                .with_context(|| format!("--geo {}: cannot read", p.display()))?;
            Ok(aerorect::io::eo::detect_format(&text))
        })
        .transpose()?;
    let geo_is_poses = geo_format == Some(aerorect::io::EoFormat::PoseCsv);
    if geo_is_poses && poses.is_some() {
        bail!("--geo is a pose table and --poses gives another: give one of them");
    }
    let poses = if geo_is_poses {
        geo.geo_file.as_deref()
    } else {
        poses
    };
    let mounting = Mounting::from_angles(
        geo.boresight_deg
            .as_deref()
            .map(|t| triple("boresight-deg", t))
            .transpose()?
            .unwrap_or([0.0; 3]),
        geo.lever_arm_m
            .as_deref()
            .map(|t| -> Result<_> {
                let arm = triple("lever-arm-m", t)?;
                sane::check_lever_arm_m(arm).with_context(|| format!("--lever-arm-m '{t}'"))
            })
            .transpose()?
            .unwrap_or([0.0; 3]),
    );
    let crs = output_crs(geo, poses)?;
    let poses = poses
        .map(|p| -> Result<_> {
            let rows = aerorect::io::read_poses(p)?;
            Ok(Arc::new(
                rows.into_iter().map(|r| (r.filename.clone(), r)).collect(),
            ))
        })
        .transpose()?;
    Ok(DroneOptions {
        gsd_m,
        ground_height_m,
        dem: geo.dem.as_deref().map(load_dem).transpose()?.map(Arc::new),
        vertical_offset_m: geo.vertical_offset_m,
        strict: geo.strict,
        occlusion: geo.occlusion,
        crs,
        camera: camera.map(CameraFile::read).transpose()?,
        poses,
        mounting,
        geo: match (&geo.geo_file, geo_is_poses) {
            (Some(p), false) => Some(Arc::new(aerorect::photo_source::load_geo_file(p)?)),
            _ => None,
        },
        track_headings: None,
        sensefly_roll: geo.sensefly_roll.into(),
        limits,
        warp,
        cog: None,
    })
}

/// The flags with a sane range (the library's), refused naming the flag and its value.
fn check_ranges(geo: &GeoArgs, gsd_m: Option<f64>, ground_height_m: Option<f64>) -> Result<()> {
    if let Some(g) = gsd_m {
        sane::check_gsd_m(g).with_context(|| format!("--gsd-m {}", Num(g)))?;
    }
    if let Some(z) = ground_height_m {
        sane::check_height_m("ground height", z)
            .with_context(|| format!("--ground-height-m {}", Num(z)))?;
    }
    let v = geo.vertical_offset_m;
    sane::check_height_m("vertical offset", v)
        .with_context(|| format!("--vertical-offset-m {}", Num(v)))?;
    Ok(())
}

/// The output CRS: `--crs`, else the pose table's `.prj` (an error names the one it came from).
fn output_crs(geo: &GeoArgs, poses: Option<&Path>) -> Result<Option<Crs>> {
    let (text, origin) = match (&geo.crs, poses) {
        (Some(c), _) => (c.clone(), "--crs".to_string()),
        (None, Some(p)) => {
            let prj = p.with_extension("prj");
            match aerorect::io::read_text(&prj) {
                Ok(t) => (
                    t.trim().to_string(),
                    format!("{} (the poses' CRS)", prj.display()),
                ),
                Err(_) => return Ok(None),
            }
        }
        (None, None) => return Ok(None),
    };
    let mut short: String = text.chars().take(80).collect();
    if short.len() < text.len() {
        short.push_str("...");
    }
    Ok(Some(Crs::projected_from_text(
        &text,
        &format!("{origin} '{short}'"),
    )?))
}

/// `--cog` writes a .tif: refuses another extension.
pub(crate) fn cog_needs_tif(flag: &str, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("tif") | Some("tiff")) {
        bail!(
            "--cog writes a cloud-optimised GeoTIFF: {flag} {} must end in .tif or .tiff",
            path.display()
        );
    }
    Ok(())
}

pub fn rectify_from_metadata(a: &RectifyArgs) -> Result<()> {
    if a.altitude_m.is_some() || a.base_altitude_m.is_some() {
        bail!("--altitude-m / --base-altitude-m go with --attitude; from metadata use --gsd-m");
    }
    // The nodata value is checked against the photo's sample type when it is read.
    let warp = WarpOptions {
        interp: a.interp,
        nodata: a.nodata,
        alpha: a.alpha,
        prefilter: !a.no_prefilter,
        coordinates: crate::args::coordinates(a.exact_coordinates),
    };
    let limits = RectifyLimits {
        max_output_px: a.max_output_px,
    };
    let mut opts = ortho_options(
        &a.geo,
        (a.gsd_m, a.ground_height_m, a.camera.as_deref()),
        limits,
        warp,
        None,
    )?;
    if let Some(text) = &a.pose {
        let v: Vec<f64> = text
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .with_context(|| format!("--pose '{text}': expected x,y,z,omega,phi,kappa"))?;
        let [x, y, z, omega, phi, kappa] = v[..] else {
            bail!("--pose '{text}': expected six numbers x,y,z,omega,phi,kappa");
        };
        if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
            bail!("--pose '{text}': {bad} is not a finite number");
        }
        let name = a
            .input
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or("")
            .to_string();
        let rec = PoseRecord {
            filename: name.clone(),
            x,
            y,
            z,
            omega,
            phi,
            kappa,
        };
        opts.poses = Some(Arc::new([(name, rec)].into_iter().collect()));
    }
    if a.cog {
        cog_needs_tif("OUTPUT", &a.output)?;
        opts.cog = Some(CogOptions::masked_by_alpha(a.alpha));
    }
    let mut staged = StagedOutputs::new();
    let r = rectify_photo_staged(&a.input, &a.output, &opts, None, &mut staged)?;
    if let Some(p) = &a.report {
        staged.text(p, &serde_json::to_string_pretty(&r)?)?;
    }
    staged.commit()?;
    outln!("{}", result_line(&r));
    for w in &r.info.warnings {
        eprintln!("warning: {}: {w}", a.input.display());
    }
    Ok(())
}

fn result_line(r: &PhotoResult) -> String {
    let i = &r.info;
    format!(
        "{} -> {}: {} x {} px at {:.3} m/px, {}, gimbal yaw {:.1} pitch {:.1}, height {:.1} m{}, {:.2} s",
        r.input,
        r.output,
        r.output_size[0],
        r.output_size[1],
        i.gsd_m,
        i.geo.crs,
        i.gimbal_yaw_pitch_roll_deg[0],
        i.gimbal_yaw_pitch_roll_deg[1],
        i.height_m,
        if i.clipped { ", far field clipped" } else { "" },
        r.seconds
    )
}

/// The frames of a flight and how to place them on the ground (batch and mosaic).
#[derive(Args, Clone, Debug)]
pub struct FlightArgs {
    /// Ground sample distance, metres; default: each frame's own at nadir (batch), the finest
    /// frame's (mosaic). Give it to put every frame on one ground grid.
    #[arg(long)]
    pub gsd_m: Option<f64>,
    /// Ground elevation against AbsoluteAltitude (default: height above the take-off point).
    #[arg(long)]
    pub ground_height_m: Option<f64>,
    /// Camera file for every frame (overrides the metadata's camera).
    #[arg(long)]
    pub camera: Option<PathBuf>,
    /// Exterior orientation of the frames: CSV `filename,x,y,z,omega,phi,kappa` (the world CRS
    /// from --crs or the CSV's .prj sidecar; angles in degrees, PATB omega-phi-kappa).
    #[arg(long)]
    pub poses: Option<PathBuf>,
    #[command(flatten)]
    pub geo: GeoArgs,
    /// Make the flight consistent first: tie points from the frames' overlaps, then a joint
    /// adjustment of attitudes and camera (batch also writes OUT_DIR/adjustment.json and
    /// rewrites every frame: each depends on the whole flight).
    #[arg(long)]
    pub adjust: bool,
    /// With --adjust: correct positions with this prior standard deviation (m) for every frame
    /// (default: each photo's RTK standard deviations where it has them, else 5 m; positions
    /// from --poses are held).
    #[arg(long, requires = "adjust", conflicts_with = "hold_positions")]
    pub adjust_positions_m: Option<f64>,
    /// With --adjust: keep every recorded position.
    #[arg(long, requires = "adjust")]
    pub hold_positions: bool,
    /// With --adjust: also solve each camera's radial distortion k1, k2 (added to its lens;
    /// cameras with a rational or non-OpenCV lens keep theirs).
    #[arg(long, requires = "adjust")]
    pub adjust_lens: bool,
    /// With --adjust: also solve a boresight rotation per camera.
    #[arg(long, requires = "adjust")]
    pub adjust_boresight: bool,
    /// With --adjust: the recorded attitudes' standard deviation (degrees, each axis).
    #[arg(long, requires = "adjust", default_value_t = 1.0)]
    pub attitude_sigma_deg: f64,
    /// With --adjust: the most matching rounds (each renders the frames again with the last
    /// round's orientation and matches afresh; they stop when the median frame's attitude moves less than 0.005 deg).
    /// At most 20 are run; rounds that do not settle are reported with their turns.
    #[arg(long, requires = "adjust", default_value_t = 8)]
    pub adjust_passes: usize,
    /// With --adjust: where tie points come from: `both` (SIFT features first, which need no
    /// attitude, then correlation of the rendered frames, whose ties replace a pair's features
    /// where it ties the pair), `features` (one round) or `correlation` (the recorded
    /// attitudes must be within a few degrees).
    #[arg(long, requires = "adjust", default_value = "both")]
    pub ties: String,
    /// With --adjust and no --gcps: take each GPS fix robustly (Huber at three sigmas) about
    /// the block's common shift, so that a fix the images contradict is down-weighted (see
    /// adjustment.json's gps[].weight).
    #[arg(long, requires = "adjust")]
    pub robust_gps: bool,
    /// With --adjust: ground control points: ODM's gcp_list.txt, a Pix4D or Metashape marker
    /// CSV, or ours (see CONVENTIONS.md); a Pix4D coordinates file and its image-marks file as
    /// two files, comma-separated. Their marks hold the solve, the datum of the GPS positions
    /// is solved, and OUT_DIR/accuracy.json reports every point.
    #[arg(long, requires = "adjust", value_delimiter = ',')]
    pub gcps: Vec<PathBuf>,
    /// With --gcps: points kept out of the solve and reported as check points (names,
    /// comma-separated; the file may also mark them).
    #[arg(long, requires = "gcps", value_delimiter = ',')]
    pub checkpoints: Vec<String>,
    /// With --gcps: an image mark's standard deviation (px).
    #[arg(long, requires = "gcps", default_value_t = aerorect::flight::MARK_SIGMA_PX)]
    pub gcp_sigma_px: f64,
    /// With --gcps: added to the points' heights to bring them to the ground's vertical datum
    /// (the DEM's or --ground-height-m's), as --vertical-offset-m does for the cameras.
    #[arg(
        long,
        requires = "gcps",
        default_value_t = 0.0,
        allow_hyphen_values = true
    )]
    pub gcp_vertical_offset_m: f64,
}

impl FlightArgs {
    /// `files` with every file these options read.
    pub(crate) fn inputs(&self, files: Files) -> Files {
        let prj = match (&self.geo.crs, &self.poses) {
            (None, Some(p)) => Some(p.with_extension("prj")),
            _ => None,
        };
        files
            .input("--camera", self.camera.as_deref())
            .input("--poses", self.poses.as_deref())
            .input("--poses (its .prj)", prj.as_deref())
            .input("--geo", self.geo.geo_file.as_deref())
            .input("--dem", self.geo.dem.as_deref())
            .inputs("--gcps", &self.gcps)
    }

    /// The ground control these options name (read and checked), if any.
    pub(crate) fn control(&self) -> Result<Option<aerorect::flight::ControlOptions>> {
        if self.gcps.is_empty() {
            return Ok(None);
        }
        let co = aerorect::flight::ControlOptions {
            checkpoints: self.checkpoints.clone(),
            mark_sigma_px: self.gcp_sigma_px,
            vertical_offset_m: self.gcp_vertical_offset_m,
            ..aerorect::flight::ControlOptions::read(&self.gcps)?
        };
        co.validate().context("--gcps")?;
        Ok(Some(co))
    }

    /// The options every frame of `inputs` shares, with the flight's checks: the photos an
    /// external-orientation file misses, and the GPS-track headings of photos without attitude.
    pub(crate) fn options(
        &self,
        inputs: &[PathBuf],
        limits: RectifyLimits,
        warp: WarpOptions,
    ) -> Result<DroneOptions> {
        let mut opts = ortho_options(
            &self.geo,
            (self.gsd_m, self.ground_height_m, self.camera.as_deref()),
            limits,
            warp,
            self.poses.as_deref(),
        )?;
        for w in aerorect::photo_source::prepare_flight(&mut opts, inputs)? {
            eprintln!("warning: {w}");
        }
        Ok(opts)
    }

    pub(crate) fn flight_options(&self) -> Result<aerorect::flight::FlightOptions> {
        use aerorect::flight::PositionPrior;
        for (flag, v, max) in [
            (
                "--adjust-positions-m",
                self.adjust_positions_m,
                sane::MAX_HEIGHT_M,
            ),
            (
                "--attitude-sigma-deg",
                Some(self.attitude_sigma_deg),
                aerorect::flight::MAX_ATTITUDE_SIGMA_DEG,
            ),
        ] {
            if let Some(v) = v.filter(|v| !(v.is_finite() && *v > 0.0 && *v <= max)) {
                bail!(
                    "{flag} {}: must be a finite number > 0 and at most {max}",
                    Num(v)
                );
            }
        }
        if self.adjust_passes == 0 {
            bail!("--adjust-passes 0: at least one matching round");
        }
        Ok(aerorect::flight::FlightOptions {
            positions: match (self.hold_positions, self.adjust_positions_m) {
                (true, _) => PositionPrior::Hold,
                (false, Some(s)) => PositionPrior::Sigma(s),
                (false, None) => PositionPrior::Recorded,
            },
            attitude_sigma_deg: self.attitude_sigma_deg,
            passes: self.adjust_passes,
            ties: aerorect::flight::TieSource::from_name(&self.ties)
                .with_context(|| format!("--ties {}", self.ties))?,
            refine_radial: self.adjust_lens,
            refine_boresight: self.adjust_boresight,
            control: self.control()?,
            robust_gps: self.robust_gps,
            ..Default::default()
        })
    }
}

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

/// What became of one input.
enum Outcome {
    Done(Box<PhotoResult>),
    Skipped(String),
    Failed(String),
}

fn output_for(a: &BatchArgs, input: &Path) -> Result<PathBuf> {
    let stem = input
        .file_stem()
        .with_context(|| format!("{}: no file name", input.display()))?;
    Ok(a.out_dir.join(stem).with_extension(&a.format))
}

pub fn batch(a: BatchArgs) -> Result<()> {
    if a.format != "tif" && a.format != "png" {
        bail!("--format '{}': expected tif or png", a.format);
    }
    if a.jobs == 0 {
        bail!("--jobs 0: at least one frame must be in flight");
    }
    if a.cog && a.format != "tif" {
        bail!(
            "--cog writes cloud-optimised GeoTIFFs: it needs --format tif, not '{}'",
            a.format
        );
    }
    batch_files(&a)?.check()?;
    if a.flight.adjust {
        a.flight.flight_options()?;
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
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("{}: cannot create", a.out_dir.display()))?;
    if a.flight.adjust {
        return batch_adjusted(&a, &opts);
    }
    let started = std::time::Instant::now();
    let pb =
        ProgressBar::with_draw_target(Some(a.inputs.len() as u64), ProgressDrawTarget::stderr());
    pb.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} frames, {elapsed} elapsed, eta {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let say = |line: String| {
        if pb.is_hidden() {
            outln!("{line}");
        } else {
            pb.println(line);
        }
    };
    let queue = Mutex::new(a.inputs.iter().enumerate());
    let outcomes: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    // `jobs` workers take frames from one queue: at most `jobs` frames are in memory at once.
    std::thread::scope(|s| {
        for _ in 0..a.jobs.min(a.inputs.len()) {
            s.spawn(|| {
                loop {
                    let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
                    let Some((k, input)) = next else { break };
                    let outcome = process(&a, input, &opts);
                    let line = match &outcome {
                        Outcome::Done(r) => with_warnings(result_line(r), r),
                        Outcome::Skipped(why) => format!("{}: skipped: {why}", input.display()),
                        Outcome::Failed(why) => format!("{}: FAILED: {why}", input.display()),
                    };
                    say(line);
                    pb.inc(1);
                    if let Ok(mut o) = outcomes.lock() {
                        o.push((k, outcome));
                    }
                }
            });
        }
    });
    pb.finish_and_clear();
    let mut outcomes = outcomes.into_inner().unwrap_or_default();
    outcomes.sort_by_key(|(k, _)| *k);
    summarise(&a, &outcomes, started.elapsed().as_secs_f64())
}

/// Refuses two photos that would go to one output (a/X.JPG and b/X.JPG both to OUT/X.tif).
fn refuse_collisions(a: &BatchArgs) -> Result<()> {
    let mut first: HashMap<PathBuf, &Path> = HashMap::new();
    for input in &a.inputs {
        let out = output_for(a, input)?;
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
fn batch_files(a: &BatchArgs) -> Result<Files> {
    aerorect::io::refuse_duplicate_photos(&a.inputs)?;
    refuse_collisions(a)?;
    let mut files = a
        .flight
        .inputs(Files::new())
        .folder("--out-dir", Some(&a.out_dir));
    for input in &a.inputs {
        files = files.input("PHOTOS", Some(input));
    }
    for input in &a.inputs {
        for out in image_files(&output_for(a, input)?, true) {
            files = files.output("--out-dir", Some(&out));
        }
    }
    let adjustment = a.flight.adjust.then(|| adjustment_json(a));
    let poses = a.flight.adjust.then(|| adjusted_poses_csv(a));
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

/// Where `batch --adjust` writes the adjustment's report.
fn adjustment_json(a: &BatchArgs) -> PathBuf {
    a.out_dir.join("adjustment.json")
}

/// Where `batch --adjust` writes the adjusted exterior orientation (`--poses`' format, with
/// its CRS in a `.prj` beside it).
fn adjusted_poses_csv(a: &BatchArgs) -> PathBuf {
    a.out_dir.join("adjusted_poses.csv")
}

fn process(a: &BatchArgs, input: &Path, opts: &DroneOptions) -> Outcome {
    let output = match output_for(a, input) {
        Ok(o) => o,
        Err(e) => return failure(input, e),
    };
    // An existing output counts as done only when it is a whole image; else it is redone.
    let mut broken = None;
    if output.exists() && !a.force {
        match aerorect::io::check_image_whole(&output) {
            Ok(()) => {
                return Outcome::Skipped(format!(
                    "{} exists (use --force to rewrite)",
                    output.display()
                ));
            }
            Err(e) => broken = Some(e),
        }
    }
    let thumbs = a.report_html.as_ref().map(|_| 320);
    match rectify_photo(input, &output, opts, thumbs) {
        Ok(mut r) => {
            if let Some(e) = broken {
                let redone =
                    format!("the existing output was not a whole image ({e}): rectified again");
                r.info.warnings.insert(0, redone);
            }
            Outcome::Done(Box::new(r))
        }
        Err(e) => failure(input, e.full_message()),
    }
}

/// A failed frame; the input's name is said once (the line starts with it), not again from
/// the error's own context.
fn failure(input: &Path, e: impl std::fmt::Display) -> Outcome {
    let text = e.to_string();
    let name = format!("{}: ", input.display());
    Outcome::Failed(text.strip_prefix(&name).unwrap_or(&text).to_string())
}

/// A frame's result line followed by its warnings, one indented line each.
fn with_warnings(line: String, r: &PhotoResult) -> String {
    r.info
        .warnings
        .iter()
        .fold(line, |acc, w| format!("{acc}\n  warning: {w}"))
}

fn summarise(a: &BatchArgs, outcomes: &[(usize, Outcome)], seconds: f64) -> Result<()> {
    let done: Vec<&PhotoResult> = outcomes
        .iter()
        .filter_map(|(_, o)| match o {
            Outcome::Done(r) => Some(r.as_ref()),
            _ => None,
        })
        .collect();
    let listed = |want_failed: bool| -> Vec<(String, String)> {
        outcomes
            .iter()
            .filter_map(|(k, o)| match (o, want_failed) {
                (Outcome::Failed(w), true) | (Outcome::Skipped(w), false) => {
                    Some((a.inputs[*k].display().to_string(), w.clone()))
                }
                _ => None,
            })
            .collect()
    };
    let (failed, skipped) = (listed(true), listed(false));
    if let Some(p) = &a.report_html {
        write_report(p, (&done, &skipped, &failed), seconds)?;
    }
    outln!(
        "{} frames: {} rectified, {} skipped, {} failed, {:.2} s",
        outcomes.len(),
        done.len(),
        skipped.len(),
        failed.len(),
        seconds
    );
    if !failed.is_empty() {
        for (f, why) in &failed {
            eprintln!("failed: {f}: {why}");
        }
        bail!(
            "{} of {} frames failed (listed above)",
            failed.len(),
            outcomes.len()
        );
    }
    Ok(())
}

/// A frame listed in the summary: its input and why.
type Listed = (String, String);

/// Writes the HTML report, except over an earlier one when no frame was rectified in this run
/// (a re-run that skips every frame would replace the flight's report with an empty one).
fn write_report(
    path: &Path,
    (done, skipped, failed): (&[&PhotoResult], &[Listed], &[Listed]),
    seconds: f64,
) -> Result<()> {
    if done.is_empty() && path.exists() {
        outln!(
            "report: {} kept as it was (no frame was rectified in this run)",
            path.display()
        );
        return Ok(());
    }
    let html = aerorect::report_html::render(done, skipped, failed, seconds, None);
    write_text(path, &html)?;
    outln!("report: {}", path.display());
    Ok(())
}

#[derive(Args)]
pub struct OverlapArgs {
    /// A georeferenced frame (GeoTIFF written by rectify or batch).
    a: PathBuf,
    /// Another on the same grid (same CRS and GSD, origins a whole number of pixels apart).
    b: PathBuf,
    /// Side of the matched tiles, pixels.
    #[arg(long, default_value_t = 256)]
    patch: usize,
    #[arg(long)]
    json: bool,
}

pub fn overlap(a: OverlapArgs) -> Result<()> {
    if a.patch < 16 {
        bail!("--patch {} is below 16", a.patch);
    }
    let r = aerorect::drone::overlap_shift(&a.a, &a.b, a.patch)?;
    if a.json {
        outln!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        outln!(
            "{} vs {}: {} tiles of {} px over a {} x {} px overlap: B is offset by ({:.2}, {:.2}) px = ({:.3} m east, {:.3} m north) (median), RMS {:.2} px",
            a.a.display(),
            a.b.display(),
            r.patches,
            a.patch,
            r.overlap_px[0],
            r.overlap_px[1],
            r.median_px[0],
            r.median_px[1],
            r.median_m[0],
            r.median_m[1],
            r.rms_px
        );
    }
    Ok(())
}

/// `batch --adjust`: plan, match and adjust the whole flight, then write every frame with its
/// adjusted orientation and `adjustment.json`; a failed adjustment writes nothing.
pub(crate) fn print_adjustment(r: &aerorect::flight::FlightReport) {
    for p in &r.pairs {
        outln!(
            "pair {} / {}: {} tie points of {} patches{}, misalignment {:.3} m -> {}",
            p.a,
            p.b,
            p.inliers,
            p.patches,
            if p.reliable {
                ""
            } else {
                " (nothing reliable shared: not used)"
            },
            p.misalignment_before_m,
            p.misalignment_after_m
                .map_or("-".to_string(), |m| format!("{m:.3} m"))
        );
    }
    for u in &r.unconnected {
        eprintln!("warning: {u}: overlaps no other frame reliably; left as recorded");
    }
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    let adj = &r.adjustment;
    outln!(
        "adjustment: {} frames, {} tie points, rms {:.2} -> {:.2} px in {} iterations ({}), {:.2} s",
        r.frames.len(),
        adj.tie_points,
        adj.rms_before_px,
        adj.rms_after_px,
        adj.iterations,
        serde_json::to_value(adj.termination)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default(),
        adj.seconds
    );
    if let Some(d) = &adj.datum {
        outln!(
            "datum of the recorded positions ({:?}): shift {:.3}, {:.3}, {:.3} m, rotation {:.4}, {:.4}, {:.4} deg, scale {:.0} ppm",
            d.model,
            d.shift_m[0],
            d.shift_m[1],
            d.shift_m[2],
            d.rotation_deg[0],
            d.rotation_deg[1],
            d.rotation_deg[2],
            d.scale_ppm
        );
    }
    if let Some(a) = &r.accuracy {
        print_accuracy(a);
    }
}

fn print_accuracy(a: &aerorect::flight::AccuracyReport) {
    for p in &a.points {
        let m = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:+.3}"));
        outln!(
            "{:?} {}: dX {} dY {} dZ {} m; {} marks",
            p.role,
            p.name,
            m(p.residual_m.map(|r| r[0])),
            m(p.residual_m.map(|r| r[1])),
            m(p.residual_z_m),
            p.images.len()
        );
    }
    for (what, b, r) in [
        ("control", &a.control_before, &a.control),
        ("check", &a.check_before, &a.check),
    ] {
        if r.count > 0 {
            outln!(
                "RMSE over {} {what} points XY / Z: {:.3} / {:.3} m recorded, {:.3} / {:.3} m adjusted (GSD {:.3} m)",
                r.count,
                b.xy_m,
                b.z_m,
                r.xy_m,
                r.z_m,
                a.mean_gsd_m
            );
        }
    }
    if let Some(c) = &a.asprs_horizontal {
        outln!(
            "ASPRS 2014 horizontal accuracy class: {} ({:.3} m at 95 %, {} check points)",
            c.class_cm
                .map_or("beyond 10 m".into(), |c| format!("{c} cm")),
            c.accuracy_95_m,
            c.check_points
        );
    }
    if !a.unreached.is_empty() {
        eprintln!(
            "warning: {} frames in blocks no ground control point reaches: {}",
            a.unreached.len(),
            a.unreached.join(", ")
        );
    }
}

fn batch_adjusted(a: &BatchArgs, opts: &DroneOptions) -> Result<()> {
    let fo = a.flight.flight_options()?;
    let flight = aerorect::flight::adjust_flight(&a.inputs, opts, &fo)?;
    let r = &flight.report;
    print_adjustment(r);
    // Every frame depends on the whole adjustment: the frames and adjustment.json land
    // together, or (when a frame fails) none of them does.
    let outputs: Vec<PathBuf> = a
        .inputs
        .iter()
        .map(|input| output_for(a, input))
        .collect::<Result<_>>()?;
    let mut staged = StagedOutputs::new();
    let done = flight.stage_batch(
        &outputs,
        &a.out_dir,
        opts,
        &mut staged,
        |k, res| match res {
            Ok(p) => outln!("{}", result_line(p)),
            Err(e) => eprintln!("failed: {}: {}", a.inputs[k].display(), e.full_message()),
        },
    )?;
    let poses = adjusted_poses_csv(a);
    if let Some(p) = &a.report_html {
        let overview = flight.overview()?;
        let section = aerorect::report_html::FlightSection {
            report: r,
            ties: &flight.ties,
            overview_png: Some(
                aerorect::io::thumbnail_png(&AnyRaster::U8(overview), 800)
                    .map_err(anyhow::Error::msg)?,
            ),
        };
        let done: Vec<&PhotoResult> = done.iter().collect();
        let seconds = r.seconds + done.iter().map(|d| d.seconds).sum::<f64>();
        let html = aerorect::report_html::render(&done, &[], &[], seconds, Some(&section));
        staged.text(p, &html)?;
    }
    staged.commit()?;
    outln!(
        "adjustment report: {}; adjusted poses: {}",
        adjustment_json(a).display(),
        poses.display()
    );
    Ok(())
}
