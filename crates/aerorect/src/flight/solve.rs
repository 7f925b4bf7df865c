//! One round's adjustment: the pairs' tie points and the frames' priors into
//! `aerorect_solve::adjust`, its warnings and errors, and the rounds' settling.

use super::*;

/// One round of matching and adjustment.
pub(super) struct Round {
    pub(super) reports: Vec<PairReport>,
    pub(super) adjusted: aerorect_solve::adjust::Adjusted,
    pub(super) ties: Vec<TieVector>,
    pub(super) warnings: Vec<String>,
    /// Every adjusted GPS position against the images.
    pub(super) gps: Vec<GpsCheck>,
    /// Against the ground control, when there is some.
    pub(super) accuracy: Option<accuracy::AccuracyReport>,
}

impl Round {
    /// The round's summary; restarts the clock `t`.
    pub(super) fn summary(
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
            final_solve: None,
            sources: None,
            held_by_features: false,
        }
    }

    /// Every frame's adjusted pose and camera.
    pub(super) fn orientation(&self, rec: &Recorded) -> (Vec<Pose>, Vec<Camera>) {
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

/// The whole flight's tilt from its recorded attitudes ([`common_tilt_warning`]), or, with
/// none recorded, that nothing but the GPS heights level a block spread enough for a drift
/// to tilt it ([`unseen_drift_warning`]); `gps_levels`: only the GPS heights level the block
/// its GPS frees, and the frames' order cannot tell a drift in them from a tilt.
fn tilt_warning(
    plan: &FlightPlan,
    adjust_frames: &[AdjustFrame],
    report: &AdjustReport,
    gps_levels: bool,
) -> Option<String> {
    let sigma = plan.fo.attitude_sigma_deg;
    match common_tilt_deg(&plan.frames, adjust_frames, report, sigma) {
        Some(tilt) => common_tilt_warning(tilt, gps_levels),
        None => {
            let centres: Vec<[f64; 3]> = plan.rec.poses.iter().map(|p| p.centre).collect();
            (gps_levels && drift::drift_decided(&centres)).then(unseen_drift_warning)
        }
    }
}

/// Adjusts the recorded orientation to the tie points of the matched pairs (each with its
/// frames' names; `all`: their spare ties too, see [`PairMatch::solve_ties`]; `dem`: the
/// ground is a DEM; `posed`: the frames come from a pose table), the solve starting from
/// `start` (the last solve's corrections) when given; `sigmas`: whether its report gives the
/// standard deviations.
pub(super) fn match_and_adjust(
    (matched, all): (&[(&PairMatch, String, String)], bool),
    plan: &FlightPlan,
    (dem, posed): (bool, bool),
    start: Option<&Corrections>,
    sigmas: bool,
) -> Result<Round, Error> {
    let (rec, fo, frames) = (&plan.rec, &plan.fo, &plan.frames);
    let ground = plan.ground.as_ref();
    let cams: Vec<&Camera> = rec.camera_of.iter().map(|&c| &rec.cameras[c]).collect();
    // Each pair's ties and report, the pairs in parallel (the final solve's 1.6 M ties of the
    // 1,000-frame flight were a second of one core here), then joined in pair order.
    let per_pair: Vec<(PairReport, Vec<TiePoint>)> = matched
        .par_iter()
        .map(|(m, a, b)| pair_ties(m, (a, b), all, (&rec.poses, &cams), ground))
        .collect();
    let mut reports = Vec::with_capacity(matched.len());
    let mut ties = Vec::with_capacity(per_pair.iter().map(|(_, t)| t.len()).sum());
    for (report, t) in per_pair {
        reports.push(report);
        ties.extend(t);
    }
    // Ground control that moves the recorded positions.
    let control = plan
        .control
        .as_ref()
        .filter(|c| c.datum() != Datum::Recorded);
    let position_sigma_m = plan.position_sigma_m(posed);
    let adjust_frames: Vec<AdjustFrame> = rec
        .poses
        .iter()
        .zip(&rec.camera_of)
        .enumerate()
        .map(|(k, (p, &camera))| AdjustFrame {
            camera,
            centre: p.centre,
            world_from_camera: p.world_from_camera(),
            position_sigma_m: plan.own_position_sigma_m(k),
            attitude_sigma_deg: frames[k].own_attitude_sigma_deg(fo.attitude_sigma_deg),
        })
        .collect();
    let relief = (!dem).then(|| plan.relief(&ties));
    let aopts = AdjustOptions {
        attitude_sigma_deg: fo.attitude_sigma_deg,
        position_sigma_m,
        // With the datum free, a nadir block's height and the focal length trade almost
        // freely (on NGI's frames 22 m for 0.46 %, the ground unchanged): the focal length
        // is held as recorded.
        refine_focal: fo.refine_focal && control.is_none(),
        refine_principal_point: fo.refine_principal_point,
        refine_radial: fo.refine_radial,
        refine_boresight: fo.refine_boresight,
        terrain: Some((
            ground,
            // Without a DEM the level ground is a guess: every tie, a feature's or the
            // correlator's, is a real point on the hills (see RELIEF_SIGMA_M).
            terrain_sigma_m(dem),
        )),
        // Where the GPS decides a block's tilt, its ties leave the level ground freely.
        terrain_sigma_by_frame: relief.as_ref().map(|r| r.sigmas_m.as_slice()),
        max_iterations: 100,
        start,
        settled: Some(SOLVE_SETTLED_DEG),
        standard_deviations: sigmas,
        ..AdjustOptions::default()
    };
    let aopts = relook::robust_gps(
        control,
        (position_sigma_m, fo.robust_gps),
        (frames.len(), plan.gps_drift_times()),
        aopts,
    );
    // The control points join the ties for the solve; without control the ties go as they are
    // (no copy of every tie each round).
    let all: std::borrow::Cow<[TiePoint]> = match (control, &fo.control) {
        (Some(c), Some(co)) => {
            let mut all = ties.clone();
            all.extend(c.tie_points(co.mark_sigma_px, aopts.pixel_sigma));
            all.into()
        }
        _ => ties.as_slice().into(),
    };
    let solve = |o: &AdjustOptions| {
        timing::time("solve: adjust", || {
            aerorect_solve::adjust::adjust(&adjust_frames, &rec.cameras, &all, o)
        })
        .map_err(Error::context("flight adjustment"))
    };
    let relook = relook::Relook {
        plan,
        ties: &ties,
        adjust_frames: &adjust_frames,
        relief: relief.as_ref(),
        position_sigma_m,
        control: control.is_some(),
    };
    let (adjusted, relooked) = relook.solve(&aopts, solve)?;
    let accuracy = plan.control.as_ref().map(|c| {
        let recorded = aerorect_solve::adjust::OrientedFrames {
            frames: &adjust_frames,
            cameras: &rec.cameras,
        };
        accuracy::accuracy_report(c, (recorded, adjusted.oriented()), frames, &all)
    });
    let mut warnings = solve_warnings(frames, &adjusted.report)?;
    warnings.extend(relooked);
    warnings.extend(drift::drift_warning(&adjusted.report));
    let gps = gps_checks(frames, &adjust_frames, &adjusted.report, position_sigma_m);
    warnings.extend(contradictions(
        frames,
        &adjust_frames,
        &adjusted.report,
        fo,
        &gps,
    ));
    // Only the GPS heights level a block its GPS frees, and the frames' order cannot tell a
    // drift in them from a tilt.
    let gps_levels = !dem
        && control.is_none()
        && position_sigma_m.is_some()
        && plan.gps_drift_times().is_none()
        && relief.as_ref().is_some_and(|r| !r.freed.is_empty());
    warnings.extend(tilt_warning(
        plan,
        &adjust_frames,
        &adjusted.report,
        gps_levels,
    ));
    let mut round = Round {
        gps,
        accuracy,
        reports,
        adjusted,
        ties: Vec::new(),
        warnings,
    };
    let (poses, cameras) = round.orientation(rec);
    let new_cams: Vec<&Camera> = cameras.iter().collect();
    timing::time("solve: misalignment", || {
        finish_reports(&mut round.reports, &ties, (&poses, &new_cams), ground)
    });
    round.ties = timing::time("solve: tie vectors", || {
        tie_vectors(&ties, (&rec.poses, &cams), (&poses, &new_cams), ground)
    });
    Ok(round)
}

/// A pair's tie points as this solve takes them (`all`: the spare ones too) and its report,
/// with the pair's misalignment under the recorded orientation.
fn pair_ties(
    m: &PairMatch,
    (a, b): (&String, &String),
    all: bool,
    recorded: (&[Pose], &[&Camera]),
    ground: GroundFn<'_>,
) -> (PairReport, Vec<TiePoint>) {
    let t: Vec<TiePoint> = m.solve_ties(all).map(|t| t.tie_point(m.a, m.b)).collect();
    let report = PairReport {
        a: a.clone(),
        b: b.clone(),
        patches: m.patches,
        // The ties this solve takes (each reliable pair's, in order: see `finish_reports`).
        inliers: match m.reliable() {
            true => t.len(),
            false => m.inliers,
        },
        misalignment_before_m: timing::time("solve: misalignment", || {
            misalignment(&t, recorded.0, recorded.1, ground)
        }),
        misalignment_after_m: None,
        reliable: m.reliable(),
    };
    (report, t)
}

/// Each tie's gap on the ground before and after the adjustment (the ties in parallel).
fn tie_vectors(
    ties: &[TiePoint],
    (old_poses, old_cams): (&[Pose], &[&Camera]),
    (poses, cams): (&[Pose], &[&Camera]),
    ground: GroundFn<'_>,
) -> Vec<TieVector> {
    ties.par_iter()
        .filter_map(|t| {
            Some(TieVector {
                ground: [t.ground[0], t.ground[1]],
                before_m: tie_gap(t, old_poses, old_cams, ground)?,
                after_m: tie_gap(t, poses, cams, ground)?,
            })
        })
        .collect()
}

/// The warnings of a solve (gauge freedoms held, an iteration limit met with a sub-pixel
/// RMS), or its error when its own residuals say it failed.
pub(super) fn solve_warnings(
    frames: &[Frame],
    report: &AdjustReport,
) -> Result<Vec<String>, Error> {
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

/// Whether the rounds settled (the last median turn below `settled_deg`, or the features
/// held the solve that ended them: [`RoundSummary::held_by_features`]) and, if not, whether
/// they oscillate ([`oscillates`]).
pub(super) fn settling(rounds: &[RoundSummary], settled_deg: f64) -> (bool, bool) {
    let Some((last, earlier)) = rounds.split_last() else {
        return (true, false);
    };
    if earlier.is_empty() || last.median_turn_deg < settled_deg || last.held_by_features {
        return (true, false);
    }
    (false, oscillates(earlier, last.median_turn_deg))
}

/// Whether a round's median turn `turn` after the `earlier` rounds says the rounds oscillate:
/// it is above half the smallest before it (the turns no longer shrink).
pub(super) fn oscillates(earlier: &[RoundSummary], turn: f64) -> bool {
    let smallest = earlier
        .iter()
        .map(|r| r.median_turn_deg)
        .fold(f64::INFINITY, f64::min);
    turn > 0.5 * smallest
}

/// Rounds before one that can end the rounds by oscillating ([`oscillates`]): the features'
/// round and one correlation round, so that two correlation rounds' turns compare.
pub(super) const OSCILLATION_EARLIER_ROUNDS: usize = 2;

pub(super) fn rounds_warning(
    rounds: &[RoundSummary],
    settled_deg: f64,
    oscillating: bool,
) -> String {
    let turns: Vec<String> = rounds
        .iter()
        .map(|r| format!("{:.3}", r.median_turn_deg))
        .collect();
    // Turns that stopped halving but still shrink are not an oscillation: the 100-frame
    // simulation without a DEM turned its median frame 31.2, 0.060 and 0.054 deg.
    let rising = rounds.split_last().is_some_and(|(last, earlier)| {
        earlier
            .iter()
            .any(|r| last.median_turn_deg > r.median_turn_deg)
    });
    format!(
        "the matching rounds {} in {} rounds: the median frame turned by {} deg per round (largest {:.3} deg in the last), never below {settled_deg:.4} deg; the last round's orientation is kept",
        match (oscillating, rising) {
            (true, true) => "oscillate",
            (true, false) => "stopped halving their turns",
            (false, _) => "did not settle",
        },
        rounds.len(),
        turns.join(", "),
        rounds.last().map_or(0.0, |r| r.largest_turn_deg)
    )
}

/// The frames a failed solve left worst: those with no observation, then the (at most five)
/// largest residual RMS, with it.
pub(super) fn unplaced(frames: &[Frame], report: &AdjustReport) -> String {
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

/// Every frame's adjusted pose as `--poses` reads it (omega-phi-kappa about the grid axes).
pub(super) fn adjusted_poses(
    frames: &[Frame],
    poses: &[Pose],
    cameras: &[Camera],
) -> Vec<AdjustedPose> {
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

pub(super) fn finish_reports(
    reports: &mut [PairReport],
    ties: &[TiePoint],
    (poses, cams): (&[Pose], &[&Camera]),
    ground: GroundFn<'_>,
) {
    // Ties are in pair order; each reliable pair contributed `inliers` of them.
    let mut at = 0;
    let mut pairs: Vec<(&mut PairReport, &[TiePoint])> = Vec::new();
    for r in reports.iter_mut().filter(|r| r.reliable) {
        let n = r.inliers;
        pairs.push((r, &ties[at..at + n]));
        at += n;
    }
    pairs.into_par_iter().for_each(|(r, t)| {
        r.misalignment_after_m = Some(misalignment(t, poses, cams, ground));
    });
}

pub(super) fn unconnected(frames: &[Frame], reports: &[PairReport]) -> Vec<String> {
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

/// The rotation between each pair of poses of the same frames, degrees.
pub(super) fn turns_deg(a: &[Pose], b: &[Pose]) -> Vec<f64> {
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

pub(super) fn largest_turn_deg(a: &[Pose], b: &[Pose]) -> f64 {
    turns_deg(a, b).into_iter().fold(0.0, f64::max)
}

pub(super) fn median_turn_deg(a: &[Pose], b: &[Pose]) -> f64 {
    let mut t = turns_deg(a, b);
    t.sort_by(f64::total_cmp);
    t.get(t.len() / 2).copied().unwrap_or(0.0)
}

/// A round's solve stops when a step turns no frame by this many degrees (a tenth of the
/// rounds' settled turn on the 1,000-frame simulation, 0.011 deg; a fifteenth of the
/// fixed-wing simulation's median attitude error after adjustment, 0.0157 deg). At 1e-4
/// the steps after the first two turned the median frame by 1e-5 degrees for four to seven
/// more iterations, and the 1,000-frame fixed wing ended within 0.0001 deg of where 1e-3
/// leaves it (median / max error 0.0157 / 0.0630 against 0.0156 / 0.0630) in 9 s more.
pub const SOLVE_SETTLED_DEG: f64 = 1e-3;

/// A GPS fix moved by more than this many of its sigmas is contradicted by the images (the
/// Huber threshold of each axis with robust GPS).
pub const GPS_CONTRADICTION_SIGMAS: f64 = 3.0;

/// The standard deviation (m) of the ground's height under a tie: a DEM's, else the level
/// ground's guess ([`RELIEF_SIGMA_M`]).
pub(super) fn terrain_sigma_m(dem: bool) -> f64 {
    match dem {
        true => 1.0,
        false => RELIEF_SIGMA_M,
    }
}

impl FlightPlan {
    /// The recorded positions' prior standard deviation (m) for the frames without their own
    /// (`posed`: the frames come from a pose table); none when they are held.
    pub(super) fn position_sigma_m(&self, posed: bool) -> Option<f64> {
        // Ground control moves the recorded positions, pose tables' too.
        let control = self
            .control
            .as_ref()
            .is_some_and(|c| c.datum() != Datum::Recorded);
        match self.fo.positions {
            PositionPrior::Hold => None,
            PositionPrior::Sigma(s) => Some(s),
            PositionPrior::Recorded => (!posed || control).then_some(GPS_SIGMA_M),
        }
    }

    /// Each frame's time for a GPS drift, where the images can tell the drift
    /// ([`drift::drift_decided`]): a DEM holds the block's tilt and height under it; without
    /// one, the strips' order must decide the drift's height apart from the block's tilt
    /// ([`drift::drift_tilt_sigma_rad`] below [`drift::MAX_DRIFT_TILT_SIGMA_DEG`]), and the
    /// level ground the freed ties average to places the block in height.
    pub(super) fn gps_drift_times(&self) -> Option<&[f64]> {
        let centres: Vec<[f64; 3]> = self.rec.poses.iter().map(|p| p.centre).collect();
        let sigma = (0..self.len())
            .filter_map(|k| self.frame_position_sigma_m(k))
            .fold(0.0, f64::max);
        let tilt_decided = || {
            drift::drift_tilt_sigma_rad(&centres, &self.times, sigma)
                < drift::MAX_DRIFT_TILT_SIGMA_DEG.to_radians()
        };
        let decided = drift::drift_decided(&centres) && (self.opts.dem.is_some() || tilt_decided());
        decided.then_some(self.times.as_slice())
    }

    /// Frame `k`'s own position prior (m; east, north, up): its receiver's RTK standard
    /// deviations when the recorded positions are taken as they come (a claim of a millimetre
    /// held to 5 mm).
    pub(super) fn own_position_sigma_m(&self, k: usize) -> Option<[f64; 3]> {
        let own = self.fo.positions == PositionPrior::Recorded;
        self.frames[k]
            .rtk_std_m
            .filter(|_| own)
            .map(|s| s.map(|v| v.max(0.005)))
    }

    /// Frame `k`'s position prior (m, its largest axis); none when its position is held.
    pub(super) fn frame_position_sigma_m(&self, k: usize) -> Option<f64> {
        match self.own_position_sigma_m(k) {
            Some(s) => Some(s.into_iter().fold(0.0, f64::max)),
            None => self.position_sigma_m(self.opts.poses.is_some()),
        }
    }
}

impl Frame {
    /// The frame's own attitude prior (degrees, each axis): a source that needs a wider one
    /// than the flight's `flight_deg` (body angles, GPS track headings); none otherwise.
    pub(super) fn own_attitude_sigma_deg(&self, flight_deg: f64) -> Option<f64> {
        self.info
            .attitude
            .prior_sigma_deg
            .map(|s| s.max(flight_deg))
    }

    /// The frame's attitude prior (degrees, each axis).
    pub(super) fn attitude_sigma_deg(&self, flight_deg: f64) -> f64 {
        self.own_attitude_sigma_deg(flight_deg)
            .unwrap_or(flight_deg)
    }
}
