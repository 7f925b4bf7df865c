//! A flight made consistent from its own overlaps: each frame is first rectified from its
//! metadata onto one coarse ground grid; overlapping frames are matched there by phase
//! correlation of patches (the ortho removes most of the perspective between look
//! directions); RANSAC keeps the matches one homography explains; every match becomes a tie
//! point (its frame pixels through each frame's own ortho map), and the joint adjustment
//! (`aerorect_solve::adjust`) corrects attitudes (and optionally positions) and the cameras.

use crate::Error;
use crate::drone::{DroneOptions, DronePlanInfo, georeference, plan_from_metadata};
use crate::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use aerorect_core::{Camera, ImageSize};
use aerorect_geo::{OrthoGrid, Pose, Projection};
use aerorect_io::{Crs, PhotoMetadata};
use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
use aerorect_raster::{AnyRaster, Interp, Raster, WarpOptions};
use aerorect_solve::adjust::{AdjustFrame, AdjustOptions, AdjustReport, Observation, TiePoint};
use aerorect_solve::ransac::{RansacOptions, ransac_homography};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How frames are matched and what the adjustment solves for.
#[derive(Debug, Clone)]
pub struct FlightOptions {
    /// Ground sample distance of the matching grid; default 4x the finest frame's own.
    pub match_gsd_m: Option<f64>,
    /// Side of the correlated patches (pixels of the matching grid).
    pub patch: usize,
    pub positions: PositionPrior,
    pub attitude_sigma_deg: f64,
    pub refine_focal: bool,
    pub refine_principal_point: bool,
    /// Radial distortion k1, k2 per camera (a camera with no lens model or OpenCV's).
    pub refine_radial: bool,
    /// A boresight rotation per camera.
    pub refine_boresight: bool,
    /// Most matching rounds: after each adjustment every frame is rendered again with its
    /// adjusted orientation and matched afresh (as the frames come to coincide, patches that
    /// an attitude error had pushed apart match too, and the correlation's bias from the
    /// frames' remaining relative rotation and scale fades), and the adjustment is solved
    /// again; rounds stop when the median frame's attitude moves by less than `settled_deg`
    /// (one weakly held frame at the edge of a block can wander by a hundredth of a degree
    /// from round to round without the others moving). At most [`MAX_PASSES`].
    pub passes: usize,
    pub settled_deg: f64,
}

/// The largest standard deviation of a recorded attitude, degrees (half a turn).
pub const MAX_ATTITUDE_SIGMA_DEG: f64 = 180.0;

impl FlightOptions {
    /// Refuses an attitude standard deviation outside 0 < s <= [`MAX_ATTITUDE_SIGMA_DEG`] and
    /// a position one that is not a finite number in 0 < s <= 1e5 m.
    pub fn validate(&self) -> Result<(), Error> {
        let s = self.attitude_sigma_deg;
        if !(s.is_finite() && s > 0.0 && s <= MAX_ATTITUDE_SIGMA_DEG) {
            return Err(Error::Invalid(format!(
                "attitude standard deviation {} deg: must be > 0 and at most {MAX_ATTITUDE_SIGMA_DEG} deg",
                aerorect_core::error::Num(s)
            )));
        }
        if let PositionPrior::Sigma(p) = self.positions
            && !(p.is_finite() && p > 0.0 && p <= crate::sane::MAX_HEIGHT_M)
        {
            return Err(Error::Invalid(format!(
                "position standard deviation {} m: must be > 0 and at most {} m",
                aerorect_core::error::Num(p),
                crate::sane::MAX_HEIGHT_M
            )));
        }
        Ok(())
    }
}

impl Default for FlightOptions {
    fn default() -> Self {
        Self {
            match_gsd_m: None,
            patch: 64,
            positions: PositionPrior::Recorded,
            attitude_sigma_deg: 1.0,
            refine_focal: true,
            refine_principal_point: false,
            refine_radial: false,
            refine_boresight: false,
            passes: 8,
            settled_deg: 0.005,
        }
    }
}

/// The most pixels of one frame's gray ortho on the matching grid (16 MB as f32): the grid's
/// GSD is coarsened until every frame fits (a warning says so).
pub const MATCH_BUDGET_PX: u64 = 4_000_000;

/// The matching rounds' cap: [`FlightOptions::passes`] above it runs this many (a warning
/// says so).
pub const MAX_PASSES: usize = 20;

/// A solve stopped by its iteration limit (no tolerance met) is kept, with a warning, when
/// its residual RMS is at most this (px: four times the tie points' 0.5 px sigma); above it
/// the flight is an error naming the frames.
pub const UNCONVERGED_RMS_PX: f64 = 2.0;

/// Standard deviation (m) of a consumer GPS position, the prior of frames with no RTK tags.
pub const GPS_SIGMA_M: f64 = 5.0;

/// How the adjustment treats the recorded positions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PositionPrior {
    /// As recorded (surveyed exterior orientation).
    Hold,
    /// Corrected, with this standard deviation (m) for every frame.
    Sigma(f64),
    /// Corrected, each frame with its receiver's RTK standard deviations where the photo
    /// carries them (DJI's `RtkStd*`), else [`GPS_SIGMA_M`]; held when the frames come with a
    /// pose table. Positions matter: from GPS a few metres apart, two frames' rays meet at
    /// heights the ground contradicts, and with positions held that error has only the
    /// attitudes to go to.
    Recorded,
}

/// One frame of the flight, planned from its metadata.
struct Frame {
    input: PathBuf,
    info: DronePlanInfo,
    /// Its ortho plan on the matching grid with the recorded orientation.
    coarse_plan: OrthoPlan,
    /// The photo's RTK standard deviations (m; east, north, up), if it has them.
    rtk_std_m: Option<[f64; 3]>,
}

/// A frame's gray ortho on the matching grid (NaN: no data) and that ortho's plan.
struct Rendered {
    coarse: Raster<f32>,
    coarse_plan: OrthoPlan,
}

/// What matching a pair of frames found.
#[derive(Debug, Clone, Serialize)]
pub struct PairReport {
    pub a: String,
    pub b: String,
    pub patches: usize,
    pub inliers: usize,
    /// Median ground distance between where the two frames put the same tie point (m), with
    /// the recorded and with the adjusted orientation.
    pub misalignment_before_m: f64,
    pub misalignment_after_m: Option<f64>,
    /// False when the pair shares nothing reliable (then it gives no tie points).
    pub reliable: bool,
}

/// A frame's adjusted exterior orientation: the projection centre in the flight's CRS and
/// omega, phi, kappa (degrees) about that CRS's grid axes, as `--poses` reads them.
#[derive(Debug, Clone, Serialize)]
pub struct AdjustedPose {
    /// `filename` is the photo's file name.
    #[serde(flatten)]
    pub pose: aerorect_io::PoseRecord,
    /// The adjusted camera's focal length (px, fx).
    pub focal_px: f64,
}

impl FlightReport {
    /// The adjusted poses as `--poses` (and Orthority) read them:
    /// `filename,x,y,z,omega,phi,kappa`.
    pub fn poses_csv(&self) -> String {
        let mut out = String::from("filename,x,y,z,omega,phi,kappa\n");
        for a in &self.poses {
            let p = &a.pose;
            out += &format!(
                "{},{:.4},{:.4},{:.4},{:.8},{:.8},{:.8}\n",
                p.filename, p.x, p.y, p.z, p.omega, p.phi, p.kappa
            );
        }
        out
    }
}

/// What one matching round found.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RoundSummary {
    pub tie_points: usize,
    pub reliable_pairs: usize,
    pub rms_after_px: f64,
    /// The largest and the median attitude change from the previous round's (degrees; the
    /// first round's from the recorded attitudes).
    pub largest_turn_deg: f64,
    pub median_turn_deg: f64,
    pub seconds: f64,
}

/// The flight's matching and adjustment.
#[derive(Debug, Clone, Serialize)]
pub struct FlightReport {
    pub frames: Vec<String>,
    /// Matching rounds run (see [`FlightOptions::passes`]); the pairs are the last round's.
    pub passes: usize,
    /// Each round: its tie points, residual RMS and the largest attitude change from the
    /// round before.
    pub rounds: Vec<RoundSummary>,
    pub match_gsd_m: f64,
    /// Whether the last round's median turn met [`FlightOptions::settled_deg`]; when not,
    /// `oscillating` says whether the turns stopped shrinking (the last round's median turn
    /// is above half the smallest before it) and a warning lists the turns per round.
    pub settled: bool,
    pub oscillating: bool,
    /// What the user should know: the matching grid coarsened, passes capped, gauge
    /// freedoms held, a solve kept at its iteration limit, rounds that did not settle.
    pub warnings: Vec<String>,
    pub pairs: Vec<PairReport>,
    /// Frames no reliable pair reaches (left as recorded).
    pub unconnected: Vec<String>,
    pub adjustment: AdjustReport,
    pub poses: Vec<AdjustedPose>,
    pub seconds: f64,
}

/// The flight's shared CRS: `--crs`, else the UTM zone of the first frame with a position.
fn flight_crs(
    frames: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
) -> Result<(Crs, Projection), Error> {
    if let Some(c) = &opts.crs {
        return Ok(c.clone());
    }
    let (lon, lat) = frames
        .iter()
        .find_map(|(_, m)| Some((m.longitude_deg?, m.latitude_deg?)))
        .ok_or_else(|| Error::Invalid("no frame of the flight has a GPS position".into()))?;
    let (p, epsg) = Projection::utm_for(lon, lat).map_err(|e| Error::Invalid(e.to_string()))?;
    Ok((Crs::Epsg(epsg), p))
}

/// Plans a frame on the matching grid with its recorded orientation.
fn plan_frame(
    input: &Path,
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    (gsd, max_output_px): (f64, u64),
) -> Result<Frame, Error> {
    let file = input.display().to_string();
    let rtk_std_m = meta.dji.rtk_std_m;
    let size = aerorect_io::read_image(input)?.size();
    let coarse_opts = DroneOptions {
        gsd_m: Some(gsd),
        warp: WarpOptions {
            interp: Interp::Bilinear,
            nodata: f64::NAN,
            alpha: false,
            prefilter: true,
            ..WarpOptions::default()
        },
        limits: aerorect_core::RectifyLimits { max_output_px },
        occlusion: false,
        ..opts.clone()
    };
    let posed = opts
        .poses
        .as_deref()
        .map(|p| crate::drone::pose_for(p, input));
    let (coarse_plan, info) = match posed {
        Some(Some(pose)) => crate::drone::plan_from_pose(pose, meta, size, &coarse_opts, &file)?,
        Some(None) => return Err(Error::Invalid(format!("{file}: not in the pose table"))),
        None => plan_from_metadata(meta, size, &coarse_opts, &file)?,
    };
    Ok(Frame {
        input: input.to_path_buf(),
        info,
        coarse_plan,
        rtk_std_m,
    })
}

/// The overlap of two frames' grids in A's pixels: [c0, r0, c1, r1) and B's offset.
fn overlap(ga: &OrthoGrid, gb: &OrthoGrid) -> Option<([i64; 4], [i64; 2])> {
    let g = ga.gsd;
    let off = [
        ((gb.top_left[0] - ga.top_left[0]) / g).round() as i64,
        ((ga.top_left[1] - gb.top_left[1]) / g).round() as i64,
    ];
    let [c0, r0, c1, r1] = aerorect_geo::common_window(ga.size, gb.size, off);
    (c1 > c0 && r1 > r0).then_some(([c0, r0, c1, r1], off))
}

/// A patch of a raster at (c, r) of `side` px, or `None` if it has nodata or no texture.
fn patch(img: &Raster<f32>, c: usize, r: usize, side: usize) -> Option<Vec<f32>> {
    let w = img.size().width;
    let mut out = Vec::with_capacity(side * side);
    for y in r..r + side {
        out.extend_from_slice(&img.plane(0)[y * w + c..y * w + c + side]);
    }
    if out.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let n = out.len() as f32;
    let mean = out.iter().sum::<f32>() / n;
    let var = out.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / n;
    (var > 4.0).then_some(out)
}

/// Matched patch centres: position in A's grid and in B's grid, with confidence.
type Match = ([f64; 2], [f64; 2], f64);

/// Patches of `side` px over the pair's overlap, each of B's taken `prior` px away from A's,
/// phase-correlated: the matches and the number of patches compared.
fn match_patches(
    a: &Rendered,
    b: &Rendered,
    side: usize,
    prior: [i64; 2],
) -> Result<(Vec<Match>, usize), Error> {
    let Some(([c0, r0, c1, r1], off)) = overlap(&a.coarse_plan.grid, &b.coarse_plan.grid) else {
        return Ok((vec![], 0));
    };
    let mut pc = PhaseCorrelator::new(
        side,
        side,
        PhaseOptions {
            weighting: Weighting::Phase,
            window: true,
            smooth: 0.0,
        },
    )
    .map_err(|e| Error::Invalid(e.to_string()))?;
    let (mut out, mut tried) = (Vec::new(), 0);
    let step = (side / 2) as i64;
    let (bw, bh) = (b.coarse.size().width as i64, b.coarse.size().height as i64);
    let mut r = r0;
    while r + side as i64 <= r1 {
        let mut c = c0;
        while c + side as i64 <= c1 {
            let (cb, rb) = (c - off[0] + prior[0], r - off[1] + prior[1]);
            let inside_b = cb >= 0 && rb >= 0 && cb + side as i64 <= bw && rb + side as i64 <= bh;
            let pa = patch(&a.coarse, c as usize, r as usize, side);
            let pb = if inside_b {
                patch(&b.coarse, cb as usize, rb as usize, side)
            } else {
                None
            };
            if let (Some(pa), Some(pb)) = (pa, pb) {
                tried += 1;
                if let Ok(e) = pc.estimate(&pa, &pb)
                    && e.confidence > 0.08
                    && e.dx.abs().max(e.dy.abs()) < side as f64 / 4.0
                {
                    let h = side as f64 / 2.0 - 0.5;
                    let at_a = [c as f64 + h, r as f64 + h];
                    let at_b = [cb as f64 + h + e.dx, rb as f64 + h + e.dy];
                    out.push((at_a, at_b, e.confidence));
                }
            }
            c += step;
        }
        r += step;
    }
    Ok((out, tried))
}

/// Coarse to fine: large patches find the pair's overall offset (attitude errors move frames
/// by metres), then `side` patches are matched around it.
fn match_pair(a: &Rendered, b: &Rendered, side: usize) -> Result<(Vec<Match>, usize), Error> {
    let (ga, gb) = (&a.coarse_plan.grid, &b.coarse_plan.grid);
    // The largest power-of-two patch (up to 256 px) that fits the overlap.
    let fits = overlap(ga, gb).map_or(0, |([c0, r0, c1, r1], _)| {
        (c1 - c0).min(r1 - r0).max(0) as usize
    });
    let big = [256, 128, 64]
        .into_iter()
        .find(|&s| s <= fits)
        .unwrap_or(side);
    let (coarse, _) = match_patches(a, b, big, [0, 0])?;
    let mut prior = [0i64; 2];
    if !coarse.is_empty() {
        let off = overlap(ga, gb).map_or([0, 0], |o| o.1);
        for k in 0..2 {
            let mut d: Vec<f64> = coarse
                .iter()
                .map(|m| m.1[k] - (m.0[k] - off[k] as f64))
                .collect();
            d.sort_by(f64::total_cmp);
            prior[k] = d[d.len() / 2].round() as i64;
        }
    }
    match_patches(a, b, side, prior)
}

/// Where a frame pixel's ray meets the level `z` (world x, y).
fn on_level(pose: &Pose, camera: &Camera, px: [f64; 2], z: f64) -> Option<[f64; 2]> {
    pose.level_point(
        pose.world_direction(camera.ray_from_pixel(px[0], px[1])?),
        z,
    )
}

/// What matching one pair of frames (indices `a`, `b`) found, as the adjustment takes it; it
/// travels between processes as [`exact_json`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairMatch {
    pub a: usize,
    pub b: usize,
    pub patches: usize,
    pub inliers: usize,
    /// The pair's tie points (none unless at least 8 matches agree).
    pub ties: Vec<PairTie>,
}

/// A tie point of a pair: its first guess on the ground, its pixel in each frame and weight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PairTie {
    pub ground: [f64; 3],
    pub pixel_a: [f64; 2],
    pub pixel_b: [f64; 2],
    pub weight: f64,
}

impl PairMatch {
    fn reliable(&self) -> bool {
        self.inliers >= 8
    }
}

/// Tie points of one pair (frame indices `i`, `j`) as rendered.
fn pair_ties(
    (i, a): (usize, &Rendered),
    (j, b): (usize, &Rendered),
    side: usize,
    ground_z: &(dyn Fn(f64, f64) -> f64 + Send + Sync),
) -> Result<PairMatch, Error> {
    let (matches, tried) = match_pair(a, b, side)?;
    let mut report = PairMatch {
        a: i,
        b: j,
        patches: tried,
        inliers: 0,
        ties: vec![],
    };
    let from: Vec<[f64; 2]> = matches.iter().map(|m| m.0).collect();
    let to: Vec<[f64; 2]> = matches.iter().map(|m| m.1).collect();
    let ransac = RansacOptions {
        threshold: 1.0,
        ..RansacOptions::default()
    };
    let Ok(fit) = ransac_homography(&from, &to, &ransac) else {
        return Ok(report);
    };
    let mut ties = Vec::new();
    for (m, keep) in matches.iter().zip(&fit.inliers) {
        let (Some(pa), Some(pb)) = (
            a.coarse_plan.frame_pixel_of_unmasked(m.0[0], m.0[1]),
            b.coarse_plan.frame_pixel_of_unmasked(m.1[0], m.1[1]),
        ) else {
            continue;
        };
        if !*keep {
            continue;
        }
        let g = a.coarse_plan.grid.centre_of(m.0[0], m.0[1]);
        ties.push(PairTie {
            ground: [g[0], g[1], ground_z(g[0], g[1])],
            pixel_a: pa,
            pixel_b: pb,
            weight: m.2.clamp(0.05, 1.0),
        });
    }
    report.inliers = ties.len();
    if report.reliable() {
        report.ties = ties;
    }
    Ok(report)
}

impl PairTie {
    fn tie_point(&self, a: usize, b: usize) -> TiePoint {
        let obs = |frame, pixel| Observation {
            frame,
            pixel,
            weight: self.weight,
        };
        TiePoint {
            ground: self.ground,
            observations: vec![obs(a, self.pixel_a), obs(b, self.pixel_b)],
        }
    }
}

/// Median ground distance between the two frames' rays of each tie (at the tie's height).
fn misalignment(ties: &[TiePoint], poses: &[Pose], cameras: &[&Camera]) -> f64 {
    let mut d: Vec<f64> = ties
        .iter()
        .filter_map(|t| tie_gap(t, poses, cameras).map(|g| g[0].hypot(g[1])))
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The terrain's height at world (x, y): the DEM (through its CRS), the level ground, or 0
/// (heights above the take-off point).
fn ground_fn(
    opts: &DroneOptions,
    world: &Projection,
) -> Box<dyn Fn(f64, f64) -> f64 + Send + Sync> {
    if let Some(dem) = &opts.dem {
        let dem = std::sync::Arc::clone(dem);
        let world = world.clone();
        let mid = dem.range().map_or(0.0, |r| 0.5 * (r.0 + r.1));
        return Box::new(move |x, y| dem.height_in(&world, x, y).unwrap_or(mid));
    }
    let z = opts.ground_height_m.unwrap_or(0.0);
    Box::new(move |_, _| z)
}

/// The flight after adjustment: every frame's corrected pose and camera.
pub struct AdjustedFlight {
    frames: Vec<Frame>,
    /// Every frame as rendered for the last matching round.
    rendered: Vec<Rendered>,
    /// The last round's tie points, with their gaps before and after.
    pub ties: Vec<TieVector>,
    pub poses: Vec<Pose>,
    pub cameras: Vec<Camera>,
    pub report: FlightReport,
    world: Projection,
    crs: Crs,
}

/// Plans, matches and adjusts a flight: [`FlightPlan`]'s steps, each round's frames rendered
/// once and shared by their pairs.
pub fn adjust_flight(
    inputs: &[PathBuf],
    opts: &DroneOptions,
    fo: &FlightOptions,
) -> Result<AdjustedFlight, Error> {
    fo.validate()?;
    let plan = FlightPlan::new(inputs, opts, fo)?;
    let mut progress = FlightProgress::default();
    loop {
        let o = progress.orientation.as_ref();
        let rendered: Vec<Rendered> = (0..plan.len())
            .into_par_iter()
            .map(|k| plan.render(k, o))
            .collect::<Result<_, Error>>()?;
        let grids: Vec<OrthoGrid> = rendered.iter().map(|r| r.coarse_plan.grid).collect();
        let matched: Vec<PairMatch> = overlapping(&grids)
            .par_iter()
            .map(|&(i, j)| plan.match_rendered((i, &rendered[i]), (j, &rendered[j])))
            .collect::<Result<_, Error>>()?;
        let round = plan.adjust_round(&mut progress, matched)?;
        if progress.done {
            return Ok(plan.finish(progress, round, rendered));
        }
    }
}

/// A flight planned for matching (every frame's metadata, camera and recorded pose, its plan
/// on the matching grid, the flight's CRS and ground): the steps of [`adjust_flight`], each a
/// pure function of the plan and its arguments, so that they can run apart (a pair on each
/// worker) and give what `adjust_flight` gives. The same inputs and options plan the same.
pub struct FlightPlan {
    frames: Vec<Frame>,
    opts: DroneOptions,
    fo: FlightOptions,
    gsd: f64,
    ground: Box<dyn Fn(f64, f64) -> f64 + Send + Sync>,
    rec: Recorded,
    world: Projection,
    crs: Crs,
    started: std::time::Instant,
    /// The plan's warnings (the matching grid coarsened).
    warnings: Vec<String>,
}

/// Every frame's pose and camera (a round's adjusted orientation).
#[derive(Debug, Clone, PartialEq)]
pub struct Orientation {
    pub poses: Vec<Pose>,
    pub cameras: Vec<Camera>,
}

/// The rounds so far: the last round's orientation (none before the first), their summaries,
/// and whether they are done. Travels between processes as [`FlightProgress::to_json`].
#[derive(Debug, Clone, Default)]
pub struct FlightProgress {
    pub orientation: Option<Orientation>,
    pub rounds: Vec<RoundSummary>,
    pub done: bool,
    /// When the last round ended (its successor's clock).
    since: Option<std::time::Instant>,
}

impl FlightPlan {
    /// Reads every frame's metadata and plans it on the matching grid.
    pub fn new(inputs: &[PathBuf], opts: &DroneOptions, fo: &FlightOptions) -> Result<Self, Error> {
        let started = std::time::Instant::now();
        let metas: Vec<(PathBuf, PhotoMetadata)> = inputs
            .iter()
            .map(|p| Ok((p.clone(), aerorect_io::read_photo_metadata(p)?)))
            .collect::<Result<_, Error>>()?;
        let (crs, world) = flight_crs(&metas, opts)?;
        let opts = DroneOptions {
            crs: Some((crs.clone(), world.clone())),
            ..opts.clone()
        };
        // The matching grid: the finest nadir GSD times up to 4 (frames keep about 600 px across).
        let gsd = match fo.match_gsd_m {
            Some(g) => g,
            None => {
                let (g, short_side) = finest_gsd(&metas, &opts)?;
                g * (short_side as f64 / 600.0).clamp(1.0, 4.0)
            }
        };
        let (gsd, frames, warnings) = plan_matching(&metas, &opts, gsd)?;
        Ok(Self {
            ground: ground_fn(&opts, &world),
            rec: recorded(&frames),
            frames,
            opts,
            fo: fo.clone(),
            gsd,
            world,
            crs,
            started,
            warnings,
        })
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frame `k`'s plan on the matching grid: as recorded, or with `orientation`'s pose and
    /// camera (its frame pixels, and so its tie observations, stay those of the photo).
    fn matching_plan(
        &self,
        k: usize,
        orientation: Option<&Orientation>,
    ) -> Result<OrthoPlan, Error> {
        let f = &self.frames[k];
        let Some(o) = orientation else {
            return Ok(f.coarse_plan.clone());
        };
        let ground = frame_ground(f, &self.opts);
        let req = OrthoRequest {
            camera: &o.cameras[k],
            pose: o.poses[k],
            world: &self.world,
            ground: &ground,
            gsd_m: f.coarse_plan.grid.gsd,
            // The GSD was chosen for the recorded orientation to fit the budget; an adjusted
            // one moves the footprint a little.
            limits: aerorect_core::RectifyLimits {
                max_output_px: 4 * MATCH_BUDGET_PX,
            },
            occlusion: false,
        };
        let warp = WarpOptions {
            interp: Interp::Bilinear,
            nodata: f64::NAN,
            alpha: false,
            prefilter: true,
            ..WarpOptions::default()
        };
        plan_ortho(&req, warp).map_err(|e| Error::Invalid(format!("{}: {e}", f.input.display())))
    }

    /// Frame `k`'s gray ortho on the matching grid.
    fn render(&self, k: usize, orientation: Option<&Orientation>) -> Result<Rendered, Error> {
        let coarse_plan = self.matching_plan(k, orientation)?;
        let input = &self.frames[k].input;
        let image = aerorect_io::read_image(input)?;
        let gray = AnyRaster::F32(crate::motion::gray(&image)?);
        drop(image);
        let AnyRaster::F32(coarse) = coarse_plan.run(&gray)? else {
            return Err(Error::Invalid(format!(
                "{}: gray ortho is not f32",
                input.display()
            )));
        };
        Ok(Rendered {
            coarse,
            coarse_plan,
        })
    }

    /// The pairs of frames whose matching grids overlap with `orientation` (none: recorded).
    pub fn pairs(&self, orientation: Option<&Orientation>) -> Result<Vec<(usize, usize)>, Error> {
        let grids: Vec<OrthoGrid> = (0..self.len())
            .into_par_iter()
            .map(|k| Ok(self.matching_plan(k, orientation)?.grid))
            .collect::<Result<_, Error>>()?;
        Ok(overlapping(&grids))
    }

    /// Frames `i` and `j` rendered with `orientation` (none: recorded) and matched.
    pub fn pair_match(
        &self,
        i: usize,
        j: usize,
        orientation: Option<&Orientation>,
    ) -> Result<PairMatch, Error> {
        if i.max(j) >= self.len() {
            return Err(Error::Invalid(format!(
                "pair ({i}, {j}) of a flight of {} frames",
                self.len()
            )));
        }
        let (a, b) = (self.render(i, orientation)?, self.render(j, orientation)?);
        self.match_rendered((i, &a), (j, &b))
    }

    fn match_rendered(
        &self,
        a: (usize, &Rendered),
        b: (usize, &Rendered),
    ) -> Result<PairMatch, Error> {
        pair_ties(a, b, self.fo.patch, self.ground.as_ref())
    }

    /// One round's adjustment from the matches of every overlapping pair (in [`Self::pairs`]'
    /// order): the recorded orientation adjusted to their tie points; `progress` gets the
    /// round's orientation and summary, and is done after [`FlightOptions::passes`] rounds or
    /// when the median frame turned by less than [`FlightOptions::settled_deg`]. Returns the
    /// flight's report as of this round.
    pub fn adjust(
        &self,
        progress: &mut FlightProgress,
        matched: Vec<PairMatch>,
    ) -> Result<FlightReport, Error> {
        let round = self.adjust_round(progress, matched)?;
        Ok(self.report(progress, round).0)
    }

    fn adjust_round(
        &self,
        progress: &mut FlightProgress,
        matched: Vec<PairMatch>,
    ) -> Result<Round, Error> {
        let posed = self.opts.poses.is_some();
        let mode = (self.opts.dem.is_some(), posed);
        let name = |k: usize| self.frames.get(k).map(|f| f.input.display().to_string());
        let mut pairs = Vec::with_capacity(matched.len());
        for m in matched {
            let (Some(a), Some(b)) = (name(m.a), name(m.b)) else {
                return Err(Error::Invalid(format!(
                    "pair ({}, {}) of a flight of {} frames",
                    m.a,
                    m.b,
                    self.len()
                )));
            };
            pairs.push((m, a, b));
        }
        let round = match_and_adjust(pairs, self, mode)?;
        let (poses, cameras) = round.orientation(&self.rec);
        let before = progress
            .orientation
            .as_ref()
            .map_or(&self.rec.poses, |o| &o.poses);
        let typical = median_turn_deg(before, &poses);
        let since = progress.since.unwrap_or(self.started);
        progress.rounds.push(round.summary((before, &poses), since));
        progress.since = Some(std::time::Instant::now());
        progress.done = progress.rounds.len() >= self.fo.passes.min(MAX_PASSES)
            || (progress.rounds.len() > 1 && typical < self.fo.settled_deg);
        progress.orientation = Some(Orientation { poses, cameras });
        Ok(round)
    }

    /// The flight's report after `round`, and the round's tie vectors.
    fn report(&self, progress: &FlightProgress, round: Round) -> (FlightReport, Vec<TieVector>) {
        let (poses, cameras) = round.orientation(&self.rec);
        let (settled, oscillating) = settling(&progress.rounds, self.fo.settled_deg);
        let mut warnings = self.warnings.clone();
        if self.fo.passes > MAX_PASSES {
            warnings.push(format!(
                "{} matching rounds asked for: at most {MAX_PASSES} are run",
                self.fo.passes
            ));
        }
        warnings.extend(round.warnings.iter().cloned());
        if !settled {
            warnings.push(rounds_warning(
                &progress.rounds,
                self.fo.settled_deg,
                oscillating,
            ));
        }
        let report = FlightReport {
            frames: self
                .frames
                .iter()
                .map(|f| f.input.display().to_string())
                .collect(),
            passes: progress.rounds.len(),
            rounds: progress.rounds.clone(),
            match_gsd_m: self.gsd,
            settled,
            oscillating,
            warnings,
            unconnected: unconnected(&self.frames, &round.reports),
            pairs: round.reports,
            adjustment: round.adjusted.report,
            poses: adjusted_poses(&self.frames, &poses, &cameras),
            seconds: self.started.elapsed().as_secs_f64(),
        };
        (report, round.ties)
    }

    fn finish(
        self,
        progress: FlightProgress,
        round: Round,
        rendered: Vec<Rendered>,
    ) -> AdjustedFlight {
        let (poses, cameras) = round.orientation(&self.rec);
        let (report, ties) = self.report(&progress, round);
        AdjustedFlight {
            frames: self.frames,
            rendered,
            ties,
            poses,
            cameras,
            report,
            world: self.world,
            crs: self.crs,
        }
    }

    /// The output CRS of every frame.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }

    /// Frame `k` rectified with `orientation`'s pose and camera onto the output grid, staged
    /// (as [`AdjustedFlight::write_frame_staged`]).
    pub fn write_frame_staged(
        &self,
        k: usize,
        orientation: &Orientation,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let (Some(f), Some(pose), Some(camera)) = (
            self.frames.get(k),
            orientation.poses.get(k),
            orientation.cameras.get(k),
        ) else {
            return Err(Error::Invalid(format!(
                "frame {k} of a flight of {} frames",
                self.len()
            )));
        };
        let oriented = Oriented {
            frame: f,
            pose: *pose,
            camera,
            world: &self.world,
            crs: &self.crs,
        };
        oriented.write_staged(output, opts, staged)
    }
}

/// The pairs (i < j) of these grids that overlap.
fn overlapping(grids: &[OrthoGrid]) -> Vec<(usize, usize)> {
    (0..grids.len())
        .flat_map(|i| (i + 1..grids.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| overlap(&grids[i], &grids[j]).is_some())
        .collect()
}

/// JSON that gives back every finite float to the bit (each written as `"f64:"` and its bits
/// in hex; a NaN or infinity becomes null, which reading refuses): a round's matches and
/// orientation go from worker to worker so.
pub fn exact_json<T: Serialize>(value: &T) -> Result<String, Error> {
    let mut v = serde_json::to_value(value).map_err(|e| Error::Invalid(e.to_string()))?;
    map_numbers(&mut v, &|v| {
        if let serde_json::Value::Number(n) = v
            && n.is_f64()
            && let Some(x) = n.as_f64()
        {
            *v = serde_json::Value::String(format!("f64:{:016x}", x.to_bits()));
        }
    });
    serde_json::to_string(&v).map_err(|e| Error::Invalid(e.to_string()))
}

/// The value [`exact_json`] wrote.
pub fn from_exact_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, Error> {
    let mut v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| Error::Invalid(format!("exact JSON: {e}")))?;
    map_numbers(&mut v, &|v| {
        if let serde_json::Value::String(s) = v
            && let Some(bits) = s.strip_prefix("f64:")
            && let Ok(b) = u64::from_str_radix(bits, 16)
        {
            *v = serde_json::Number::from_f64(f64::from_bits(b))
                .map_or(serde_json::Value::Null, serde_json::Value::Number);
        }
    });
    serde_json::from_value(v).map_err(|e| Error::Invalid(format!("exact JSON: {e}")))
}

fn map_numbers(v: &mut serde_json::Value, f: &dyn Fn(&mut serde_json::Value)) {
    match v {
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| map_numbers(x, f)),
        serde_json::Value::Object(o) => o.values_mut().for_each(|x| map_numbers(x, f)),
        _ => f(v),
    }
}

/// A pose's file form: the centre and `world_from_camera` row by row.
type PoseFile = ([f64; 3], [[f64; 3]; 3]);

/// [`FlightProgress`]'s file form.
#[derive(Serialize, Deserialize)]
struct ProgressFile {
    poses: Option<Vec<PoseFile>>,
    cameras: Option<Vec<CameraFile>>,
    rounds: Vec<RoundSummary>,
    done: bool,
}

#[derive(Serialize, Deserialize)]
struct CameraFile {
    intrinsics: aerorect_core::Intrinsics,
    distortion: Option<aerorect_core::distortion::Distortion>,
    size: ImageSize,
}

impl FlightProgress {
    /// As [`exact_json`]: every float to the bit.
    pub fn to_json(&self) -> Result<String, Error> {
        let o = self.orientation.as_ref();
        let file = ProgressFile {
            poses: o.map(|o| {
                o.poses
                    .iter()
                    .map(|p| {
                        let m = p.world_from_camera();
                        let row = |r: usize| [m[(r, 0)], m[(r, 1)], m[(r, 2)]];
                        (p.centre, [row(0), row(1), row(2)])
                    })
                    .collect()
            }),
            cameras: o.map(|o| {
                o.cameras
                    .iter()
                    .map(|c| CameraFile {
                        intrinsics: c.intrinsics,
                        distortion: c.distortion.clone(),
                        size: c.size,
                    })
                    .collect()
            }),
            rounds: self.rounds.clone(),
            done: self.done,
        };
        exact_json(&file)
    }

    pub fn from_json(text: &str) -> Result<Self, Error> {
        let f: ProgressFile = from_exact_json(text)?;
        let orientation = match (f.poses, f.cameras) {
            (Some(p), Some(c)) => Some(Orientation {
                poses: p
                    .into_iter()
                    .map(|(centre, [a, b, c])| {
                        let m = aerorect_core::Mat3::new(
                            a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2],
                        );
                        Pose::new(centre, &m)
                    })
                    .collect(),
                cameras: c
                    .into_iter()
                    .map(|c| Camera::new(c.intrinsics, c.distortion, c.size))
                    .collect(),
            }),
            _ => None,
        };
        Ok(Self {
            orientation,
            rounds: f.rounds,
            done: f.done,
            since: None,
        })
    }
}

/// The rotation between each pair of poses of the same frames, degrees.
fn turns_deg(a: &[Pose], b: &[Pose]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(p, q)| {
            let m = p.world_from_camera().transpose() * q.world_from_camera();
            ((m.trace() - 1.0) / 2.0)
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        })
        .collect()
}

fn largest_turn_deg(a: &[Pose], b: &[Pose]) -> f64 {
    turns_deg(a, b).into_iter().fold(0.0, f64::max)
}

fn median_turn_deg(a: &[Pose], b: &[Pose]) -> f64 {
    let mut t = turns_deg(a, b);
    t.sort_by(f64::total_cmp);
    t.get(t.len() / 2).copied().unwrap_or(0.0)
}

/// The recorded orientation: poses, the distinct cameras and each frame's camera index.
struct Recorded {
    poses: Vec<Pose>,
    cameras: Vec<Camera>,
    camera_of: Vec<usize>,
}

/// One round of matching and adjustment.
struct Round {
    reports: Vec<PairReport>,
    adjusted: aerorect_solve::adjust::Adjusted,
    ties: Vec<TieVector>,
    warnings: Vec<String>,
}

/// A tie point on the ground and how far apart its two frames put it (frame b's ground point
/// to frame a's, metres east and north, at the tie's height) with the recorded and with the
/// adjusted orientation.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TieVector {
    pub ground: [f64; 2],
    pub before_m: [f64; 2],
    pub after_m: [f64; 2],
}

/// The two frames' ground points of a two-frame tie, b to a.
fn tie_gap(t: &TiePoint, poses: &[Pose], cameras: &[&Camera]) -> Option<[f64; 2]> {
    let [a, b] = [t.observations.first()?, t.observations.get(1)?];
    let pa = on_level(&poses[a.frame], cameras[a.frame], a.pixel, t.ground[2])?;
    let pb = on_level(&poses[b.frame], cameras[b.frame], b.pixel, t.ground[2])?;
    Some([pa[0] - pb[0], pa[1] - pb[1]])
}

impl Round {
    /// The round's summary; restarts the clock `t`.
    fn summary(
        &self,
        (before, after): (&[Pose], &[Pose]),
        since: std::time::Instant,
    ) -> RoundSummary {
        RoundSummary {
            largest_turn_deg: largest_turn_deg(before, after),
            median_turn_deg: median_turn_deg(before, after),
            tie_points: self.adjusted.report.tie_points,
            reliable_pairs: self.reports.iter().filter(|r| r.reliable).count(),
            rms_after_px: self.adjusted.report.rms_after_px,
            seconds: since.elapsed().as_secs_f64(),
        }
    }

    /// Every frame's adjusted pose and camera.
    fn orientation(&self, rec: &Recorded) -> (Vec<Pose>, Vec<Camera>) {
        let poses = self
            .adjusted
            .frames
            .iter()
            .map(|f| Pose::new(f.centre, &f.world_from_camera))
            .collect();
        let cameras = rec
            .camera_of
            .iter()
            .map(|&c| self.adjusted.cameras[c].clone())
            .collect();
        (poses, cameras)
    }
}

/// Adjusts the recorded orientation to the tie points of the matched pairs (each with its
/// frames' names; `dem`: the ground is a DEM; `posed`: the frames come from a pose table).
fn match_and_adjust(
    matched: Vec<(PairMatch, String, String)>,
    plan: &FlightPlan,
    (dem, posed): (bool, bool),
) -> Result<Round, Error> {
    let (rec, fo, frames) = (&plan.rec, &plan.fo, &plan.frames);
    let ground = plan.ground.as_ref();
    let cams: Vec<&Camera> = rec.camera_of.iter().map(|&c| &rec.cameras[c]).collect();
    let mut reports = Vec::with_capacity(matched.len());
    let mut ties = Vec::new();
    for (m, a, b) in matched {
        let t: Vec<TiePoint> = m.ties.iter().map(|t| t.tie_point(m.a, m.b)).collect();
        reports.push(PairReport {
            a,
            b,
            patches: m.patches,
            inliers: m.inliers,
            misalignment_before_m: misalignment(&t, &rec.poses, &cams),
            misalignment_after_m: None,
            reliable: m.reliable(),
        });
        ties.extend(t);
    }
    let position_sigma_m = match fo.positions {
        PositionPrior::Hold => None,
        PositionPrior::Sigma(s) => Some(s),
        PositionPrior::Recorded => (!posed).then_some(GPS_SIGMA_M),
    };
    let own = fo.positions == PositionPrior::Recorded;
    let adjust_frames: Vec<AdjustFrame> = rec
        .poses
        .iter()
        .zip(&rec.camera_of)
        .zip(frames)
        .map(|((p, &camera), f)| AdjustFrame {
            camera,
            centre: p.centre,
            world_from_camera: p.world_from_camera(),
            // A receiver's claim of a millimetre is held to 5 mm.
            position_sigma_m: f.rtk_std_m.filter(|_| own).map(|s| s.map(|v| v.max(0.005))),
        })
        .collect();
    let aopts = AdjustOptions {
        attitude_sigma_deg: fo.attitude_sigma_deg,
        position_sigma_m,
        refine_focal: fo.refine_focal,
        refine_principal_point: fo.refine_principal_point,
        refine_radial: fo.refine_radial,
        refine_boresight: fo.refine_boresight,
        terrain: Some((ground, if dem { 1.0 } else { 0.1 })),
        ..AdjustOptions::default()
    };
    let adjusted = aerorect_solve::adjust::adjust(&adjust_frames, &rec.cameras, &ties, &aopts)
        .map_err(|e| Error::Invalid(format!("flight adjustment: {e}")))?;
    let warnings = solve_warnings(frames, &adjusted.report)?;
    let mut round = Round {
        reports,
        adjusted,
        ties: Vec::new(),
        warnings,
    };
    let (poses, cameras) = round.orientation(rec);
    let new_cams: Vec<&Camera> = cameras.iter().collect();
    finish_reports(&mut round.reports, &ties, &poses, &new_cams);
    round.ties = ties
        .iter()
        .filter_map(|t| {
            Some(TieVector {
                ground: [t.ground[0], t.ground[1]],
                before_m: tie_gap(t, &rec.poses, &cams)?,
                after_m: tie_gap(t, &poses, &new_cams)?,
            })
        })
        .collect();
    Ok(round)
}

/// The warnings of a solve (gauge freedoms held, an iteration limit met with a sub-pixel
/// RMS), or its error when its own residuals say it failed.
fn solve_warnings(frames: &[Frame], report: &AdjustReport) -> Result<Vec<String>, Error> {
    let name = |k: usize| frames[k].input.display().to_string();
    let mut out = Vec::new();
    for g in &report.gauge {
        let names: Vec<String> = g.frames.iter().map(|&k| name(k)).collect();
        out.push(format!(
            "{} were taken from one point ({:.2} m apart at {:.0} m range): {}",
            names.join(", "),
            g.baseline_m,
            g.range_m,
            g.held
        ));
    }
    if !report.converged {
        if report.rms_after_px > UNCONVERGED_RMS_PX {
            return Err(Error::Invalid(format!(
                "the flight adjustment did not converge in {} iterations (rms {:.2} px, over {UNCONVERGED_RMS_PX} px); the frames it could not place: {}; nothing written",
                report.iterations,
                report.rms_after_px,
                unplaced(frames, report)
            )));
        }
        out.push(format!(
            "the flight adjustment met no tolerance in {} iterations ({:?}); its rms {:.2} px is sub-pixel, so its result is kept",
            report.iterations, report.termination, report.rms_after_px
        ));
    }
    Ok(out)
}

/// Every frame planned on the matching grid: at `gsd`, or coarser until every frame's ortho
/// fits [`MATCH_BUDGET_PX`] (with a warning); returns the GSD used.
fn plan_matching(
    metas: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
    gsd: f64,
) -> Result<(f64, Vec<Frame>, Vec<String>), Error> {
    let (mut g, mut first) = (gsd, None);
    for _ in 0..8 {
        let planned: Vec<Result<Frame, Error>> = metas
            .par_iter()
            .map(|(p, m)| plan_frame(p, m, opts, (g, MATCH_BUDGET_PX)))
            .collect();
        if planned.iter().all(Result::is_ok) {
            let frames = planned.into_iter().collect::<Result<Vec<_>, _>>()?;
            let warnings = first
                .map(|(px, k): (u64, usize)| {
                    format!(
                        "matching grid: at {gsd:.4} m the ortho of {} would be {px} px, over the matching budget of {MATCH_BUDGET_PX} px; the frames are matched at {g:.4} m",
                        metas[k].0.display()
                    )
                })
                .into_iter()
                .collect();
            return Ok((g, frames, warnings));
        }
        // A frame over the budget plans with room to spare (a plan allocates no pixels):
        // its size says how much coarser the grid must be; any other failure is the frame's.
        let mut worst = (0u64, 0usize);
        for (k, r) in planned.into_iter().enumerate() {
            let Err(e) = r else { continue };
            let (p, m) = &metas[k];
            let Ok(f) = plan_frame(p, m, opts, (g, 64 * MATCH_BUDGET_PX)) else {
                return Err(e);
            };
            worst = worst.max((f.coarse_plan.grid.size.pixels() as u64, k));
        }
        first.get_or_insert(worst);
        g *= 1.02 * (worst.0 as f64 / MATCH_BUDGET_PX as f64).sqrt().max(1.0);
    }
    Err(Error::Invalid(format!(
        "matching grid: no GSD up to {g:.3} m keeps every frame's ortho within {MATCH_BUDGET_PX} px"
    )))
}

/// Whether the rounds settled (the last median turn below `settled_deg`) and, if not,
/// whether they oscillate (the last median turn above half the smallest before it).
fn settling(rounds: &[RoundSummary], settled_deg: f64) -> (bool, bool) {
    let Some(last) = rounds.last() else {
        return (true, false);
    };
    if rounds.len() < 2 || last.median_turn_deg < settled_deg {
        return (true, false);
    }
    let smallest = rounds[..rounds.len() - 1]
        .iter()
        .map(|r| r.median_turn_deg)
        .fold(f64::INFINITY, f64::min);
    (false, last.median_turn_deg > 0.5 * smallest)
}

fn rounds_warning(rounds: &[RoundSummary], settled_deg: f64, oscillating: bool) -> String {
    let turns: Vec<String> = rounds
        .iter()
        .map(|r| format!("{:.3}", r.median_turn_deg))
        .collect();
    format!(
        "the matching rounds {} in {} rounds: the median frame turned by {} deg per round (largest {:.3} deg in the last), never below {settled_deg} deg; the last round's orientation is kept",
        if oscillating {
            "oscillate"
        } else {
            "did not settle"
        },
        rounds.len(),
        turns.join(", "),
        rounds.last().map_or(0.0, |r| r.largest_turn_deg)
    )
}

/// The frames a failed solve left worst: those with no observation, then the (at most five)
/// largest residual RMS, with it.
fn unplaced(frames: &[Frame], report: &AdjustReport) -> String {
    let name = |k: usize| frames[k].input.display().to_string();
    let mut worst: Vec<(usize, f64)> = report
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| {
            (
                k,
                if f.observations == 0 {
                    f64::INFINITY
                } else {
                    f.rms_after_px
                },
            )
        })
        .collect();
    worst.sort_by(|a, b| b.1.total_cmp(&a.1));
    worst
        .iter()
        .take(5)
        .map(|&(k, r)| match r.is_finite() {
            true => format!("{} (rms {r:.2} px)", name(k)),
            false => format!("{} (no tie point)", name(k)),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The ground a frame is projected on: the DEM, else the level ground under it as planned
/// from its metadata.
fn frame_ground(f: &Frame, opts: &DroneOptions) -> Ground {
    match &opts.dem {
        Some(dem) => Ground::Dem {
            dem: std::sync::Arc::clone(dem),
            fallback: None,
            strict: opts.strict,
        },
        None => Ground::Flat(level_ground(f)),
    }
}

/// The level ground under a frame as planned from its metadata.
fn level_ground(f: &Frame) -> f64 {
    f.info.pose.centre[2] - f.info.height_m
}

/// Every frame's adjusted pose as `--poses` reads it (omega-phi-kappa about the grid axes).
fn adjusted_poses(frames: &[Frame], poses: &[Pose], cameras: &[Camera]) -> Vec<AdjustedPose> {
    frames
        .iter()
        .zip(poses.iter().zip(cameras))
        .map(|(f, (p, c))| {
            let opk = aerorect_core::CameraRotation::from_matrix(p.world_from_camera())
                .map_or([f64::NAN; 3], |r| r.to_omega_phi_kappa());
            AdjustedPose {
                pose: aerorect_io::PoseRecord {
                    filename: f
                        .input
                        .file_name()
                        .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                    x: p.centre[0],
                    y: p.centre[1],
                    z: p.centre[2],
                    omega: opk[0],
                    phi: opk[1],
                    kappa: opk[2],
                },
                focal_px: c.intrinsics.fx,
            }
        })
        .collect()
}

/// The finest nadir GSD of the flight's frames (height over the focal length in pixels) and
/// the shortest side of their images.
fn finest_gsd(
    metas: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
) -> Result<(f64, usize), Error> {
    let ground = match (&opts.dem, opts.ground_height_m) {
        (_, Some(g)) => g,
        (Some(dem), None) => dem.range().map_or(0.0, |r| 0.5 * (r.0 + r.1)),
        (None, None) => 0.0,
    };
    let (mut best, mut short) = (f64::INFINITY, usize::MAX);
    for (p, m) in metas {
        // Only the matching grid's GSD depends on this: the camera file's own size, else the
        // size the photo's tags were written for.
        let cam = match (&opts.camera, m.width, m.height) {
            (Some(c), _, _) => c
                .camera(None)
                .or_else(|_| c.camera(Some(aerorect_io::read_image(p)?.size())))?,
            (None, Some(w), Some(h)) => {
                let size = ImageSize::new(w as usize, h as usize);
                crate::drone::camera_from_metadata(m, size, &p.display().to_string())?.camera
            }
            (None, _, _) => {
                let size = aerorect_io::read_image(p)?.size();
                crate::drone::camera_from_metadata(m, size, &p.display().to_string())?.camera
            }
        };
        let pose = match opts.poses.as_deref() {
            Some(t) => Some(crate::drone::pose_for(t, p).ok_or_else(|| {
                Error::Invalid(format!("{}: not in the pose table", p.display()))
            })?),
            None => None,
        };
        let h = match pose {
            Some(pose) => pose.z - ground,
            None => m.dji.relative_altitude_m.unwrap_or(100.0),
        };
        best = best.min(h.abs().max(1.0) / cam.intrinsics.fx);
        short = short.min(cam.size.width.min(cam.size.height));
    }
    Ok((best, short))
}

/// The recorded poses, the distinct cameras and each frame's camera index.
fn recorded(frames: &[Frame]) -> Recorded {
    let mut cameras: Vec<Camera> = Vec::new();
    let mut camera_of = Vec::with_capacity(frames.len());
    for f in frames {
        let c = &f.info.camera.camera;
        let k = cameras.iter().position(|x| x == c).unwrap_or_else(|| {
            cameras.push(c.clone());
            cameras.len() - 1
        });
        camera_of.push(k);
    }
    Recorded {
        poses: frames.iter().map(|f| f.info.pose).collect(),
        cameras,
        camera_of,
    }
}

fn finish_reports(reports: &mut [PairReport], ties: &[TiePoint], poses: &[Pose], cams: &[&Camera]) {
    // Ties are in pair order; each reliable pair contributed `inliers` of them.
    let mut at = 0;
    for r in reports.iter_mut().filter(|r| r.reliable) {
        let t = &ties[at..at + r.inliers];
        r.misalignment_after_m = Some(misalignment(t, poses, cams));
        at += r.inliers;
    }
}

fn unconnected(frames: &[Frame], reports: &[PairReport]) -> Vec<String> {
    frames
        .iter()
        .map(|f| f.input.display().to_string())
        .filter(|name| {
            !reports
                .iter()
                .any(|r| r.reliable && (&r.a == name || &r.b == name))
        })
        .collect()
}

/// A frame with a pose and camera, and the flight's CRS.
struct Oriented<'a> {
    frame: &'a Frame,
    pose: Pose,
    camera: &'a Camera,
    world: &'a Projection,
    crs: &'a Crs,
}

impl Oriented<'_> {
    /// The frame's ortho plan on the output grid (`opts`'s GSD, else the frame's own at nadir).
    fn plan(&self, opts: &DroneOptions) -> Result<OrthoPlan, Error> {
        let f = self.frame;
        let file = f.input.display().to_string();
        let ground = frame_ground(f, opts);
        // `info.gsd_m` is the matching grid's; the frame's own is its height over fx.
        let own_gsd = f.info.height_m / f.info.camera.camera.intrinsics.fx;
        let req = OrthoRequest {
            camera: self.camera,
            pose: self.pose,
            world: self.world,
            ground: &ground,
            gsd_m: opts.gsd_m.unwrap_or(own_gsd),
            limits: opts.limits,
            occlusion: opts.occlusion,
        };
        plan_ortho(&req, opts.warp).map_err(|e| Error::Invalid(format!("{file}: {e}")))
    }

    /// Rectifies the frame onto the output grid, its output staged.
    fn write_staged(
        &self,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let t = std::time::Instant::now();
        let mut lap_t = t;
        let f = self.frame;
        let image = aerorect_io::read_image(&f.input)?;
        let read = crate::drone::lap(&mut lap_t);
        let plan = self.plan(opts)?;
        let plan_s = crate::drone::lap(&mut lap_t);
        let out = plan.run(&image)?;
        let warp = crate::drone::lap(&mut lap_t);
        let mut info = f.info.clone();
        info.pose = self.pose;
        info.geo = georeference(self.crs.clone(), &plan, &opts.warp);
        info.gsd_m = plan.grid.gsd;
        info.warnings.extend(plan.warnings.iter().cloned());
        crate::drone::stage_output(staged, output, &out, &info.geo, opts.cog.as_ref())?;
        let stage_seconds = crate::drone::StageSeconds {
            read,
            plan: plan_s,
            warp,
            write: crate::drone::lap(&mut lap_t),
        };
        Ok(crate::drone::PhotoResult {
            input: f.input.display().to_string(),
            output: output.display().to_string(),
            input_size: [image.size().width, image.size().height],
            output_size: [plan.grid.size.width, plan.grid.size.height],
            footprint_en: plan.footprint.clone(),
            info,
            seconds: t.elapsed().as_secs_f64(),
            stage_seconds,
            thumbnails: None,
        })
    }
}

impl AdjustedFlight {
    fn oriented(&self, k: usize) -> Oriented<'_> {
        Oriented {
            frame: &self.frames[k],
            pose: self.poses[k],
            camera: &self.cameras[k],
            world: &self.world,
            crs: &self.crs,
        }
    }

    /// Frame `k`'s ortho plan with its adjusted pose and camera on the output grid (`opts`'s
    /// GSD, else the frame's own at nadir).
    pub fn plan(&self, k: usize, opts: &DroneOptions) -> Result<OrthoPlan, Error> {
        self.oriented(k).plan(opts)
    }

    /// The output CRS of every frame.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }

    /// Every frame planned for a mosaic with its adjusted pose and camera, all at one GSD:
    /// `opts`'s, else the finest frame's own (to the millimetre, as
    /// [`crate::mosaic::frames_from_photos`] chooses it).
    pub fn mosaic_frames(
        &self,
        opts: &DroneOptions,
    ) -> Result<Vec<crate::mosaic::MosaicFrame>, Error> {
        let mut o = opts.clone();
        if o.gsd_m.is_none() {
            let finest = self
                .frames
                .iter()
                .map(|f| f.info.height_m / f.info.camera.camera.intrinsics.fx)
                .fold(f64::INFINITY, f64::min);
            o.gsd_m = Some(((finest * 1000.0).round() / 1000.0).max(0.001));
        }
        (0..self.frames.len())
            .map(|k| {
                let c = self.poses[k].centre;
                Ok(crate::mosaic::MosaicFrame {
                    path: self.frames[k].input.clone(),
                    plan: self.plan(k, &o)?,
                    nadir_xy: [c[0], c[1]],
                    height_m: c[2] - level_ground(&self.frames[k]),
                })
            })
            .collect()
    }

    /// Rectifies frame `k` with its adjusted pose and camera onto the output grid and writes
    /// `output` (GeoTIFF, COG with `opts.cog`, or PNG + world file) atomically.
    pub fn write_frame(
        &self,
        k: usize,
        output: &Path,
        opts: &DroneOptions,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let mut staged = aerorect_io::StagedOutputs::new();
        let r = self.write_frame_staged(k, output, opts, &mut staged)?;
        staged.commit()?;
        Ok(r)
    }

    /// [`Self::write_frame`] with the output staged, to land with the caller's other outputs.
    pub fn write_frame_staged(
        &self,
        k: usize,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        self.oriented(k).write_staged(output, opts, staged)
    }

    /// A gray overview of the flight on the matching grid, each cell the mean of the frames
    /// that see it (as rendered for the last matching round), stretched to 8 bits between its
    /// 1st and 99th percentiles; cells no frame sees are black.
    pub fn overview(&self) -> Result<Raster<u8>, Error> {
        let grids: Vec<_> = self.rendered.iter().map(|f| f.coarse_plan.grid).collect();
        let Some(g0) = grids.first() else {
            return Err(Error::Invalid("a flight of no frames".into()));
        };
        let gsd = g0.gsd;
        let left = grids
            .iter()
            .map(|g| g.top_left[0])
            .fold(f64::INFINITY, f64::min);
        let top = grids
            .iter()
            .map(|g| g.top_left[1])
            .fold(f64::NEG_INFINITY, f64::max);
        let at = |g: &aerorect_geo::OrthoGrid| {
            (
                ((g.top_left[0] - left) / gsd).round() as usize,
                ((top - g.top_left[1]) / gsd).round() as usize,
            )
        };
        let (w, h) = grids.iter().fold((0, 0), |(w, h), g| {
            let (c, r) = at(g);
            (w.max(c + g.size.width), h.max(r + g.size.height))
        });
        if w * h > 64_000_000 {
            return Err(Error::Invalid(format!(
                "the flight's overview would be {w} x {h} px"
            )));
        }
        let (mut sum, mut n) = (vec![0f64; w * h], vec![0u32; w * h]);
        for (f, g) in self.rendered.iter().zip(&grids) {
            let (c0, r0) = at(g);
            for (i, v) in f.coarse.plane(0).iter().enumerate() {
                if v.is_finite() {
                    let j = (r0 + i / g.size.width) * w + c0 + i % g.size.width;
                    sum[j] += *v as f64;
                    n[j] += 1;
                }
            }
        }
        let mean: Vec<Option<f64>> = sum
            .iter()
            .zip(&n)
            .map(|(s, &k)| (k > 0).then(|| s / k as f64))
            .collect();
        let mut seen: Vec<f64> = mean.iter().flatten().copied().collect();
        seen.sort_by(f64::total_cmp);
        let q = |p: f64| {
            seen.get((p * (seen.len().max(1) - 1) as f64) as usize)
                .copied()
        };
        let (lo, hi) = (q(0.01).unwrap_or(0.0), q(0.99).unwrap_or(1.0));
        let px = mean
            .iter()
            .map(|m| {
                m.map_or(0, |v| {
                    (1.0 + 254.0 * ((v - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0)) as u8
                })
            })
            .collect();
        Ok(Raster::from_planes(ImageSize::new(w, h), vec![px])?)
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_json_gives_back_every_float_to_the_bit() {
        // Floats whose shortest decimal form a best-effort parser may miss by an ulp.
        let awkward = [
            0.1 + 0.2,
            -0.0,
            f64::MIN_POSITIVE / 3.0,
            f64::MAX,
            1.0 - f64::EPSILON / 2.0,
            2.0f64.sqrt() * 1e-300,
            123456.789_012_345_67,
        ];
        let m = PairMatch {
            a: 2,
            b: 7,
            patches: 40,
            inliers: 9,
            ties: awkward
                .windows(2)
                .map(|w| PairTie {
                    ground: [w[0], w[1], -w[0]],
                    pixel_a: [w[1], w[0]],
                    pixel_b: [w[0] * 0.5, w[1] / 7.0],
                    weight: w[0],
                })
                .collect(),
        };
        let back: PairMatch = from_exact_json(&exact_json(&m).unwrap()).unwrap();
        let bits = |m: &PairMatch| -> Vec<u64> {
            m.ties
                .iter()
                .flat_map(|t| {
                    let mut v = t.ground.to_vec();
                    v.extend(t.pixel_a);
                    v.extend(t.pixel_b);
                    v.push(t.weight);
                    v
                })
                .map(f64::to_bits)
                .collect()
        };
        assert_eq!(bits(&back), bits(&m));
        assert_eq!((back.a, back.b, back.patches, back.inliers), (2, 7, 40, 9));
    }

    #[test]
    fn progress_gives_back_poses_and_cameras_to_the_bit() {
        let r = aerorect_core::CameraRotation::omega_phi_kappa(0.1 + 0.2, -1.3e-3, 271.7).unwrap();
        let pose = Pose::new(
            [512_345.678_9, 5_974_321.012_3, 0.1 + 0.2],
            r.ground_from_camera(),
        );
        let k = aerorect_core::Intrinsics::new(3666.6667, 3666.6666, 2735.7, 1823.3).unwrap();
        let camera = Camera::new(k, None, ImageSize::new(5472, 3648));
        let p = FlightProgress {
            orientation: Some(Orientation {
                poses: vec![pose],
                cameras: vec![camera],
            }),
            rounds: vec![],
            done: true,
            since: None,
        };
        let back = FlightProgress::from_json(&p.to_json().unwrap()).unwrap();
        assert_eq!(back.orientation, p.orientation);
        assert!(back.done);
    }
}
