//! The flight's steps as pure functions of its plan: plan, render, match, adjust a round,
//! report, each able to run apart (Dask) and give what `adjust_flight` gives.

use super::*;

/// [`FlightPlan::settled_deg`] when no camera is above the plan's ground (no height to turn a
/// grid pixel into an angle): the fixed stop rounds had before [`SETTLED_GRID_PX`].
const FALLBACK_SETTLED_DEG: f64 = 0.005;

/// A flight planned for matching (every frame's metadata, camera and recorded pose, its plan
/// on the matching grid, the flight's CRS and ground): the steps of [`adjust_flight`], each a
/// pure function of the plan and its arguments, so that they can run apart (a pair on each
/// worker) and give what `adjust_flight` gives. The same inputs and options plan the same.
pub struct FlightPlan {
    pub(super) frames: Vec<Frame>,
    pub(super) opts: DroneOptions,
    pub(super) fo: FlightOptions,
    pub(super) gsd: f64,
    pub(super) ground: Box<dyn Fn(f64, f64) -> f64 + Send + Sync>,
    pub(super) rec: Recorded,
    pub(super) crs: Crs,
    pub(super) started: std::time::Instant,
    /// The plan's warnings (the matching grid coarsened, marks left out).
    pub(super) warnings: Vec<String>,
    /// The ground control in the flight's CRS, on its frames.
    pub(super) control: Option<control::Resolved>,
    /// How senseFly's roll was read, when the images decided it.
    pub(super) roll: Option<RollChoice>,
    /// The photos decoded once for the features and every round's render.
    pub(super) decoded: std::sync::Arc<decoded::Decoded>,
    /// Each frame's time in the flight, for a GPS drift ([`drift::flight_times`]).
    pub(super) times: Vec<f64>,
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
    pub(super) since: Option<std::time::Instant>,
    /// The last round's corrections, where the next round's solve starts (within one
    /// process: a round from [`FlightProgress::to_json`] starts at the recorded values).
    pub(super) start: Option<Corrections>,
    /// The ground the last round's tie points describe, once the rounds are done (see
    /// [`FlightOptions::tie_surface`]): the adjusted frames are rendered over it.
    pub surface: Option<TieSurface>,
    /// The features round's source sample (rendered and correlated with this orientation),
    /// for the next round to take (within one process, see [`sources::Sampled`]).
    pub(super) sampled: Option<sources::Sampled>,
}

/// Each frame's gray levels' bytes: the budget keeps them before its photo (`decoded`).
fn level_bytes(rec: &Recorded) -> Vec<usize> {
    rec.camera_of
        .iter()
        .map(|&c| {
            rec.cameras.get(c).map_or(0, |camera| {
                aerorect_raster::ReducedLevels::<f32>::byte_len_for(camera.size, 1)
            })
        })
        .collect()
}

impl FlightPlan {
    /// Reads every frame's metadata and plans it on the matching grid.
    pub fn new(inputs: &[PathBuf], opts: &DroneOptions, fo: &FlightOptions) -> Result<Self, Error> {
        let started = std::time::Instant::now();
        // With `--geo`, its positions, heights and angles stand in for the photos' own here
        // too: the flight's CRS and matching grid come from them.
        let metas: Vec<(PathBuf, PhotoMetadata)> = inputs
            .iter()
            .map(|p| {
                let own = aerorect_io::read_photo_metadata(p)?;
                let file = p.display().to_string();
                Ok((
                    p.clone(),
                    crate::photo_source::with_geo_record(&own, opts, &file)?,
                ))
            })
            .collect::<Result<_, Error>>()?;
        let crs = flight_crs(&metas, opts)?;
        let opts = DroneOptions {
            crs: Some(crs.clone()),
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
        let (gsd, frames, mut warnings) = plan_matching(&metas, &opts, gsd)?;
        let rec = recorded(&frames);
        let control = match &fo.control {
            Some(co) => Some(control::resolve(co, &frames, &rec, &crs)?),
            None => None,
        };
        warnings.extend(control.iter().flat_map(|c| c.warnings.iter().cloned()));
        let decoded =
            decoded::Decoded::new(&level_bytes(&rec), crate::memory::cache_budget_bytes());
        Ok(Self {
            times: drift::flight_times(&metas),
            ground: ground_fn(&opts, &crs),
            control,
            rec,
            frames,
            opts,
            fo: fo.clone(),
            gsd,
            crs,
            started,
            warnings,
            roll: None,
            decoded: std::sync::Arc::new(decoded),
        })
    }

    /// The same plan keeping at most `bytes` of decoded photos and gray levels, not a share
    /// of the machine's available memory: a Dask worker's plan, whose memory limit is its own.
    pub fn with_cache_budget(mut self, bytes: usize) -> Self {
        let decoded = decoded::Decoded::new(&level_bytes(&self.rec), bytes);
        self.decoded = std::sync::Arc::new(decoded);
        self
    }

    /// The median turn (degrees) below which the rounds are settled:
    /// [`FlightOptions::settled_deg`] when given, else the turn that moves the median frame's
    /// ground by [`SETTLED_GRID_PX`] of the matching grid, at its recorded height above the
    /// plan's ground.
    pub fn settled_deg(&self) -> f64 {
        if let Some(d) = self.fo.settled_deg {
            return d;
        }
        let mut heights: Vec<f64> = self
            .rec
            .poses
            .iter()
            .map(|p| p.centre[2] - (self.ground)(p.centre[0], p.centre[1]))
            .filter(|h| h.is_finite() && *h > 0.0)
            .collect();
        heights.sort_by(f64::total_cmp);
        match heights.get(heights.len() / 2) {
            Some(h) => (SETTLED_GRID_PX * self.gsd / h).to_degrees(),
            None => FALLBACK_SETTLED_DEG,
        }
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frame `k`'s plan on the matching grid: as recorded, or with `orientation`'s pose and
    /// camera (its frame pixels, and so its tie observations, stay those of the photo).
    pub(super) fn matching_plan(
        &self,
        k: usize,
        orientation: Option<&Orientation>,
    ) -> Result<OrthoPlan, Error> {
        let f = &self.frames[k];
        let Some(o) = orientation else {
            return Ok(f.coarse_plan.clone());
        };
        let ground = frame_ground(f, &self.opts, None);
        let req = OrthoRequest {
            camera: &o.cameras[k],
            pose: o.poses[k],
            world: &self.crs,
            ground: &ground,
            gsd_m: f.coarse_plan.grid.gsd,
            // The GSD was chosen for the recorded orientation to fit the budget; an adjusted
            // one moves the footprint a little.
            limits: aerorect_core::RectifyLimits {
                max_output_px: 4 * MATCH_BUDGET_PX,
            },
            occlusion: false,
        };
        plan_ortho(&req, matching_warp()).map_err(Error::context(f.input.display()))
    }

    /// Frame `k`'s gray ortho on the matching grid.
    pub(super) fn render(
        &self,
        k: usize,
        orientation: Option<&Orientation>,
    ) -> Result<Rendered, Error> {
        self.render_keeping(k, orientation, true)
    }

    /// [`Self::render`]; `keep`: whether the gray levels it makes are kept for later rounds
    /// (not for the features round's source sample, after which the rounds may end: the
    /// levels of a photo not kept were kept by the features, see `decoded`).
    pub(super) fn render_keeping(
        &self,
        k: usize,
        orientation: Option<&Orientation>,
        keep: bool,
    ) -> Result<Rendered, Error> {
        let coarse_plan = self.matching_plan(k, orientation)?;
        let input = &self.frames[k].input;
        // The frame's reduced levels, kept between rounds, give the same pixels as its gray
        // frame wherever the matching grid is more than twice coarser than the photo.
        let levels = self.decoded.gray_levels((k, input), keep)?;
        if let Some(coarse) = coarse_plan.run_levels(&levels)? {
            return Ok(Rendered {
                coarse,
                coarse_plan,
            });
        }
        let image = self.decoded.get(k, input)?;
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

    pub(super) fn match_rendered(
        &self,
        a: (usize, &Rendered),
        b: (usize, &Rendered),
    ) -> Result<PairMatch, Error> {
        // Over the level ground the hills' parallax stays in the rendered frames.
        let relief = self.opts.dem.is_none();
        pair_ties(a, b, self.fo.patch, self.ground.as_ref(), relief)
    }

    /// One round's adjustment from the matches of every overlapping pair (in [`Self::pairs`]'
    /// order): the recorded orientation adjusted to their tie points; `progress` gets the
    /// round's orientation and summary, and is done after [`FlightOptions::passes`] rounds or
    /// when the median frame turned by less than [`Self::settled_deg`]. Returns the
    /// flight's report as of this round.
    pub fn adjust(
        &self,
        progress: &mut FlightProgress,
        matched: Vec<PairMatch>,
    ) -> Result<FlightReport, Error> {
        let round = self.adjust_round(progress, matched, self.fo.final_all_ties)?;
        Ok(self.report(progress, round).0)
    }

    /// Each match with its frames' names.
    fn named<'m>(
        &self,
        matches: impl Iterator<Item = &'m PairMatch>,
    ) -> Result<Vec<(&'m PairMatch, String, String)>, Error> {
        let name = |k: usize| self.frames.get(k).map(|f| f.input.display().to_string());
        matches
            .map(|m| match (name(m.a), name(m.b)) {
                (Some(a), Some(b)) => Ok((m, a, b)),
                _ => Err(Error::Invalid(format!(
                    "pair ({}, {}) of a flight of {} frames",
                    m.a,
                    m.b,
                    self.len()
                ))),
            })
            .collect()
    }

    /// The solve that ends the rounds: every tie of `pairs` (spare ones too), from `round`'s
    /// solution (whose poses are `poses`), and what it did.
    fn last_solve(
        &self,
        pairs: &[(&PairMatch, String, String)],
        mode: (bool, bool),
        round: &Round,
        poses: &[Pose],
    ) -> Result<(Round, FinalSolve), Error> {
        let t = std::time::Instant::now();
        let last = timing::time("final solve, all ties (wall)", || {
            match_and_adjust(
                (pairs, true),
                self,
                mode,
                Some(&round.adjusted.corrections),
                true,
            )
        })?;
        let (p, _) = last.orientation(&self.rec);
        let solved = FinalSolve {
            tie_points: last.adjusted.report.tie_points,
            rms_after_px: last.adjusted.report.rms_after_px,
            largest_turn_deg: largest_turn_deg(poses, &p),
            median_turn_deg: median_turn_deg(poses, &p),
            seconds: t.elapsed().as_secs_f64(),
        };
        Ok((last, solved))
    }

    /// One round (see [`Self::adjust`]); when it ends the rounds and `all_at_end`, the round's
    /// orientation is that of the solve with every tie (see
    /// [`FlightOptions::final_all_ties`]).
    pub(super) fn adjust_round(
        &self,
        progress: &mut FlightProgress,
        matched: Vec<PairMatch>,
        all_at_end: bool,
    ) -> Result<Round, Error> {
        let posed = self.opts.poses.is_some();
        let mode = (self.opts.dem.is_some(), posed);
        // Where correlation ties a pair, its matches (sub-pixel, on frames that now
        // coincide) replace the pair's features; elsewhere the features hold it.
        let key = |m: &PairMatch| (m.a.min(m.b), m.a.max(m.b));
        let correlated: std::collections::BTreeSet<(usize, usize)> = matched
            .iter()
            .filter(|m| !m.features && m.reliable())
            .map(key)
            .collect();
        let pairs = self.named(
            matched
                .iter()
                .filter(|m| !(m.features && correlated.contains(&key(m)))),
        )?;
        let start = progress.start.as_ref();
        // The report's standard deviations are the last solve's: a round that a solve with
        // every tie would follow, should it end the rounds, does without them.
        let last_follows = all_at_end && pairs.iter().any(|(m, _, _)| !m.spare.is_empty());
        let round = timing::time("solve round (wall)", || {
            match_and_adjust((&pairs, false), self, mode, start, !last_follows)
        })?;
        let (poses, cameras) = round.orientation(&self.rec);
        let before = progress
            .orientation
            .as_ref()
            .map_or(&self.rec.poses, |o| &o.poses);
        let typical = median_turn_deg(before, &poses);
        let since = progress.since.unwrap_or(self.started);
        let mut summary = round.summary((before, &poses), since);
        // Over a DEM, the solve that ends the rounds takes both sources where correlation
        // tied pairs, each weighed by the round's orientation; the features round weighs them
        // on a correlated sample of its pairs (see `sources`), without a DEM too unless its
        // solve took a GPS drift: the drift's height, and so the block's tilt, then rests on
        // the ties' heights about the level ground, and correlation's held it better (the
        // 8 x 8 fixed wing, GPS only, its fixes climbing 80 m: 1.11 / 1.43 deg from the truth
        // after the correlation rounds, 2.02 / 2.08 where the features ended them).
        let cams: Vec<&Camera> = cameras.iter().collect();
        let features_round = all_at_end
            && self.fo.ties == TieSource::Both
            && !matched.is_empty()
            && matched.iter().all(|m| m.features);
        let mut sampled = None;
        summary.sources = match (self.opts.dem.is_some(), correlated.is_empty()) {
            (true, false) => SourceWeights::weigh(&matched, (&poses, &cams), self.gap_on()),
            (dem, true)
                if features_round && (dem || !drift::drift_solved(&round.adjusted.report)) =>
            {
                let orientation = Orientation {
                    poses: poses.clone(),
                    cameras: cameras.clone(),
                };
                let (weights, work) = self.sampled_sources(&matched, &orientation)?;
                sampled = Some(work);
                weights
            }
            (false, false) | (_, true) => None,
        };
        summary.held_by_features = all_at_end && summary.sources.is_some_and(|w| w.features_hold());
        // Rounds whose turns stopped shrinking end too (another round would turn the frames
        // about as much again): the senseFly photos' rounds turned their median frame 6.27,
        // 0.90, 0.34, 0.12, 0.19, 0.10, 0.19, 0.26 deg and ran to the cap of eight.
        let oscillating = progress.rounds.len() >= OSCILLATION_EARLIER_ROUNDS
            && typical >= self.settled_deg()
            && oscillates(&progress.rounds, typical);
        progress.done = progress.rounds.len() + 1 >= self.fo.passes.min(MAX_PASSES)
            || (!progress.rounds.is_empty() && typical < self.settled_deg())
            || self.fo.ties == TieSource::Features
            || summary.held_by_features
            || oscillating;
        // Only correlation's ties need the features weighed against them.
        let both = match progress.done && all_at_end && !correlated.is_empty() {
            true => summary.sources.and_then(|w| w.factor(&matched)),
            false => None,
        }
        .map(|f| sources::both_sources(&matched, f));
        let all = progress.done && (last_follows || both.is_some());
        let (round, poses, cameras) = match all {
            true => {
                let last_pairs = match &both {
                    Some(b) => self.named(b.iter())?,
                    None => pairs,
                };
                let (last, solved) = self.last_solve(&last_pairs, mode, &round, &poses)?;
                summary.final_solve = Some(solved);
                let (p, c) = last.orientation(&self.rec);
                (last, p, c)
            }
            false => (round, poses, cameras),
        };
        progress.rounds.push(summary);
        // The next round renders with this round's orientation, as the sample did.
        progress.sampled = sampled.filter(|_| !progress.done);
        progress.since = Some(std::time::Instant::now());
        progress.orientation = Some(Orientation { poses, cameras });
        progress.start = Some(round.adjusted.corrections.clone());
        // The surface takes every reliable pair's ties as the last solve took them, and the
        // features that correlation replaced in the solve too: both are the same ground seen
        // from two frames.
        let surface = progress.done && self.fo.tie_surface && self.opts.dem.is_none();
        progress.surface = match surface {
            true => {
                let ties: Vec<TiePoint> = matched
                    .iter()
                    .flat_map(|m| m.solve_ties(all).map(|t| t.tie_point(m.a, m.b)))
                    .collect();
                match ties.is_empty() {
                    true => None,
                    false => timing::time("tie surface", || {
                        tie_surface(&ties, round.adjusted.oriented(), &self.crs)
                    })?,
                }
            }
            false => None,
        };
        Ok(round)
    }

    /// The flight's report after `round`, and the round's tie vectors.
    pub(super) fn report(
        &self,
        progress: &FlightProgress,
        round: Round,
    ) -> (FlightReport, Vec<TieVector>) {
        let (poses, cameras) = round.orientation(&self.rec);
        let (settled, oscillating) = settling(&progress.rounds, self.settled_deg());
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
                self.settled_deg(),
                oscillating,
            ));
        }
        let names: Vec<String> = self
            .frames
            .iter()
            .map(|f| f.input.display().to_string())
            .collect();
        let blocks = blocks(&names, &round.reports, &round.adjusted.report.frames);
        warnings.extend(blocks_warning(&blocks));
        let report = FlightReport {
            frames: names,
            passes: progress.rounds.len(),
            rounds: progress.rounds.clone(),
            match_gsd_m: self.gsd,
            settled,
            settled_deg: self.settled_deg(),
            oscillating,
            warnings,
            unconnected: unconnected(&self.frames, &round.reports),
            blocks,
            gps: round.gps,
            accuracy: round.accuracy,
            sensefly_roll: self.roll.clone(),
            surface: progress.surface.as_ref().map(|s| s.report.clone()),
            pairs: round.reports,
            adjustment: round.adjusted.report,
            poses: adjusted_poses(&self.frames, &poses, &cameras),
            seconds: self.started.elapsed().as_secs_f64(),
        };
        (report, round.ties)
    }

    pub(super) fn finish(
        self,
        progress: FlightProgress,
        round: Round,
        rendered: Vec<Rendered>,
    ) -> AdjustedFlight {
        let (poses, cameras) = round.orientation(&self.rec);
        let (report, ties) = self.report(&progress, round);
        AdjustedFlight {
            surface: progress.surface.map(|s| s.dem),
            frames: self.frames,
            rendered,
            ties,
            poses,
            cameras,
            report,
            crs: self.crs,
            decoded: self.decoded.without_levels(),
        }
    }

    /// What planning found (the matching grid coarsened, ground control marks left out).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The output CRS of every frame.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }

    /// A tie surface (`dem`) in the flight's CRS. One read back from JSON carries the CRS as
    /// WKT; the flight's own is the one the frames are planned in (the same definition: no
    /// transform per cell).
    pub(super) fn flight_dem(
        &self,
        dem: &std::sync::Arc<aerorect_geo::Dem>,
    ) -> std::sync::Arc<aerorect_geo::Dem> {
        match dem.crs.same_definition(&self.crs) {
            true => std::sync::Arc::clone(dem),
            false => std::sync::Arc::new(aerorect_geo::Dem {
                crs: self.crs.clone(),
                ..(**dem).clone()
            }),
        }
    }

    /// Frame `k` rectified with `progress`' orientation (its pose and camera) onto the output
    /// grid, over its tie surface when it has one, staged (as
    /// [`AdjustedFlight::write_frame_staged`]).
    pub fn write_frame_staged(
        &self,
        k: usize,
        progress: &FlightProgress,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let Some(orientation) = &progress.orientation else {
            return Err(Error::Invalid(
                "the progress has no adjusted orientation yet".into(),
            ));
        };
        let surface = progress.surface.as_ref().map(|s| self.flight_dem(&s.dem));
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
            crs: &self.crs,
            surface: surface.as_ref(),
            decoded: (&self.decoded, k),
        };
        oriented.write_staged(output, opts, staged)
    }
}
