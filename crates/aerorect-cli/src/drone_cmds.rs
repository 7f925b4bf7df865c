//! Drone photos from their own metadata: `rectify` without --attitude, the flight's options
//! (batch, mosaic), and `overlap`. The options go to the facade as requests
//! (`aerorect::options`), which checks them; this file only turns flags into them.

use crate::args::{GeoArgs, RectifyArgs};
use crate::outputs::Files;
use aerorect::core::RectifyLimits;
use aerorect::drone::{DroneOptions, PhotoResult, rectify_photo_staged};
use aerorect::io::StagedOutputs;
use aerorect::options::{FlightRequest, PhotoRequest};
use aerorect::raster::WarpOptions;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::{Path, PathBuf};

/// Numbers separated by commas, `n` of them (`what` says which), as a flag gives them.
fn numbers<const N: usize>(flag: &str, text: &str, what: &str) -> Result<[f64; N]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--{flag} '{text}': expected {what}"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("--{flag} '{text}': expected {what}"))
}

impl GeoArgs {
    /// The request these flags and the command's own make (nothing read or checked yet but
    /// the flags' syntax).
    pub(crate) fn request(
        &self,
        common: (Option<f64>, Option<f64>, Option<&Path>, Option<&Path>),
        limits: RectifyLimits,
        warp: WarpOptions,
    ) -> Result<PhotoRequest> {
        let (gsd_m, ground_height_m, camera, poses) = common;
        let three = |flag: &str, t: &Option<String>| {
            t.as_deref()
                .map(|t| numbers::<3>(flag, t, "three numbers"))
                .transpose()
        };
        Ok(PhotoRequest {
            gsd_m,
            ground_height_m,
            vertical_offset_m: self.vertical_offset_m,
            strict: self.strict,
            occlusion: self.occlusion,
            crs: self.crs.clone(),
            camera: camera.map(Path::to_path_buf),
            poses: poses.map(Path::to_path_buf),
            pose: None,
            geo: self.geo_file.clone(),
            dem: self.dem.clone(),
            boresight_deg: three("boresight-deg", &self.boresight_deg)?,
            lever_arm_m: three("lever-arm-m", &self.lever_arm_m)?,
            sensefly_roll: self.sensefly_roll.into(),
            limits,
            warp,
            cog: false,
        })
    }
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
    let common = (a.gsd_m, a.ground_height_m, a.camera.as_deref(), None);
    let mut req = a.geo.request(common, limits, warp)?;
    if let Some(text) = &a.pose {
        let what = "six numbers x,y,z,omega,phi,kappa";
        req.pose = Some(numbers::<6>("pose", text, what)?);
    }
    if a.cog {
        cog_needs_tif("OUTPUT", &a.output)?;
        req.cog = true;
    }
    let opts = req.resolve(Some(&a.input))?;
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

pub(crate) fn result_line(r: &PhotoResult) -> String {
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
    /// where it ties the pair; with --dem the last solve takes both, each weighed by how well
    /// its ties agree, and no correlation round is run where a correlated sample of the
    /// pairs agrees worse than the features), `features` (one round) or `correlation` (the recorded
    /// attitudes must be within a few degrees).
    #[arg(long, requires = "adjust", default_value = "both")]
    pub ties: String,
    /// With --adjust and no --gcps: take each GPS fix robustly (Huber at three sigmas) about
    /// the block's common shift from the first solve, so that a fix the images contradict is
    /// down-weighted (see adjustment.json's gps[].weight); without it, a solve that leaves a
    /// fix contradicted is solved again so.
    #[arg(long, requires = "adjust")]
    pub robust_gps: bool,
    /// With --adjust and no --dem: render the adjusted frames over the level ground
    /// (--ground-height-m) instead of the surface the flight's own tie points describe
    /// (intersected through the adjusted frames, gridded at 2 m; adjustment.json's `surface`
    /// reports its points, extent and spread).
    #[arg(long, requires = "adjust")]
    pub level_ground: bool,
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

    /// The options every frame of `inputs` shares, with the flight's checks: the photos an
    /// external-orientation file misses, and the GPS-track headings of photos without attitude.
    pub(crate) fn options(
        &self,
        inputs: &[PathBuf],
        limits: RectifyLimits,
        warp: WarpOptions,
    ) -> Result<DroneOptions> {
        let common = (
            self.gsd_m,
            self.ground_height_m,
            self.camera.as_deref(),
            self.poses.as_deref(),
        );
        let req = self.geo.request(common, limits, warp)?;
        let (opts, warnings) = req.resolve_flight(inputs)?;
        for w in warnings {
            eprintln!("warning: {w}");
        }
        Ok(opts)
    }

    /// The adjustment's request from these flags.
    fn flight_request(&self) -> FlightRequest {
        FlightRequest {
            adjust_positions_m: self.adjust_positions_m,
            hold_positions: self.hold_positions,
            adjust_lens: self.adjust_lens,
            adjust_boresight: self.adjust_boresight,
            attitude_sigma_deg: Some(self.attitude_sigma_deg),
            adjust_passes: Some(self.adjust_passes),
            ties: Some(self.ties.clone()),
            robust_gps: self.robust_gps,
            level_ground: self.level_ground,
            gcps: self.gcps.clone(),
            checkpoints: self.checkpoints.clone(),
            gcp_sigma_px: Some(self.gcp_sigma_px),
            gcp_vertical_offset_m: Some(self.gcp_vertical_offset_m),
        }
    }

    /// The adjustment's values checked, reading no file.
    pub(crate) fn validate_flight(&self) -> Result<()> {
        Ok(self.flight_request().validate()?)
    }

    /// The adjustment's options (the ground control files read).
    pub(crate) fn flight_options(&self) -> Result<aerorect::flight::FlightOptions> {
        Ok(self.flight_request().resolve()?)
    }
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
