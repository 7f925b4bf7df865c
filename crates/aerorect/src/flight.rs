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
use aerorect_geo::{Pose, Projection};
use aerorect_io::{Crs, PhotoMetadata};
use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
use aerorect_raster::{AnyRaster, Interp, Raster, WarpOptions};
use aerorect_solve::adjust::{AdjustFrame, AdjustOptions, AdjustReport, Observation, TiePoint};
use aerorect_solve::ransac::{RansacOptions, ransac_homography};
use rayon::prelude::*;
use serde::Serialize;
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
    /// from round to round without the others moving).
    pub passes: usize,
    pub settled_deg: f64,
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
    /// Its gray ortho on the matching grid (NaN: no data) and that ortho's plan.
    coarse: Raster<f32>,
    coarse_plan: OrthoPlan,
    /// The photo's RTK standard deviations (m; east, north, up), if it has them.
    rtk_std_m: Option<[f64; 3]>,
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
    pub frame: String,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub omega: f64,
    pub phi: f64,
    pub kappa: f64,
    /// The adjusted camera's focal length (px, fx).
    pub focal_px: f64,
}

impl FlightReport {
    /// The adjusted poses as `--poses` (and Orthority) read them:
    /// `filename,x,y,z,omega,phi,kappa`.
    pub fn poses_csv(&self) -> String {
        let mut out = String::from("filename,x,y,z,omega,phi,kappa\n");
        for p in &self.poses {
            out += &format!(
                "{},{:.4},{:.4},{:.4},{:.8},{:.8},{:.8}\n",
                p.frame, p.x, p.y, p.z, p.omega, p.phi, p.kappa
            );
        }
        out
    }
}

/// What one matching round found.
#[derive(Debug, Clone, Serialize)]
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

/// Plans a frame on the matching grid and renders its gray ortho there.
fn coarse_frame(
    input: &Path,
    meta: PhotoMetadata,
    opts: &DroneOptions,
    gsd: f64,
) -> Result<Frame, Error> {
    let file = input.display().to_string();
    let rtk_std_m = meta.dji.rtk_std_m;
    let image = aerorect_io::read_image(input)?;
    let size = image.size();
    let gray = AnyRaster::F32(crate::motion::gray(&image)?);
    drop(image);
    let coarse_opts = DroneOptions {
        gsd_m: Some(gsd),
        warp: WarpOptions {
            interp: Interp::Bilinear,
            nodata: f64::NAN,
            alpha: false,
        },
        limits: aerorect_core::RectifyLimits {
            max_output_px: 4_000_000,
        },
        occlusion: false,
        ..opts.clone()
    };
    let posed = opts
        .poses
        .as_deref()
        .map(|p| crate::drone::pose_for(p, input));
    let (coarse_plan, info) = match posed {
        Some(Some(pose)) => crate::drone::plan_from_pose(pose, &meta, size, &coarse_opts, &file)?,
        Some(None) => return Err(Error::Invalid(format!("{file}: not in the pose table"))),
        None => plan_from_metadata(&meta, size, &coarse_opts, &file)?,
    };
    let AnyRaster::F32(coarse) = coarse_plan.run(&gray)? else {
        return Err(Error::Invalid(format!("{file}: gray ortho is not f32")));
    };
    Ok(Frame {
        input: input.to_path_buf(),
        info,
        coarse,
        coarse_plan,
        rtk_std_m,
    })
}

/// The overlap of two frames' grids in A's pixels: [c0, r0, c1, r1) and B's offset.
fn overlap(a: &Frame, b: &Frame) -> Option<([i64; 4], [i64; 2])> {
    let (ga, gb) = (a.coarse_plan.grid, b.coarse_plan.grid);
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
    a: &Frame,
    b: &Frame,
    side: usize,
    prior: [i64; 2],
) -> Result<(Vec<Match>, usize), Error> {
    let Some(([c0, r0, c1, r1], off)) = overlap(a, b) else {
        return Ok((vec![], 0));
    };
    let mut pc = PhaseCorrelator::new(
        side,
        side,
        PhaseOptions {
            weighting: Weighting::Phase,
            window: true,
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
fn match_pair(a: &Frame, b: &Frame, side: usize) -> Result<(Vec<Match>, usize), Error> {
    // The largest power-of-two patch (up to 256 px) that fits the overlap.
    let fits = overlap(a, b).map_or(0, |([c0, r0, c1, r1], _)| {
        (c1 - c0).min(r1 - r0).max(0) as usize
    });
    let big = [256, 128, 64]
        .into_iter()
        .find(|&s| s <= fits)
        .unwrap_or(side);
    let (coarse, _) = match_patches(a, b, big, [0, 0])?;
    let mut prior = [0i64; 2];
    if !coarse.is_empty() {
        let off = overlap(a, b).map_or([0, 0], |o| o.1);
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

/// Tie points of one pair (frame indices `i`, `j`) and its report.
fn pair_ties(
    frames: &[Frame],
    i: usize,
    j: usize,
    side: usize,
    ground_z: &(dyn Fn(f64, f64) -> f64 + Sync),
) -> Result<(Vec<TiePoint>, PairReport), Error> {
    let (a, b) = (&frames[i], &frames[j]);
    let (matches, tried) = match_pair(a, b, side)?;
    let mut report = PairReport {
        a: a.input.display().to_string(),
        b: b.input.display().to_string(),
        patches: tried,
        inliers: 0,
        misalignment_before_m: f64::NAN,
        misalignment_after_m: None,
        reliable: false,
    };
    let from: Vec<[f64; 2]> = matches.iter().map(|m| m.0).collect();
    let to: Vec<[f64; 2]> = matches.iter().map(|m| m.1).collect();
    let ransac = RansacOptions {
        threshold: 1.0,
        ..RansacOptions::default()
    };
    let Ok(fit) = ransac_homography(&from, &to, &ransac) else {
        return Ok((vec![], report));
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
        let obs = |frame, pixel| Observation {
            frame,
            pixel,
            weight: m.2.clamp(0.05, 1.0),
        };
        ties.push(TiePoint {
            ground: [g[0], g[1], ground_z(g[0], g[1])],
            observations: vec![obs(i, pa), obs(j, pb)],
        });
    }
    report.inliers = ties.len();
    report.reliable = ties.len() >= 8;
    if !report.reliable {
        ties.clear();
    }
    Ok((ties, report))
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
fn ground_fn(opts: &DroneOptions, world: &Projection) -> Box<dyn Fn(f64, f64) -> f64 + Sync> {
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
    /// The last round's tie points, with their gaps before and after.
    pub ties: Vec<TieVector>,
    pub poses: Vec<Pose>,
    pub cameras: Vec<Camera>,
    pub report: FlightReport,
    world: Projection,
    crs: Crs,
}

/// Plans, matches and adjusts a flight.
pub fn adjust_flight(
    inputs: &[PathBuf],
    opts: &DroneOptions,
    fo: &FlightOptions,
) -> Result<AdjustedFlight, Error> {
    let t0 = std::time::Instant::now();
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
    let mut frames: Vec<Frame> = metas
        .into_par_iter()
        .map(|(p, m)| coarse_frame(&p, m, &opts, gsd))
        .collect::<Result<_, Error>>()?;
    let ground = ground_fn(&opts, &world);
    let rec = recorded(&frames);
    let posed = opts.poses.is_some();
    let mode = (opts.dem.is_some(), posed);
    let mut t = std::time::Instant::now();
    let mut round = match_and_adjust(&frames, &rec, ground.as_ref(), mode, fo)?;
    let (mut poses, mut cameras) = round.orientation(&rec);
    let mut rounds = vec![round.summary((&rec.poses, &poses), &mut t)];
    while rounds.len() < fo.passes {
        frames = frames
            .into_par_iter()
            .enumerate()
            .map(|(k, f)| rerender(f, poses[k], &cameras[k], &opts, &world))
            .collect::<Result<_, Error>>()?;
        round = match_and_adjust(&frames, &rec, ground.as_ref(), mode, fo)?;
        let (p, c) = round.orientation(&rec);
        let typical = median_turn_deg(&poses, &p);
        rounds.push(round.summary((&poses, &p), &mut t));
        (poses, cameras) = (p, c);
        if typical < fo.settled_deg {
            break;
        }
    }
    let report = FlightReport {
        frames: frames
            .iter()
            .map(|f| f.input.display().to_string())
            .collect(),
        passes: rounds.len(),
        rounds,
        match_gsd_m: gsd,
        unconnected: unconnected(&frames, &round.reports),
        pairs: round.reports,
        adjustment: round.adjusted.report,
        poses: adjusted_poses(&frames, &poses, &cameras),
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(AdjustedFlight {
        frames,
        ties: round.ties,
        poses,
        cameras,
        report,
        world,
        crs,
    })
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
        t: &mut std::time::Instant,
    ) -> RoundSummary {
        let s = RoundSummary {
            largest_turn_deg: largest_turn_deg(before, after),
            median_turn_deg: median_turn_deg(before, after),
            tie_points: self.adjusted.report.tie_points,
            reliable_pairs: self.reports.iter().filter(|r| r.reliable).count(),
            rms_after_px: self.adjusted.report.rms_after_px,
            seconds: t.elapsed().as_secs_f64(),
        };
        *t = std::time::Instant::now();
        s
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

/// Matches every overlapping pair of the frames as rendered and adjusts the recorded
/// orientation to the tie points (`dem`: the ground is a DEM; `posed`: the frames come from
/// a pose table).
fn match_and_adjust(
    frames: &[Frame],
    rec: &Recorded,
    ground: &(dyn Fn(f64, f64) -> f64 + Sync),
    (dem, posed): (bool, bool),
    fo: &FlightOptions,
) -> Result<Round, Error> {
    let pairs: Vec<(usize, usize)> = (0..frames.len())
        .flat_map(|i| (i + 1..frames.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| overlap(&frames[i], &frames[j]).is_some())
        .collect();
    let matched: Vec<(Vec<TiePoint>, PairReport)> = pairs
        .par_iter()
        .map(|&(i, j)| pair_ties(frames, i, j, fo.patch, ground))
        .collect::<Result<_, Error>>()?;
    let cams: Vec<&Camera> = rec.camera_of.iter().map(|&c| &rec.cameras[c]).collect();
    let mut reports = Vec::with_capacity(matched.len());
    let mut ties = Vec::new();
    for (t, mut r) in matched {
        r.misalignment_before_m = misalignment(&t, &rec.poses, &cams);
        ties.extend(t);
        reports.push(r);
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
    if !adjusted.report.converged {
        return Err(Error::Invalid(format!(
            "the flight adjustment did not converge in {} iterations (rms {:.2} px); nothing written",
            adjusted.report.iterations, adjusted.report.rms_after_px
        )));
    }
    let mut round = Round {
        reports,
        adjusted,
        ties: Vec::new(),
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

/// Frame `f` rendered again on the matching grid with another pose and camera (its frame
/// pixels, and so its tie observations, stay those of the photo).
fn rerender(
    f: Frame,
    pose: Pose,
    camera: &Camera,
    opts: &DroneOptions,
    world: &Projection,
) -> Result<Frame, Error> {
    let file = f.input.display().to_string();
    let image = aerorect_io::read_image(&f.input)?;
    let gray = AnyRaster::F32(crate::motion::gray(&image)?);
    drop(image);
    let ground = frame_ground(&f, opts);
    let req = OrthoRequest {
        camera,
        pose,
        world,
        ground: &ground,
        gsd_m: f.coarse_plan.grid.gsd,
        limits: aerorect_core::RectifyLimits {
            max_output_px: 4_000_000,
        },
        occlusion: false,
    };
    let warp = WarpOptions {
        interp: Interp::Bilinear,
        nodata: f64::NAN,
        alpha: false,
    };
    let coarse_plan = plan_ortho(&req, warp).map_err(|e| Error::Invalid(format!("{file}: {e}")))?;
    let AnyRaster::F32(coarse) = coarse_plan.run(&gray)? else {
        return Err(Error::Invalid(format!("{file}: gray ortho is not f32")));
    };
    Ok(Frame {
        coarse,
        coarse_plan,
        ..f
    })
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
        None => Ground::Flat(f.info.pose.centre[2] - f.info.height_m),
    }
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
                frame: f
                    .input
                    .file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                x: p.centre[0],
                y: p.centre[1],
                z: p.centre[2],
                omega: opk[0],
                phi: opk[1],
                kappa: opk[2],
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

impl AdjustedFlight {
    /// Frame `k`'s ortho plan with its adjusted pose and camera on the output grid (`opts`'s
    /// GSD, else the frame's own at nadir).
    pub fn plan(&self, k: usize, opts: &DroneOptions) -> Result<OrthoPlan, Error> {
        let f = &self.frames[k];
        let file = f.input.display().to_string();
        let ground = frame_ground(f, opts);
        // `info.gsd_m` is the matching grid's; the frame's own is its height over fx.
        let own_gsd = f.info.height_m / f.info.camera.camera.intrinsics.fx;
        let req = OrthoRequest {
            camera: &self.cameras[k],
            pose: self.poses[k],
            world: &self.world,
            ground: &ground,
            gsd_m: opts.gsd_m.unwrap_or(own_gsd),
            limits: opts.limits,
            occlusion: opts.occlusion,
        };
        plan_ortho(&req, opts.warp).map_err(|e| Error::Invalid(format!("{file}: {e}")))
    }

    /// The level ground under frame `k` as planned from its metadata.
    fn ground_z(&self, k: usize) -> f64 {
        let f = &self.frames[k];
        f.info.pose.centre[2] - f.info.height_m
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
                    height_m: c[2] - self.ground_z(k),
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
        let t = std::time::Instant::now();
        let f = &self.frames[k];
        let image = aerorect_io::read_image(&f.input)?;
        let plan = self.plan(k, opts)?;
        let out = plan.run(&image)?;
        let mut info = f.info.clone();
        info.pose = self.poses[k];
        info.geo = georeference(self.crs.clone(), &plan, &opts.warp);
        info.gsd_m = plan.grid.gsd;
        info.warnings.extend(plan.warnings.iter().cloned());
        crate::drone::stage_output(staged, output, &out, &info.geo, opts.cog.as_ref())?;
        Ok(crate::drone::PhotoResult {
            input: f.input.display().to_string(),
            output: output.display().to_string(),
            input_size: [image.size().width, image.size().height],
            output_size: [plan.grid.size.width, plan.grid.size.height],
            footprint_en: plan.footprint.clone(),
            info,
            seconds: t.elapsed().as_secs_f64(),
            thumbnails: None,
        })
    }

    /// A gray overview of the flight on the matching grid, each cell the mean of the frames
    /// that see it (as rendered for the last matching round), stretched to 8 bits between its
    /// 1st and 99th percentiles; cells no frame sees are black.
    pub fn overview(&self) -> Result<Raster<u8>, Error> {
        let grids: Vec<_> = self.frames.iter().map(|f| f.coarse_plan.grid).collect();
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
        for (f, g) in self.frames.iter().zip(&grids) {
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
