//! A round's solve looked at again: where its own result says a prior was wrong, the flight
//! is solved once more without it (and a cold solve that frees blocks from the level ground
//! starts from the level ground's). A block freed from the level ground that its GPS tilted
//! steeper than ground is ([`FlightPlan::level_steep_blocks`]) goes back to the level ground;
//! GPS fixes the images contradict are then taken robustly, so that the images win, and fixes
//! that drift in time as a whole ([`drift::drift_seen`]) are solved with their drift.

use super::*;
use aerorect_solve::adjust::Adjusted;

/// What the second looks need beyond the solve: the flight, its ties and frames as solved,
/// each frame's relief sigma without a DEM (`relief`), the recorded positions' sigma, and
/// whether ground control sets the datum (it decides the GPS's weight itself).
pub(super) struct Relook<'p> {
    pub(super) plan: &'p FlightPlan,
    pub(super) ties: &'p [TiePoint],
    pub(super) adjust_frames: &'p [AdjustFrame],
    pub(super) relief: Option<&'p relief::Relief>,
    pub(super) position_sigma_m: Option<f64>,
    pub(super) control: bool,
}

impl<'p> Relook<'p> {
    /// `solve` with `aopts`, then again as the result asks; the last result and the warnings
    /// that say why it was solved again.
    pub(super) fn solve(
        &self,
        aopts: &AdjustOptions<'_>,
        solve: impl Fn(&AdjustOptions<'_>) -> Result<Adjusted, Error>,
    ) -> Result<(Adjusted, Vec<String>), Error> {
        // A cold solve with blocks freed from the level ground starts where the level ground
        // takes the frames: freed from the recorded attitudes, 1,000 frames crawled along
        // the block's common tilt (424 s for the simulated fixed wing without a DEM; 158 s
        // so, as accurate).
        let level = match (self.relief, aopts.start) {
            (Some(r), None) if r.any_freed() => Some(solve(&AdjustOptions {
                terrain_sigma_by_frame: None,
                ..aopts.clone()
            })?),
            _ => None,
        };
        let warm;
        let aopts = match &level {
            Some(l) => {
                warm = AdjustOptions {
                    start: Some(&l.corrections),
                    ..aopts.clone()
                };
                &warm
            }
            None => aopts,
        };
        // A round that starts where one that solved a GPS drift ended solves the drift from
        // the start (the fixes quadratically): solved without it, the fixes would be
        // contradicted again and the round solved twice. Measured while the robust solve was
        // still staged (d9529d9 removed that): the 1,000-frame simulation's final solve took
        // 33 s without the carry, 16 s with it.
        let carried;
        let aopts = match self.carried_drift(aopts) {
            Some(d) => {
                carried = d;
                &carried
            }
            None => aopts,
        };
        let mut adjusted = solve(aopts)?;
        let mut warnings = Vec::new();
        let levelled = self
            .relief
            .and_then(|r| self.plan.level_steep_blocks(r, self.ties, &adjusted));
        let mut opts = aopts.clone();
        if let Some((r, w)) = &levelled {
            opts.terrain_sigma_by_frame = Some(r.as_slice());
            adjusted = solve(&opts)?;
            warnings.push(w.clone());
        }
        if let Some(robust) = self.robust_after(&opts, &adjusted) {
            adjusted = solve(&robust)?;
        }
        Ok((adjusted, warnings))
    }

    /// The options that solve a GPS drift with the fixes taken quadratically, where `opts`
    /// start from a solve that found one ([`robust_gps`] would solve a drift too); none
    /// otherwise.
    fn carried_drift<'o>(&self, opts: &AdjustOptions<'o>) -> Option<AdjustOptions<'o>>
    where
        'p: 'o,
    {
        let start = opts.start?;
        if self.control || opts.position_huber.is_some() || start.drift_m() == [0.0; 3] {
            return None;
        }
        let drift = robust_gps(
            None,
            (self.position_sigma_m, true),
            (self.plan.frames.len(), self.plan.gps_drift_times()),
            opts.clone(),
        );
        drift.gps_drift_times.is_some().then_some(AdjustOptions {
            position_huber: None,
            ..drift
        })
    }

    /// Whether `adjusted` leaves some GPS fix contradicted by the images, or, solved without
    /// a drift where one can be told, the fixes drifting ([`drift::drift_seen`]).
    fn any_contradicted(&self, adjusted: &Adjusted) -> bool {
        let checks = gps_checks(
            &self.plan.frames,
            self.adjust_frames,
            &adjusted.report,
            self.position_sigma_m,
        );
        checks.iter().any(|g| g.contradicted) || self.drift_seen(adjusted, &checks)
    }

    /// Whether `adjusted`, solved without a drift, left the fixes drifting.
    fn drift_seen(&self, adjusted: &Adjusted, checks: &[GpsCheck]) -> bool {
        let solved = drift::drift_solved(&adjusted.report);
        let Some(times) = self.plan.gps_drift_times().filter(|_| !solved) else {
            return false;
        };
        let centres: Vec<[f64; 3]> = self.plan.rec.poses.iter().map(|p| p.centre).collect();
        let offsets: Vec<[f64; 3]> = checks.iter().map(|g| g.offset_m).collect();
        let sigmas: Vec<[f64; 3]> = checks.iter().map(|g| g.prior_sigma_m).collect();
        offsets.len() == centres.len() && drift::drift_seen(&centres, times, &offsets, &sigmas)
    }

    /// The options that take every GPS fix robustly ([`robust_gps`]) when the solve with
    /// `opts` left some fix contradicted by the images and took them quadratically; none
    /// otherwise (with ground control, or where robust GPS does not apply).
    fn robust_after<'o>(
        &self,
        opts: &AdjustOptions<'o>,
        adjusted: &Adjusted,
    ) -> Option<AdjustOptions<'o>>
    where
        'p: 'o,
    {
        if self.control || opts.position_huber.is_some() {
            return None;
        }
        let frames = &self.plan.frames;
        if !self.any_contradicted(adjusted) {
            return None;
        }
        let robust = robust_gps(
            None,
            (self.position_sigma_m, true),
            (frames.len(), self.plan.gps_drift_times()),
            opts.clone(),
        );
        robust.position_huber.is_some().then_some(robust)
    }
}

/// The datum and the robustness of the GPS priors: with ground control, the datum the control
/// fixes (its shift free); without, with `robust` and three frames or more, a shift held at a
/// GPS fix's sigma over the root of the frames' count (the block stays where its GPS puts it),
/// a drift in time where `drift` gives the frames' times ([`FlightPlan::gps_drift_times`]),
/// and each fix taken robustly about them (Huber at [`GPS_CONTRADICTION_SIGMAS`]): a fix the
/// images contradict is down-weighted and the images win.
pub(super) fn robust_gps<'a>(
    control: Option<&control::Resolved>,
    (position_sigma_m, robust): (Option<f64>, bool),
    (frames, drift): (usize, Option<&'a [f64]>),
    aopts: AdjustOptions<'a>,
) -> AdjustOptions<'a> {
    match (control, position_sigma_m) {
        (Some(c), _) => AdjustOptions {
            datum: c.datum(),
            ..aopts
        },
        (None, Some(sigma)) if frames >= 3 && robust => AdjustOptions {
            datum: Datum::Shift,
            datum_shift_sigma_m: match drift {
                Some(_) => drifting_shift_sigma_m(sigma),
                None => [sigma / (frames as f64).sqrt(); 3],
            },
            position_huber: Some(GPS_CONTRADICTION_SIGMAS),
            gps_drift_times: drift,
            ..aopts
        },
        _ => aopts,
    }
}

/// The datum shift's prior (m; east, north, up) where the fixes drift with a GPS fix's
/// `sigma`. The mean of fixes that drift is no better than one fix: on the simulated fixed
/// wing over its DEM (GPS 110 m up over the flight), a shift held at a tenth of a fix's sigma
/// kept 15 of the 55 m the fixes share and left the frames 0.16 deg off. Nor is their height
/// any better than the drift's value at mid-flight, which nothing observes: the ground (the
/// DEM, or without one the level ground's height that the freed ties still average to) places
/// the block in height, the shift [`DRIFTING_HEIGHT_SIGMA_M`]. Held at a fix's sigma in height
/// too, the same flight ended 0.10 deg off over its DEM (0.02 deg free), and without a DEM
/// its cameras 44 m too high: each round's frames, rendered over the level ground, then missed
/// each other by metres and its ties failed (4.7 deg off; 0.83 deg free).
pub(super) fn drifting_shift_sigma_m(sigma: f64) -> [f64; 3] {
    [sigma, sigma, DRIFTING_HEIGHT_SIGMA_M]
}

/// The datum shift's prior in height (m) where the fixes drift: free in practice.
pub(super) const DRIFTING_HEIGHT_SIGMA_M: f64 = 1000.0;
