//! A large flight whose priors cannot guide its feature matching (a fixed wing's body angles,
//! GPS-track headings, attitudes recorded 5 degrees off) is matched in two steps. The first
//! matches, in full, a sparse net of its candidate pairs that still holds every frame to its
//! neighbours along and across the strips (each frame's [`FIRST_STEP_NEIGHBOURS`] nearest
//! frames and the Delaunay neighbours of the positions), and solves it once. The second
//! matches the remaining candidate pairs guided by that solve ([`Basis::Stepped`]): a frame
//! tied in the first step is known to a fraction of a degree, so its windows are small.
//! A pair the solve guides wrongly is matched again in full, as any guided pair
//! ([`GUIDE_RETRY_OVERLAP`]).
//!
//! Without a DEM the level ground's 10 m ([`RELIEF_SIGMA_M`]) of parallax would leave most
//! second-step windows too wide (matched in full: 17,366 pairs, 132 s of CPU on the
//! 1,000-frame fixed wing, GPS only). So the first step's solve also gives the ground its ties
//! describe ([`tie_surface`], [`StepGuide::surface`]): a placed frame's keypoints go on it,
//! and a pair of placed frames allows for the ground's height about it by the surface's own
//! spread, at least a DEM's 1 m ([`FlightPlan::basis_terrain_sigma_m`]). On that flight, whose
//! features hold without a correlation round (see `sources`): 3,002 pairs matched in full
//! instead of 17,366, features round 103.3 -> 41.1 s wall, matched and adjusted 126.5 ->
//! 65.7 s, 0.072 / 0.196 -> 0.099 / 0.228 deg from the truth (median / max; the block's common
//! turn 0.026 deg, so the frames' own: their tilt trades with their 0.2 m of position where
//! no DEM holds their heights); at a 2 m floor, 0.100 / 0.229. Tried while correlation rounds
//! still followed, the surface saved less (232.5 -> 206.7 s) and ended 0.096 / 0.852.

use super::*;
use crate::features::FrameFeatures;
use aerorect_solve::pairs::{PairOptions, candidate_pairs};

/// Flights of fewer frames are matched in one step: their candidate pairs are few, and the
/// first step's solve would cost more than it saves.
pub const MIN_STEPPED_FRAMES: usize = 50;

/// Nearest frames (by recorded position) each frame is matched with in the first step,
/// besides its Delaunay neighbours.
pub const FIRST_STEP_NEIGHBOURS: usize = 2;

/// How far (degrees, each axis) a frame tied in the first step may be from its solved
/// attitude when the second step's windows are drawn.
pub const STEPPED_ATTITUDE_SIGMA_DEG: f64 = 0.2;

/// How far (m) a frame tied in the first step may be from its solved position when the second
/// step's windows are drawn (at most its recorded prior).
pub const STEPPED_POSITION_SIGMA_M: f64 = 0.2;

/// The first step's solve: every frame's pose and camera, and which frames a reliable pair
/// tied (the others keep their recorded orientation and priors).
#[derive(Debug, Clone)]
pub struct StepGuide {
    pub orientation: Orientation,
    pub placed: Vec<bool>,
    /// The solve's corrections: where the first round's solve starts
    /// ([`FlightPlan::first_progress`]).
    pub start: Corrections,
    /// Without a DEM, the ground the first step's ties describe through its solve
    /// ([`tie_surface`]): the second step's keypoints are put on it, and its windows allow
    /// for the ground's height about it instead of the level ground's relief.
    pub surface: Option<TieSurface>,
}

/// The orientation a pair's window is predicted from.
#[derive(Debug, Clone, Copy)]
pub enum Basis<'a> {
    /// The recorded orientation and its priors.
    Recorded,
    /// The recorded orientation and its priors, in the first step of a flight matched in two
    /// steps: a pair the priors cannot guide is matched on each frame's
    /// [`FIRST_STEP_KEYPOINTS`] strongest keypoints.
    FirstStep,
    /// The first step's solve.
    Stepped(&'a StepGuide),
}

impl<'a> Basis<'a> {
    /// The first step's solve, where this basis is it and it placed every one of `frames`.
    fn placing(self, frames: &[usize]) -> Option<&'a StepGuide> {
        match self {
            Basis::Stepped(g) if frames.iter().all(|&k| g.placed.get(k) == Some(&true)) => Some(g),
            _ => None,
        }
    }
}

/// Keypoints per frame (the strongest by response) a first-step pair the priors cannot guide
/// is matched on ([`Basis::FirstStep`]). Brute-force matching is quadratic in them: on the
/// 1,000-frame fixed wing (1,051 keypoints a frame) its 3,002 first-step pairs took 17.8 s of
/// CPU with every keypoint, 10.6 s with 800 and 6.1 s with 600; the flight took 62.3, 59.3
/// and 57.6 s, and ended 0.0163 / 0.0614, 0.0167 / 0.0612 and 0.0170 / 0.0589 deg from the
/// truth (median / max). Matching those pairs again in the second step, guided by the first
/// step's solve, cost more than it saved (60.7 s) and ended no closer (0.0168 / 0.0625).
pub const FIRST_STEP_KEYPOINTS: usize = 600;

impl FlightPlan {
    /// Which step matches each of `pairs` ([`Self::feature_pairs`]): 1, or 2 for a pair the
    /// recorded priors cannot guide outside the first step's net, in a flight of at least
    /// [`MIN_STEPPED_FRAMES`] frames.
    pub fn feature_steps(&self, pairs: &[(usize, usize)]) -> Result<Vec<u8>, Error> {
        if self.len() < MIN_STEPPED_FRAMES {
            return Ok(vec![1; pairs.len()]);
        }
        let centres = self.recorded_centres();
        let opts = PairOptions {
            neighbours: FIRST_STEP_NEIGHBOURS,
            delaunay: true,
            max_distance: None,
        };
        let net: std::collections::BTreeSet<(usize, usize)> =
            candidate_pairs(&centres, None, &opts)
                .map_err(Error::context("the first step's pairs"))?
                .into_iter()
                .collect();
        Ok(pairs
            .iter()
            .map(
                |&(i, j)| match net.contains(&(i, j)) || self.prior_guides(i, j) {
                    true => 1,
                    false => 2,
                },
            )
            .collect())
    }

    /// The first step's solve from its matches (`first`); none when no pair tied or the
    /// solve failed (the second step's pairs are then matched in full).
    pub fn step_guide(&self, first: &[PairMatch]) -> Option<StepGuide> {
        let mut placed = vec![false; self.len()];
        for m in first.iter().filter(|m| m.reliable()) {
            for k in [m.a, m.b] {
                *placed.get_mut(k)? = true;
            }
        }
        if !placed.contains(&true) {
            return None;
        }
        let name = |k: usize| self.frames[k].input.display().to_string();
        let pairs: Vec<(&PairMatch, String, String)> =
            first.iter().map(|m| (m, name(m.a), name(m.b))).collect();
        let mode = (self.opts.dem.is_some(), self.opts.poses.is_some());
        let round = timing::time("features: first step's solve (wall)", || {
            match_and_adjust((&pairs, false), self, mode, None, false)
        })
        .ok()?;
        let surface = match self.opts.dem.is_none() && self.fo.tie_surface {
            true => timing::time("features: first step's surface", || {
                let ties: Vec<TiePoint> = first
                    .iter()
                    .flat_map(|m| m.solve_ties(true).map(|t| t.tie_point(m.a, m.b)))
                    .collect();
                tie_surface(&ties, round.adjusted.oriented(), &self.crs)
            })
            .ok()
            .flatten(),
            false => None,
        };
        let (poses, cameras) = round.orientation(&self.rec);
        Some(StepGuide {
            orientation: Orientation { poses, cameras },
            placed,
            start: round.adjusted.corrections,
            surface,
        })
    }

    /// The progress before the first round: its solve starts from the first step's solution
    /// (`guide`), near the first round's (on the 1,000-frame fixed wing, 0.05 degrees from the
    /// truth where the recorded attitudes are 7.5); from the recorded orientation without
    /// one, or when the flight left senseFly's roll to its images (the reading the first
    /// step solved with may have changed since).
    pub fn first_progress(&self, guide: Option<&StepGuide>) -> FlightProgress {
        FlightProgress {
            start: guide
                .filter(|_| self.roll.is_none())
                .map(|g| g.start.clone()),
            ..FlightProgress::default()
        }
    }

    /// Frame `k`'s features (`f`) as the second step matches them: where the first step
    /// placed the frame (`guide`), its keypoints on the ground by its solved pose; else as
    /// they were (by the recorded pose).
    pub fn step_features(&self, guide: &StepGuide, k: usize, f: &mut FrameFeatures) {
        if Basis::Stepped(guide).placing(&[k]).is_some() {
            f.ground = self.step_ground(Basis::Stepped(guide), k, f);
        }
    }

    /// Frame `k`'s keypoints (`f`) on the ground by its orientation in `basis`.
    pub fn step_ground(
        &self,
        basis: Basis<'_>,
        k: usize,
        f: &FrameFeatures,
    ) -> Vec<Option<[f64; 3]>> {
        let (pose, camera) = self.basis_view(basis, k);
        let surface = basis
            .placing(&[k])
            .and_then(|g| g.surface.as_ref())
            .map(|s| {
                // The report's heights are the surface's range: no pass over its cells per frame.
                let [lo, hi] = s.report.heights_m;
                let range = (lo <= hi).then_some((lo, hi));
                dem_ground_within(self.flight_dem(&s.dem), &self.crs, range)
            });
        let ground = surface
            .as_ref()
            .map_or(self.ground.as_ref(), |g| g.as_ref());
        f.features
            .keypoints
            .iter()
            .map(|kp| {
                let px = aerorect_raster::features::full_from_reduced(f.factor, [kp.x, kp.y]);
                on_ground(pose, camera, px, ground)
            })
            .collect()
    }

    /// The standard deviation (m) of the ground's height under pair (`i`, `j`)'s ties in
    /// `basis`: about the first step's surface where it placed both frames (the surface's own
    /// spread, at least a DEM's), else [`terrain_sigma_m`].
    pub(super) fn basis_terrain_sigma_m(&self, basis: Basis<'_>, i: usize, j: usize) -> f64 {
        basis
            .placing(&[i, j])
            .and_then(|g| g.surface.as_ref())
            .map_or(terrain_sigma_m(self.opts.dem.is_some()), |s| {
                s.report.spread_m.max(terrain_sigma_m(true))
            })
    }

    /// Frame `k`'s pose and camera in `basis`.
    pub(super) fn basis_view<'a>(&'a self, basis: Basis<'a>, k: usize) -> (&'a Pose, &'a Camera) {
        match basis.placing(&[k]) {
            Some(g) => (&g.orientation.poses[k], &g.orientation.cameras[k]),
            None => (&self.rec.poses[k], &self.rec.cameras[self.rec.camera_of[k]]),
        }
    }

    /// Frame `k`'s attitude (degrees) and position (m, 0 when held) standard deviations in
    /// `basis`.
    pub(super) fn basis_sigmas(&self, basis: Basis<'_>, k: usize) -> (f64, f64) {
        let attitude = self.frames[k].attitude_sigma_deg(self.fo.attitude_sigma_deg);
        let position = self.frame_position_sigma_m(k).unwrap_or(0.0);
        match basis.placing(&[k]) {
            Some(_) => (
                attitude.min(STEPPED_ATTITUDE_SIGMA_DEG),
                position.min(STEPPED_POSITION_SIGMA_M),
            ),
            None => (attitude, position),
        }
    }

    /// Whether the recorded priors guide pair (`i`, `j`) (see [`FlightPlan::guide`]).
    fn prior_guides(&self, i: usize, j: usize) -> bool {
        let size = self.rec.cameras[self.rec.camera_of[j]].size;
        let factor = crate::features::reduction_factor(size, self.tie_options().long_side_px);
        self.window_radius(Basis::Recorded, (i, j), (size, factor))
            .is_some()
    }
}

/// [`StepGuide`] as it travels between processes: the orientation as a progress's, every
/// float to the bit.
#[derive(Serialize, Deserialize)]
struct StepGuideFile {
    progress: String,
    placed: Vec<bool>,
}

impl StepGuide {
    /// As [`exact_json`]: every float to the bit.
    pub fn to_json(&self) -> Result<String, Error> {
        let progress = FlightProgress {
            orientation: Some(self.orientation.clone()),
            start: Some(self.start.clone()),
            surface: self.surface.clone(),
            ..Default::default()
        };
        exact_json(&StepGuideFile {
            progress: progress.to_json()?,
            placed: self.placed.clone(),
        })
    }

    /// The guide [`Self::to_json`] wrote for a flight of `frames` frames.
    pub fn from_json(text: &str, frames: usize) -> Result<Self, Error> {
        let f: StepGuideFile = from_exact_json(text)?;
        let p = FlightProgress::from_json(&f.progress)?;
        match (p.orientation, p.start) {
            (Some(o), Some(start))
                if o.poses.len() == frames
                    && o.cameras.len() == frames
                    && f.placed.len() == frames =>
            {
                Ok(Self {
                    orientation: o,
                    placed: f.placed,
                    start,
                    surface: p.surface,
                })
            }
            _ => Err(Error::Invalid(format!(
                "a first step's guide that is not one of {frames} frames"
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matched((a, b): (usize, usize)) -> PairMatch {
        PairMatch {
            a,
            b,
            patches: 0,
            inliers: 0,
            ties: vec![],
            spare: vec![],
            features: true,
        }
    }

    #[test]
    fn both_steps_matches_come_back_in_the_pairs_order() {
        let steps = [1, 2, 2, 1, 2, 2, 1, 2];
        let pairs: Vec<(usize, usize)> = (0..8).map(|k| (k, k + 3)).collect();
        let of = |s: u8| -> Vec<PairMatch> {
            pairs
                .iter()
                .zip(&steps)
                .filter(|(_, t)| **t == s)
                .map(|(p, _)| matched(*p))
                .collect()
        };
        let got = in_steps(&steps, of(1), of(2)).unwrap();
        let got: Vec<(usize, usize)> = got.iter().map(|m| (m.a, m.b)).collect();
        assert_eq!(got, pairs);
        // Counts that are not the steps' are refused, not paired up wrongly.
        assert!(in_steps(&steps, of(2), of(1)).is_err());
        assert!(in_steps(&steps, of(1), vec![]).is_err());
    }

    #[test]
    fn a_step_guide_travels_to_the_bit_and_only_for_its_flight() {
        let r = aerorect_core::CameraRotation::omega_phi_kappa(0.1 + 0.2, -1.3e-3, 271.7).unwrap();
        let pose = |e: f64| {
            Pose::new(
                [512_345.678_9 + e, 5_974_321.012_3, 0.1 + 0.2],
                r.ground_from_camera(),
            )
        };
        let k = aerorect_core::Intrinsics::new(3666.6667, 3666.6666, 2735.7, 1823.3).unwrap();
        let camera = Camera::new(k, None, ImageSize::new(5472, 3648));
        let g = StepGuide {
            orientation: Orientation {
                poses: vec![pose(0.0), pose(1.0 / 3.0)],
                cameras: vec![camera.clone(), camera],
            },
            placed: vec![true, false],
            start: Corrections::from_values(2, 1, &vec![0.1 + 0.2; Corrections::value_count(2, 1)])
                .unwrap(),
            surface: None,
        };
        let text = g.to_json().unwrap();
        let back = StepGuide::from_json(&text, 2).unwrap();
        assert_eq!(back.orientation, g.orientation);
        assert_eq!(back.placed, g.placed);
        assert_eq!(back.start, g.start);
        assert!(back.surface.is_none());
        // The first step's tie surface (a flight without a DEM) travels with it.
        let sample = crate::flight::exchange::tests::bit_surface();
        let surfaced = StepGuide {
            surface: Some(sample.0.clone()),
            ..g.clone()
        };
        let back = StepGuide::from_json(&surfaced.to_json().unwrap(), 2).unwrap();
        crate::flight::exchange::tests::assert_same_surface(&back.surface.unwrap(), &sample);
        let e = StepGuide::from_json(&text, 3).unwrap_err().to_string();
        assert!(e.contains("3 frames"), "{e}");
    }
}
