//! A flight made consistent from its own overlaps. The first round ties the photos by SIFT
//! features (no attitude needed; a fundamental matrix and one loose homography verify each
//! pair); the adjustment (`aerorect_solve::adjust`) corrects attitudes (and optionally
//! positions) and the cameras. Later rounds rectify every frame with the last round's
//! orientation onto one coarse ground grid and match overlapping frames there by phase
//! correlation of patches (the ortho removes most of the perspective between look
//! directions); RANSAC keeps the matches one homography explains, each becomes a tie point
//! (its frame pixels through each frame's own ortho map), and where correlation ties a pair
//! its ties replace the pair's features in the rounds; over a DEM the solve that ends them
//! takes both, each weighed by its own agreement. Where the features round's ties agree at
//! least as well as correlation's on a sample of its pairs, no correlation round is run.
//!
//! One file per stage: `frames` (the photos and their first orientation), `features` (the
//! first round's tie points from SIFT features, which need no attitude; `guide` narrows each
//! pair's search where the recorded orientation bounds it), `correlate` (the
//! later rounds' tie points, by correlation of the frames rendered on one grid), `ties` (a
//! pair's tie points as the adjustment takes them), `sources` (the two sources' weights in
//! the solve that ends the rounds), `solve` (a round's adjustment), `checks`
//! (the GPS fixes and recorded attitudes against the images after it), `plan`
//! (the steps as pure functions, for Dask), `exchange` (what travels between processes),
//! `roll` (senseFly's roll sign, by the first round's ties), `render` (the adjusted frames
//! onto the output grid, over the DEM, else `surface`: the ground the adjusted tie points
//! describe, else the level ground), `control` (ground control points as
//! tie points held to their surveyed positions) and `accuracy` (the report against them).

mod accuracy;
mod batch;
mod checks;
mod control;
mod correlate;
mod decoded;
mod drift;
mod exchange;
mod features;
mod frames;
mod guide;
mod plan;
mod predict;
mod relief;
mod relook;
mod render;
mod roll;
pub mod sift;
mod solve;
mod sources;
mod steps;
mod surface;
mod ties;
pub(crate) mod timing;

pub use accuracy::{
    ASPRS_HORIZONTAL_CLASSES_CM, AccuracyReport, AsprsClass, MarkResidual, PointAccuracy, Rmse,
    asprs_class,
};
pub use batch::{ACCURACY_FILE, ADJUSTMENT_FILES, adjustment_files};
pub use checks::{BlockReport, GpsCheck};
pub use control::{ControlOptions, MARK_SIGMA_PX, Role, SURVEY_SIGMA_M};
pub use exchange::{exact_json, from_exact_json};
pub use features::{FEATURE_TIES_PER_PAIR, MIN_FEATURE_INLIERS, TieSource, in_steps};
pub use guide::{
    GUIDE_RETRY_OVERLAP, GUIDE_SIGMAS, GUIDE_SLACK_PX, MAX_GUIDE_FRACTION, MIN_GUIDE_FRACTION,
};
pub use plan::{FlightPlan, FlightProgress, Orientation};
pub use predict::{MarkPrediction, chip};
pub use render::AdjustedFlight;
pub use roll::{FLIP_MARGIN, RollChoice, RollTrial};
pub use sources::SourceWeights;
pub use steps::{
    Basis, FIRST_STEP_KEYPOINTS, FIRST_STEP_NEIGHBOURS, MIN_STEPPED_FRAMES,
    STEPPED_ATTITUDE_SIGMA_DEG, STEPPED_POSITION_SIGMA_M, StepGuide,
};
pub use surface::{
    MIN_SURFACE_KEPT, MIN_SURFACE_POINTS, SURFACE_CELL_M, SURFACE_MAX_RESIDUAL_PX, SURFACE_NAME,
    SurfaceReport, TieSurface, tie_surface,
};
pub use ties::{FEATURE_SPARE_CELLS, PairMatch, PairTie, TieVector};

use checks::*;
use correlate::*;
use frames::*;
use render::*;
use solve::*;
use ties::*;

use crate::Error;
use crate::drone::{DroneOptions, DronePlanInfo, georeference, plan_from_metadata};
use crate::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use aerorect_core::{Camera, ImageSize};
use aerorect_geo::{Crs, OrthoGrid, Pose};
use aerorect_io::PhotoMetadata;
use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
use aerorect_raster::{AnyRaster, Interp, Raster, WarpOptions};
use aerorect_solve::adjust::{
    AdjustFrame, AdjustOptions, AdjustReport, Corrections, Datum, Observation, TiePoint,
};
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
    /// from round to round without the others moving), when the features hold the solve
    /// that ends them ([`SourceWeights::features_hold`]), or when from the third round on a
    /// round's turn is not below half the smallest before it (they oscillate: reported so).
    /// At most [`MAX_PASSES`].
    pub passes: usize,
    /// `None` (the default): the turn that moves the median frame's ground by
    /// [`SETTLED_GRID_PX`] of the matching grid (see [`FlightPlan::settled_deg`]).
    pub settled_deg: Option<f64>,
    /// Where the tie points come from (features first, then correlation, by default).
    pub ties: TieSource,
    /// Ground control points and check points.
    pub control: Option<ControlOptions>,
    /// Without ground control, take each GPS fix robustly (Huber at three sigmas) about the
    /// block's common shift from the first solve, so that a fix the images contradict is
    /// down-weighted. Off by default, where a round's solve takes the fixes quadratically and
    /// only when that leaves some fix contradicted solves again robustly
    /// ([`relook::Relook`]): on a simulated block the quadratic 5 m prior already lets the ties
    /// move a single fix 40 m off back within the block's common 3 m, and on the senseFly
    /// photos (no fix contradicted) robust fixes from the start moved the oscillating rounds'
    /// end on 2281/2282 from 1.2 to 5.1 px; a GPS that drifts bends a block quadratically
    /// (110 m up over the simulated fixed wing: 0.41 deg from the truth, 0.10 deg robustly).
    pub robust_gps: bool,
    /// Without a DEM, render the adjusted frames over the ground the flight's own tie points
    /// describe ([`tie_surface`]) instead of the level ground, when at least
    /// [`MIN_SURFACE_POINTS`] of them, and [`MIN_SURFACE_KEPT`] of all, intersect within
    /// [`SURFACE_MAX_RESIDUAL_PX`]. On by
    /// default: on the senseFly photos over hills the level ground left consecutive frames
    /// 1.5-2.3 px apart by their relief's parallax. A DEM, when given, is always the ground.
    /// In a flight matched in two steps it also guides the second step over the surface of
    /// the first step's ties ([`StepGuide::surface`]).
    pub tie_surface: bool,
    /// Once the rounds are done (settled, at [`FlightOptions::passes`], or features alone),
    /// solve once more, from the last round's solution and on the last round's matches, with
    /// every reliable tie of each pair ([`PairMatch::spare`] too: correlation's beyond its 64
    /// spread ties, the untied pairs' feature inliers beyond their 36, thinned by
    /// [`FEATURE_SPARE_CELLS`]) instead of the capped ones, and over a DEM the features
    /// of the pairs correlation tied too, each source weighed by its own agreement
    /// ([`SourceWeights`]); its orientation is the flight's. Rounds that stop without settling (oscillating,
    /// or at the cap) end the same way: the last round's matches are solved again. The rounds'
    /// own solves stay capped for speed, and whether they settled is judged on them (the
    /// final solve's own turn is in [`RoundSummary::final_solve`]).
    ///
    /// Why: only the GPS, the attitude priors and the DEM heights under the ties hold a
    /// block's common heading, and the caps dropped a third of that DEM information. On the
    /// simulated 100-frame flights (`bench/sim_flight.py 10 10`, attitude error against the
    /// truth, median / max degrees): fixed wing with 5-degree attitudes 0.164 / 0.311 capped
    /// -> 0.109 / 0.218 (before the caps 0.106 / 0.228), the same flight with GPS alone
    /// 0.083 / 0.304 -> 0.053 / 0.216, the nadir block 0.010 / 0.025 -> 0.007 / 0.024; the
    /// extra solve took about as long as one round's (fixed wing: 36,356 -> 58,036 ties, 14.5 s
    /// and 46 iterations after the four rounds' 60 s of solves, `batch --adjust` 60.7 ->
    /// 75.3 s, the rounds themselves unchanged to the bit; nadir block 10.1 -> 11.2 s). On
    /// the 1,000-frame nadir block (`40 25`): 0.008 / 0.029 -> 0.006 / 0.026, 217,512 ->
    /// 338,848 ties, 13.7 s more (the rounds' solves 93 s, the whole flight 283 s on two busy
    /// cores; 5.9 s more on quieter ones) and peak memory 1,086 -> 1,390 MB.
    /// Correlation's ties alone (40,454) won back only 0.164 -> 0.161: the feature ties of
    /// the pairs correlation does not tie (strips flown in opposite directions) carry it.
    pub final_all_ties: bool,
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
        if let Some(d) = self.settled_deg
            && !(d.is_finite() && d > 0.0)
        {
            return Err(Error::Invalid(format!(
                "settled turn {} deg: must be > 0",
                aerorect_core::error::Num(d)
            )));
        }
        Ok(())
    }
}

/// Rounds settle once the median frame's turn from the round before moves its ground by less
/// than this many pixels of the matching grid (at the frame's height above the plan's
/// ground): rendered again, the frames would differ by less than the correlator resolves, so
/// another round would measure the same ties. On the 1,000-frame simulation (0.25 m grid,
/// 130 m up: 0.011 deg) the second correlation round turned the median frame 0.0054 deg, the
/// third (under the old fixed 0.005 deg) 0.0011 deg for no gain: 0.006 / 0.021 deg from the
/// truth after three rounds, 0.005 / 0.019 after two; the fixed-wing 10 x 10 settles in three
/// rounds instead of four, 0.107 / 0.217 -> 0.106 / 0.214 deg. On the DJI nadir pair (0.1 m
/// GSD) it is 0.007 deg.
pub const SETTLED_GRID_PX: f64 = 0.1;

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
            settled_deg: None,
            ties: TieSource::Both,
            control: None,
            robust_gps: false,
            tie_surface: true,
            final_all_ties: true,
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

/// Without a DEM, how far (m, one standard deviation) a tie point's height may leave the
/// level ground: hilly ground under a drone. Correlation ties too: matched on the level
/// ground's orthos, the shift they measure is the relief's parallax, so their two pixels see
/// one point of the hill, not of the level ground. Held to it at 0.1 m, as they once were,
/// three senseFly photos along a strip over hills (2280-2282, relief about 10 m, every pair
/// tied by correlation) shrank with their tie points towards the level plane: the cameras
/// 8 m above the ground instead of 100 m, every GPS fix 91-101 m away, at 0.41 px rms.
pub const RELIEF_SIGMA_M: f64 = 10.0;

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
    /// The last round only: the solve with every reliable tie that ended the rounds (see
    /// [`FlightOptions::final_all_ties`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub final_solve: Option<FinalSolve>,
    /// How well each source's ties agree and the features' weight beside correlation's in the
    /// solve that ends the rounds: over a DEM in a round with correlation ties; in the
    /// features round, on a correlated sample of its pairs (with or without a DEM).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sources: Option<SourceWeights>,
    /// Whether this round ended the rounds because the features agree at least as well as
    /// correlation ([`SourceWeights::features_hold`]): settled for the solve that ends them.
    #[serde(default)]
    pub held_by_features: bool,
}

/// The solve that ends the rounds with every reliable tie
/// ([`FlightOptions::final_all_ties`]): its tie points, residual RMS, how far it turned the
/// frames from the round's capped solve (degrees), and its time.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FinalSolve {
    pub tie_points: usize,
    pub rms_after_px: f64,
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
    /// Whether the last round's median turn was below `settled_deg`; when not,
    /// `oscillating` says whether the turns stopped halving (the last round's median turn
    /// is above half the smallest before it) and a warning lists the turns per round (saying
    /// they oscillate where the last rose above one before it).
    pub settled: bool,
    /// The median turn that settles the rounds ([`FlightPlan::settled_deg`]).
    pub settled_deg: f64,
    pub oscillating: bool,
    /// What the user should know: the matching grid coarsened, passes capped, gauge
    /// freedoms held, a solve kept at its iteration limit, rounds that did not settle.
    pub warnings: Vec<String>,
    pub pairs: Vec<PairReport>,
    /// Frames no reliable pair reaches (left as recorded).
    pub unconnected: Vec<String>,
    /// A flight in separate blocks that share no tie point: each block with its own residual
    /// (empty, and absent from the JSON, for a flight in one piece).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub blocks: Vec<BlockReport>,
    /// Every frame's GPS position against the images (when positions are adjusted).
    pub gps: Vec<GpsCheck>,
    /// The flight against its ground control and check points (with `control`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accuracy: Option<AccuracyReport>,
    /// How senseFly's roll was read when the flight left it to its images.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensefly_roll: Option<RollChoice>,
    /// The ground the frames were rendered over when the flight's tie points made it (no DEM
    /// given, [`FlightOptions::tie_surface`]): how many points, its extent, cell and spread.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceReport>,
    pub adjustment: AdjustReport,
    pub poses: Vec<AdjustedPose>,
    pub seconds: f64,
}

/// Plans, matches and adjusts a flight: [`FlightPlan`]'s steps, each round's frames rendered
/// once and shared by their pairs.
pub fn adjust_flight(
    inputs: &[PathBuf],
    opts: &DroneOptions,
    fo: &FlightOptions,
) -> Result<AdjustedFlight, Error> {
    adjust_flight_for(inputs, opts, fo, true)
}

/// [`adjust_flight`]; `overview`: whether [`AdjustedFlight::overview`] will be asked for.
/// Without it, a flight whose rounds end with the features round is not rendered again (the
/// overview is that render's only use: 3.8 s of the 1,000-frame fixed wing's 58).
pub fn adjust_flight_for(
    inputs: &[PathBuf],
    opts: &DroneOptions,
    fo: &FlightOptions,
    overview: bool,
) -> Result<AdjustedFlight, Error> {
    fo.validate()?;
    let plan = timing::time("plan (wall)", || FlightPlan::new(inputs, opts, fo))?;
    let (features, guide) = timing::time("features round (wall)", || plan.first_round_matches())?;
    let plan = plan.with_sensefly_roll_chosen(&features)?;
    // Frames the features round's source sample rendered with `o` are taken, not rendered
    // again.
    let render_all = |o: Option<&Orientation>,
                      sampled: &mut Option<sources::Sampled>|
     -> Result<Vec<Rendered>, Error> {
        let done: Vec<Option<Rendered>> = (0..plan.len())
            .map(|k| sampled.as_mut().and_then(|s| s.take_rendered(k)))
            .collect();
        timing::time("render (wall)", || {
            done.into_par_iter()
                .enumerate()
                .map(|(k, r)| r.map_or_else(|| plan.render(k, o), Ok))
                .collect()
        })
    };
    let mut progress = plan.first_progress(guide.as_ref());
    if !features.is_empty() {
        let round = plan.adjust_round(&mut progress, features.clone(), fo.final_all_ties)?;
        if progress.done {
            let rendered = match overview {
                true => render_all(progress.orientation.as_ref(), &mut None)?,
                false => Vec::new(),
            };
            timing::print();
            return Ok(plan.finish(progress, round, rendered));
        }
    }
    loop {
        let mut sampled = progress.sampled.take();
        let rendered = render_all(progress.orientation.as_ref(), &mut sampled)?;
        let grids: Vec<OrthoGrid> = rendered.iter().map(|r| r.coarse_plan.grid).collect();
        let pairs: Vec<((usize, usize), Option<PairMatch>)> = overlapping(&grids)
            .into_iter()
            .map(|(i, j)| ((i, j), sampled.as_mut().and_then(|s| s.take_matched(i, j))))
            .collect();
        drop(sampled);
        let mut matched: Vec<PairMatch> = timing::time("correlate (wall)", || {
            pairs
                .into_par_iter()
                .map(|((i, j), m)| match m {
                    Some(m) => Ok(m),
                    None => plan.match_rendered((i, &rendered[i]), (j, &rendered[j])),
                })
                .collect::<Result<_, Error>>()
        })?;
        matched.extend(features.iter().cloned());
        let round = plan.adjust_round(&mut progress, matched, fo.final_all_ties)?;
        if progress.done {
            timing::print();
            return Ok(plan.finish(progress, round, rendered));
        }
    }
}
