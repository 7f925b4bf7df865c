//! Joint adjustment of a flight: small attitude corrections per frame (and optionally position
//! corrections), focal length and principal point per camera, from tie points seen in several
//! frames, with priors on the recorded attitude and position and a robust (Huber) loss.
//!
//! Tie points' ground positions are unknowns too; with a terrain they are held near it by a
//! height observation. Ground control points are tie points held to their surveyed position
//! instead (one image mark is enough), and with them the datum of the recorded positions (a
//! common shift, or a similarity) is solved rather than spread into the attitudes. They are eliminated block by block (Schur complement), and the reduced
//! system over frames and cameras, sparse because frames only meet their neighbours, is solved
//! with faer's sparse Cholesky: it scales to thousands of frames.
//!
//! Frame model: `world_from_camera = Rot(w) * R0 * Rot(b)` (w a rotation vector in world
//! axes, b the camera's boresight rotation in its own axes), `centre = C0 + dc`; camera: fx,
//! fy scaled by (1 + s), principal point moved by (du, dv), and radial terms dk1, dk2 added to
//! the lens's own (`q + n (dk1 r^2 + dk2 r^4)` for ideal normalised `n`, `r = |n|`: exactly
//! OpenCV's k1, k2 moved by dk1, dk2 when the lens has no rational terms).
//! Camera frame as in `aerorect_core::camera` (x right, y up, z back).
//!
//! Files: `blocks` (the named parameter blocks and their indices), `residuals` (the model and
//! the cost), `jacobian` (each frame posed once per state, `Posed`, and the analytic derivatives; `oracle` checks them against central
//! differences), `points` (ground points through the adjusted frames), `solve` (normal equations, Schur complement, the loop's steps), `normal` (the reduced system's
//! matrix, accumulated in dense blocks per pair of parameter blocks), `gauge`
//! (freedoms the ties cannot see), `report` (statistics and the adjusted frames),
//! `corrections` (a solve's result as the next one's start).
//! The loop is the crate's one Levenberg-Marquardt ([`crate::lm`]), stopped by Ceres's
//! tolerances ([`AdjustOptions::tolerances`]); after each step, the tie points with an
//! observation in Huber's linear arm are moved to their own minimum (`polish`: the loop's
//! weighted steps alone let them slide for tens of iterations).

mod blocks;
mod corrections;
mod gauge;
mod jacobian;
mod linear;
mod normal;
#[cfg(test)]
mod oracle;
mod points;
mod polish;
mod report;
mod residuals;
mod schur;
mod solve;

pub use crate::lm::{Termination, Tolerances};
pub use corrections::Corrections;
pub use gauge::{GaugeHold, ONE_POINT_RATIO, connected, connected_by, one_point};
pub use points::{OrientedFrames, PosedFrames};
pub use residuals::radial_refinable;

use crate::SolveError;
use aerorect_core::{Camera, Mat3, Vec3};
use blocks::{CameraBlock, DatumBlock, DatumParam, FrameBlock, FrameParam, Layout, State};
use residuals::Problem;
use serde::Serialize;

/// One frame's recorded exterior orientation and its camera.
#[derive(Debug, Clone)]
pub struct AdjustFrame {
    pub camera: usize,
    pub centre: [f64; 3],
    pub world_from_camera: Mat3,
    /// This frame's position prior (m, per world axis) when positions are adjusted, e.g. the
    /// receiver's own RTK standard deviations; `None` takes [`AdjustOptions::position_sigma_m`].
    pub position_sigma_m: Option<[f64; 3]>,
    /// This frame's attitude prior (degrees, each axis), e.g. wide for a photo that recorded
    /// none; `None` takes [`AdjustOptions::attitude_sigma_deg`].
    pub attitude_sigma_deg: Option<f64>,
}

impl AdjustFrame {
    /// This frame's position prior (m, per world axis): its own, else `flight_m` on each.
    pub fn position_sigma_or(&self, flight_m: f64) -> [f64; 3] {
        self.position_sigma_m.unwrap_or([flight_m; 3])
    }
}

/// A tie point's observation in one frame (observed pixel, with the matcher's confidence as a
/// relative weight in (0, 1]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub frame: usize,
    pub pixel: [f64; 2],
    pub weight: f64,
}

/// A point seen in two or more frames (one or more for ground control), with a first guess
/// of its ground position.
#[derive(Debug, Clone, PartialEq)]
pub struct TiePoint {
    pub ground: [f64; 3],
    pub observations: Vec<Observation>,
    /// The surveyed position of a ground control point; `None` for a tie point.
    pub control: Option<Control>,
}

/// A ground control point's surveyed position and its standard deviation per world axis (m).
/// It holds the point instead of the terrain.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Control {
    pub ground: [f64; 3],
    pub sigma_m: [f64; 3],
}

/// How the frame of the recorded positions may differ from the ground control's: with ground
/// control, consumer GPS shares an offset of metres across a block, which must be solved, not
/// spread into the attitudes. Only used when positions are adjusted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum Datum {
    /// The recorded positions are in the control's frame.
    #[default]
    Recorded,
    /// A common shift of every recorded position.
    Shift,
    /// A similarity: shift, a small rotation and a scale about the frames' centroid (three
    /// or more control points).
    Similarity,
}

/// The terrain's height at (x, y) of the world frame.
pub type HeightFn<'a> = &'a (dyn Fn(f64, f64) -> f64 + Sync);

/// What is solved for, and how strongly the records hold.
#[derive(Clone)]
pub struct AdjustOptions<'a> {
    /// Standard deviation of the recorded attitude (each axis), degrees.
    pub attitude_sigma_deg: f64,
    /// Position corrections with this prior standard deviation (metres) where a frame gives
    /// none of its own; `None` keeps positions.
    pub position_sigma_m: Option<f64>,
    pub refine_focal: bool,
    pub refine_principal_point: bool,
    /// Radial distortion k1, k2 per camera (only for a camera with no lens model or OpenCV's
    /// without rational terms; others keep their lens as it is).
    pub refine_radial: bool,
    /// A boresight rotation per camera (the attitude priors hold each frame's own correction
    /// near zero, so what all frames of a camera share goes here).
    pub refine_boresight: bool,
    /// Standard deviation of a tie point's image position, pixels.
    pub pixel_sigma: f64,
    /// Huber threshold, in units of `pixel_sigma`.
    pub huber: f64,
    /// Terrain height at (x, y) and its standard deviation (m): tie points stay on the ground.
    pub terrain: Option<(HeightFn<'a>, f64)>,
    /// The terrain's standard deviation (m) per frame, instead of the one in
    /// [`Self::terrain`]: a tie point takes its first observation's frame's (a flight without
    /// a DEM holds ties to its level ground less firmly where the GPS fixes a block's tilt).
    pub terrain_sigma_by_frame: Option<&'a [f64]>,
    pub max_iterations: usize,
    /// The stops on the cost's relative decrease, the gradient and the step (Ceres's).
    pub tolerances: Tolerances,
    /// What is solved between the recorded positions' frame and the control's.
    pub datum: Datum,
    /// The datum shift's prior standard deviation (m; east, north, up in the positions'
    /// frame): weak (1 km) where ground control decides it; without control, about a GPS
    /// fix's over the root of the frames' count, so that the block stays where its GPS puts it
    /// while single fixes are taken robustly (and weak in height where the fixes drift: see
    /// the flight's `robust_gps`).
    pub datum_shift_sigma_m: [f64; 3],
    /// GPS fixes the images contradict: each frame's position prior (relative to the datum)
    /// takes Huber's loss at this many of its sigmas; `None` keeps it quadratic.
    pub position_huber: Option<f64>,
    /// Each frame's time in the flight, for a GPS drift linear in time solved with a free
    /// [`Self::datum`]: frame `f`'s recorded position belongs `drift t_f` further (on top of
    /// the datum's shift). The times are taken as given (the flight passes its frames' order,
    /// centred and scaled to -0.5..0.5, so that the drift is metres over the flight). Consumer
    /// GPS drifts: on one GPS-only flight the altitude climbed 110 m while the images held it
    /// within 40 m. `None` (or a datum held as recorded) solves no drift.
    pub gps_drift_times: Option<&'a [f64]>,
    /// Where the solve starts: a previous adjustment's corrections of the same frames and
    /// cameras (its [`Adjusted::corrections`]; the priors stay on the recorded values). A
    /// flight's later rounds start where the last ended, so they need a few iterations, not
    /// the whole way from the recorded attitudes again. `None` starts at the recorded values.
    pub start: Option<&'a Corrections>,
    /// From a warm [`Self::start`] (or in a Huber stage after the first, which starts at the
    /// last stage's minimum), also stop when an accepted step turns no frame by this
    /// many degrees (and moves no centre by a millimetre, no camera parameter by a
    /// millionth): with Huber's loss the cost's last relative decreases of 1e-6 took 42
    /// iterations on a 1,000-frame block, turning frames by far less than their precision
    /// (measured before the tie points in Huber's linear arm were polished after each step,
    /// `polish`, which removed most of that crawl). The same crawl in a cold solve's last
    /// stage: the 1,000-frame simulation's first round, on guided feature ties, took 13
    /// iterations there at relative decreases of 1e-5 to 1e-6 (now 4, the flight's attitude
    /// error unchanged). `None`: the tolerances alone.
    pub settled: Option<f64>,
    /// Whether the report gives each parameter's standard deviation (NaN when not): the
    /// inverse of the reduced system, column by column. A solve whose report nobody reads
    /// (a flight's intermediate rounds) skips it: on the 1,000-frame fixed-wing simulation
    /// 1.7 s of a round's 9 s.
    pub standard_deviations: bool,
}

impl Default for AdjustOptions<'_> {
    fn default() -> Self {
        Self {
            attitude_sigma_deg: 1.0,
            position_sigma_m: None,
            refine_focal: true,
            refine_principal_point: true,
            refine_radial: false,
            refine_boresight: false,
            pixel_sigma: 0.5,
            huber: 3.0,
            terrain: None,
            terrain_sigma_by_frame: None,
            max_iterations: 50,
            tolerances: Tolerances::default(),
            datum: Datum::Recorded,
            datum_shift_sigma_m: [1000.0; 3],
            position_huber: None,
            gps_drift_times: None,
            start: None,
            settled: None,
            standard_deviations: true,
        }
    }
}

/// The corrections and statistics of one frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameAdjustment {
    /// The rotation correction (world axes), degrees, and its standard deviation.
    pub rotation_deg: [f64; 3],
    pub rotation_sigma_deg: [f64; 3],
    pub position_m: [f64; 3],
    pub position_sigma_m: [f64; 3],
    /// Where the solved datum (its shift, rotation, scale and drift) moves this frame's
    /// recorded position (0 without a datum): `position_m` less this is what the images moved
    /// the fix beyond what the whole flight's GPS shares.
    pub datum_offset_m: [f64; 3],
    pub observations: usize,
    pub rms_before_px: f64,
    pub rms_after_px: f64,
    /// Observations the robust loss down-weighted (residual above the Huber threshold).
    pub outliers: usize,
    /// The weight the robust position prior left this frame's recorded position (1: held in
    /// full; below: the images contradict it).
    pub position_weight: f64,
}

/// The corrections of one camera.
#[derive(Debug, Clone, Serialize)]
pub struct CameraAdjustment {
    pub focal_scale: f64,
    pub focal_scale_sigma: f64,
    pub principal_point_shift_px: [f64; 2],
    pub principal_point_sigma_px: [f64; 2],
    /// What was added to the lens's k1, k2.
    pub radial_k1_k2: [f64; 2],
    pub radial_sigma: [f64; 2],
    /// The boresight rotation (camera axes), degrees.
    pub boresight_deg: [f64; 3],
    pub boresight_sigma_deg: [f64; 3],
}

/// The result of an adjustment.
#[derive(Debug, Clone, Serialize)]
pub struct AdjustReport {
    pub frames: Vec<FrameAdjustment>,
    pub cameras: Vec<CameraAdjustment>,
    pub tie_points: usize,
    pub observations: usize,
    pub iterations: usize,
    /// Whether a tolerance stopped the solve (else the iteration limit did, or no step
    /// lowered the cost from the start).
    pub converged: bool,
    /// Why the solve stopped.
    pub termination: Termination,
    /// Gauge freedoms found and held before solving.
    pub gauge: Vec<GaugeHold>,
    /// The datum solved between the recorded positions and the ground control.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub datum: Option<DatumAdjustment>,
    pub rms_before_px: f64,
    pub rms_after_px: f64,
    pub seconds: f64,
}

/// The datum between the recorded positions' frame and the ground control's (or the images'):
/// a recorded position `c` at time `t` belongs at
/// `c + shift + rotation x (c - centroid) + scale (c - centroid) + drift t`.
#[derive(Debug, Clone, Serialize)]
pub struct DatumAdjustment {
    pub model: Datum,
    pub centroid: [f64; 3],
    pub shift_m: [f64; 3],
    pub shift_sigma_m: [f64; 3],
    pub rotation_deg: [f64; 3],
    pub rotation_sigma_deg: [f64; 3],
    pub scale_ppm: f64,
    pub scale_sigma_ppm: f64,
    /// The GPS drift, where one was solved ([`AdjustOptions::gps_drift_times`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift: Option<GpsDrift>,
}

/// A GPS drift linear in time, per unit of [`AdjustOptions::gps_drift_times`] (a flight's
/// times span one unit, so over the flight: its last frame's recorded position belongs
/// `over_flight_m` further than its first's, beyond the datum's shift), each axis with its
/// standard deviation.
#[derive(Debug, Clone, Serialize)]
pub struct GpsDrift {
    pub over_flight_m: [f64; 3],
    pub sigma_m: [f64; 3],
}

/// The adjusted orientation of every frame and camera.
#[derive(Debug, Clone)]
pub struct Adjusted {
    pub frames: Vec<AdjustFrame>,
    pub cameras: Vec<Camera>,
    pub report: AdjustReport,
    /// The corrections as the solver holds them (a later solve's start).
    pub corrections: Corrections,
}

/// Adjusts the frames and cameras to the tie points.
pub fn adjust(
    frames: &[AdjustFrame],
    cameras: &[Camera],
    ties: &[TiePoint],
    opts: &AdjustOptions<'_>,
) -> Result<Adjusted, SolveError> {
    let t0 = std::time::Instant::now();
    check_input(frames, cameras, ties, opts.gps_drift_times)?;
    let mut positions_free = vec![opts.position_sigma_m.is_some(); frames.len()];
    let gauge: Vec<GaugeHold> = match opts.position_sigma_m {
        Some(sigma) => gauge::one_point_sets(frames, ties, sigma),
        None => Vec::new(),
    };
    for g in &gauge {
        for &f in &g.frames {
            positions_free[f] = false;
        }
    }
    let datum = if positions_free.iter().any(|&f| f) {
        opts.datum
    } else {
        Datum::Recorded
    };
    let layout = Layout::new(
        frames.len(),
        cameras.len(),
        |f, p| matches!(p, FrameParam::Rotation(_)) || positions_free[f],
        |c, p| Problem::camera_free(opts, &cameras[c], p),
        |p| match (datum, p) {
            (Datum::Recorded, _) => false,
            (_, DatumParam::Drift(_)) => opts.gps_drift_times.is_some(),
            (Datum::Shift, DatumParam::Shift(_)) => true,
            (Datum::Shift, _) => false,
            (Datum::Similarity, _) => true,
        },
    );
    let centroid =
        frames.iter().map(|f| Vec3::from(f.centre)).sum::<Vec3>() / frames.len().max(1) as f64;
    let mut p = Problem {
        frames,
        cameras,
        ties,
        layout,
        opts,
        huber: opts.huber,
        centroid,
    };
    let start: Vec<Vec3> = ties.iter().map(|t| Vec3::from(t.ground)).collect();
    let mut s = State {
        frames: vec![FrameBlock::default(); frames.len()],
        cameras: vec![CameraBlock::default(); cameras.len()],
        datum: DatumBlock::default(),
        points: start.clone(),
    };
    // Held positions keep their first value: a one-point set's, its fixes' mean.
    for (g, at) in gauge
        .iter()
        .filter_map(|g| Some((g, Vec3::from(g.held_at?))))
    {
        for &f in &g.frames {
            s.frames[f].position = at - Vec3::from(frames[f].centre);
        }
    }
    let before = p.rms(&s);
    if p.cost(&s).is_none() {
        return Err(SolveError::Degenerate);
    }
    let (s, rms_start, warm) = warm_start(&p, s, before.1);
    let damping = if warm {
        WARM_START_DAMPING
    } else {
        crate::lm::INITIAL_DAMPING
    };
    // Frames far from their ties (hundreds of pixels, an attitude recorded degrees off) put
    // every residual in Huber's linear arm, where the steps crawl: the threshold starts wide
    // enough to hold the typical residual and narrows fourfold per stage to its own.
    // Each stage starts where the last ended; the report is the last stage's.
    let mut out = crate::lm::Outcome {
        state: s,
        iterations: 0,
        termination: Termination::MaxIterations,
    };
    let mut storage = solve::Storage::default();
    for (stage, huber) in huber_stages(opts.huber, rms_start / opts.pixel_sigma)
        .into_iter()
        .enumerate()
    {
        p.huber = huber;
        let mut solver = solve::Solver {
            problem: &p,
            start: start.clone(),
            storage,
            // A later stage starts at the last one's minimum, near its own.
            settled: opts.settled.filter(|_| warm || stage > 0),
        };
        out = crate::lm::minimise_damped(
            &mut solver,
            out.state,
            opts.max_iterations,
            opts.tolerances,
            damping,
        );
        if out.termination == Termination::Failed {
            return Err(SolveError::Degenerate);
        }
        storage = solver.storage;
    }
    let fit = report::Fit {
        before,
        after: p.rms(&out.state),
        sigmas: match opts.standard_deviations {
            true => report::standard_deviations(&p, &out.state, storage),
            false => report::unknown_deviations(&p),
        },
        iterations: out.iterations,
        termination: out.termination,
        gauge,
        t0,
        position_weights: (0..frames.len())
            .map(
                |f| match positions_free[f] && opts.position_huber.is_some() {
                    true => p.position_weight(&out.state, f).0,
                    false => 1.0,
                },
            )
            .collect(),
    };
    Ok(report::finish(&p, &out.state, fit))
}

/// The damping a solve from [`AdjustOptions::start`] starts with: near the minimum the
/// Gauss-Newton step is good, and at the loop's usual 1e-3 the 1,000-frame simulated block
/// took 42 iterations from its last round's corrections to meet the function tolerance
/// (measured before `polish`).
const WARM_START_DAMPING: f64 = 1e-8;

/// The state [`AdjustOptions::start`] gives (its free parameters; the held ones stay at
/// zero), its overall RMS and true, where its cost is defined; else `s` (the recorded
/// values, of overall RMS `rms`) and false.
fn warm_start(p: &Problem<'_>, s: State, rms: f64) -> (State, f64, bool) {
    let Some(c) = p.opts.start else {
        return (s, rms, false);
    };
    if c.frames.len() != s.frames.len() || c.cameras.len() != s.cameras.len() {
        return (s, rms, false);
    }
    let from = State {
        frames: c.frames.clone(),
        cameras: c.cameras.clone(),
        datum: c.datum,
        points: Vec::new(),
    };
    let mut warm = s.clone();
    for (_, q) in p.layout.free() {
        *q.value_mut(&mut warm) = q.value(&from);
    }
    if p.cost(&warm).is_none() {
        return (s, rms, false);
    }
    // The tie points' first guesses are on the ground where the recorded (or last round's)
    // rays meet it; moved to where the corrected frames put them (each point alone, the
    // frames held), the start's residuals are the frames', and its Huber stages follow them.
    for _ in 0..WARM_POINT_PASSES {
        let Some(blocks) = p.point_blocks(&warm) else {
            break;
        };
        let moved = move_points(&warm, &blocks);
        if p.cost(&moved).is_none() {
            break;
        }
        warm = moved;
    }
    let rms_warm = p.rms(&warm).1;
    (warm, rms_warm, true)
}

/// Gauss-Newton passes over the tie points alone at a warm start.
const WARM_POINT_PASSES: usize = 3;

/// `s` with every tie point moved by its own Gauss-Newton step (the frames and cameras
/// held): `H_pp^-1 b_p`, where `H_pp` is invertible.
fn move_points(s: &State, blocks: &[(Mat3, Vec3)]) -> State {
    let mut out = s.clone();
    for (x, (hpp, bp)) in out.points.iter_mut().zip(blocks) {
        if let Some(inv) = hpp.try_inverse() {
            *x += inv * bp;
        }
    }
    out
}

/// The Huber thresholds of the stages: `last` alone when the typical residual (`rms`, sigma
/// units) is within it, else from about the residual down to `last` by factors of four.
fn huber_stages(last: f64, rms: f64) -> Vec<f64> {
    let mut stages = vec![last];
    let mut k = last;
    while rms.is_finite() && k * 4.0 < rms && stages.len() < 8 {
        k *= 4.0;
        stages.push(k);
    }
    stages.reverse();
    stages
}

fn check_input(
    frames: &[AdjustFrame],
    cameras: &[Camera],
    ties: &[TiePoint],
    drift_times: Option<&[f64]>,
) -> Result<(), SolveError> {
    if let Some(t) =
        drift_times.filter(|t| t.len() != frames.len() || t.iter().any(|v| !v.is_finite()))
    {
        return Err(SolveError::DriftTimes {
            got: t.len(),
            frames: frames.len(),
        });
    }
    if let Some((frame, f)) = frames
        .iter()
        .enumerate()
        .find(|(_, f)| f.camera >= cameras.len())
    {
        return Err(SolveError::UnknownCamera {
            frame,
            camera: f.camera,
            cameras: cameras.len(),
        });
    }
    for (index, t) in ties.iter().enumerate() {
        if let Some(why) = tie_problem(t, frames.len()) {
            return Err(SolveError::BadTie { index, why });
        }
    }
    Ok(())
}

/// Why the adjustment cannot take tie point `t` (with `frames` frames), if it cannot.
fn tie_problem(t: &TiePoint, frames: usize) -> Option<String> {
    let fewest = if t.control.is_some() { 1 } else { 2 };
    if t.observations.len() < fewest {
        return Some(format!(
            "{} view(s), at least {fewest} needed",
            t.observations.len()
        ));
    }
    if let Some(c) = &t.control
        && !(c.ground.iter().all(|v| v.is_finite())
            && c.sigma_m.iter().all(|s| s.is_finite() && *s > 0.0))
    {
        return Some("its surveyed position or deviation is not a finite (positive) number".into());
    }
    if let Some(o) = t.observations.iter().find(|o| o.frame >= frames) {
        return Some(format!("a view in frame {}, of {frames} frames", o.frame));
    }
    if t.observations.iter().any(|o| {
        o.weight.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            || !o.pixel.iter().all(|v| v.is_finite())
    }) {
        return Some("a view's pixel is not finite or its weight is not positive".into());
    }
    if !t.ground.iter().all(|v| v.is_finite()) {
        return Some("its first ground guess is not finite".into());
    }
    None
}
