//! The first round's tie points from SIFT features of the photos themselves: they need no
//! attitude and tolerate rotation, scale and viewpoint, so frames recorded 10-20 degrees off,
//! with no attitude at all or flown in opposite directions still tie. Candidate pairs come
//! from the recorded positions and predicted footprints; matches pass the ratio and mutual
//! tests and a fundamental matrix (RANSAC), so relief does not reject them.

use super::*;
use crate::features::{
    FrameFeatures, PairTies, Prediction, TieOptions, match_frames, match_frames_within,
    raster_features,
};
use aerorect_solve::pairs::candidate_pairs;
use aerorect_solve::ransac::RansacOptions;

/// Where a flight's tie points come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum TieSource {
    /// Features first (no attitude needed), then correlation of the rendered frames refines
    /// in later rounds: where it ties a pair its matches replace the pair's features in the
    /// rounds' solves, which hold the pairs it cannot tie. Over a DEM the solve that ends the
    /// rounds takes both, each weighed by its own agreement ([`super::SourceWeights`]); where
    /// the features agree at least as well, no correlation round is run.
    #[default]
    Both,
    /// Features only: one round (they do not depend on the orientation).
    Features,
    /// Correlation of the rendered frames only (the recorded attitudes must be within a few
    /// degrees).
    Correlation,
}

impl TieSource {
    /// The source named `both`, `features` or `correlation`.
    pub fn from_name(name: &str) -> Result<Self, Error> {
        match name {
            "both" => Ok(Self::Both),
            "features" => Ok(Self::Features),
            "correlation" => Ok(Self::Correlation),
            other => Err(Error::Invalid(format!(
                "tie points from '{other}': expected both, features or correlation"
            ))),
        }
    }
}

/// The most tie points one pair gives from its features, one per cell of a grid over the
/// inliers ([`spread`]): enough to hold the pair, few enough that the solve stays small.
pub const FEATURE_TIES_PER_PAIR: usize = FEATURE_SPREAD_CELLS * FEATURE_SPREAD_CELLS;

/// The fewest verified matches that tie a pair by features: eight points fit a fundamental
/// matrix exactly, and two frames that share nothing give 8-12 chance "inliers" of 20-45
/// ratio-test matches; a real overlap gives dozens to hundreds.
pub const MIN_FEATURE_INLIERS: usize = 20;

/// A fundamental matrix lets a wrong match slide along its epipolar line; the matches must
/// also lie within this fraction of the frame's long side of one homography (flat ground
/// plus the relief's parallax).
const HOMOGRAPHY_SLACK: f64 = 0.05;

/// A feature tie's standard deviation, in pixels of the reduced frame (SIFT's sub-pixel
/// position on the reduced image).
const FEATURE_SIGMA_REDUCED_PX: f64 = 0.5;

impl FlightPlan {
    /// How frames are reduced and described for feature matching: a pair with fewer matches
    /// than [`MIN_FEATURE_INLIERS`] cannot tie, so it is not verified, and RANSAC gives up on
    /// a pair once a consensus of that many would have been found (`min_inliers`): most of
    /// the candidate pairs of a flight (8,406 on the 1,000-frame simulation, about 4,400 of
    /// them nearest neighbours, the rest predicted footprints' overlaps) share nothing, and
    /// ran all their iterations (F-RANSAC 22.9 -> 2.3 s of CPU there).
    pub fn tie_options(&self) -> TieOptions {
        let base = TieOptions::default();
        TieOptions {
            min_matches: MIN_FEATURE_INLIERS,
            ransac: RansacOptions {
                min_inliers: MIN_FEATURE_INLIERS,
                ..base.ransac
            },
            ..base
        }
    }

    /// Frame `k` decoded, reduced and described.
    pub fn frame_features(&self, k: usize) -> Result<FrameFeatures, Error> {
        let f = self.frames.get(k).ok_or_else(|| {
            Error::Invalid(format!("frame {k} of a flight of {} frames", self.len()))
        })?;
        let image = self.decoded.get_with_levels(k, &f.input)?;
        let mut features = timing::time("features: sift", || {
            raster_features(&f.input, &image, &self.tie_options())
        })?;
        features.ground = self.keypoints_on_ground(k, &features);
        Ok(features)
    }

    /// Every frame's recorded position on the map (x, y).
    pub(super) fn recorded_centres(&self) -> Vec<[f64; 2]> {
        self.rec
            .poses
            .iter()
            .map(|p| [p.centre[0], p.centre[1]])
            .collect()
    }

    /// The pairs to match by features: the nearest neighbours and Delaunay neighbours of the
    /// recorded positions, and every pair whose predicted footprints overlap.
    /// None when the ties come from correlation alone.
    pub fn feature_pairs(&self) -> Result<Vec<(usize, usize)>, Error> {
        if self.fo.ties == TieSource::Correlation {
            return Ok(vec![]);
        }
        let centres = self.recorded_centres();
        let footprints: Vec<Vec<[f64; 2]>> = self
            .frames
            .iter()
            .map(|f| f.coarse_plan.footprint.clone())
            .collect();
        let usable = footprints.iter().all(|f| f.len() >= 3);
        let opts = self.tie_options().pairs;
        candidate_pairs(&centres, usable.then_some(&footprints[..]), &opts)
            .map_err(Error::context("candidate pairs"))
    }

    /// Frames `i` and `j` matched by their features (guided where the orientation in `basis`
    /// bounds the search, see `guide`; `a`'s ground positions must be by that orientation,
    /// [`Self::step_ground`]): the pair's tie points, each with its first guess on the ground
    /// where frame `i`'s recorded ray meets the ground.
    pub fn feature_match(
        &self,
        basis: Basis<'_>,
        (i, a): (usize, &FrameFeatures),
        (j, b): (usize, &FrameFeatures),
    ) -> Result<PairMatch, Error> {
        if i.max(j) >= self.len() {
            return Err(Error::Invalid(format!(
                "pair ({i}, {j}) of a flight of {} frames",
                self.len()
            )));
        }
        let (m, inliers) = self.verified_matches(basis, (i, a), (j, b))?;
        // A relative weight: the adjustment's pixel sigma is a correlation tie's (0.5 px at
        // full resolution); a feature's is its reduced position's, scaled up.
        let factor = a.factor.max(b.factor) as f64;
        let sigma = FEATURE_SIGMA_REDUCED_PX * factor;
        let weight = (0.5 / sigma).powi(2).min(1.0);
        let at_a: Vec<[f64; 2]> = inliers.iter().map(|&k| m.first_px[k]).collect();
        let (pose, camera) = (&self.rec.poses[i], &self.rec.cameras[self.rec.camera_of[i]]);
        let tie = |k: usize| {
            let ground = on_ground(pose, camera, m.first_px[k], self.ground.as_ref())?;
            Some(PairTie {
                ground,
                pixel_a: m.first_px[k],
                pixel_b: m.second_px[k],
                weight,
            })
        };
        // The rounds' solves take the spread ties; the rest are spare, for the solve that
        // ends the rounds.
        let (kept, rest) = split_kept(
            inliers.iter().copied(),
            &spread(&at_a, FEATURE_SPREAD_CELLS, |_| 0.0),
        );
        let ties: Vec<PairTie> = kept.into_iter().filter_map(tie).collect();
        let at_rest: Vec<[f64; 2]> = rest.iter().map(|&k| m.first_px[k]).collect();
        let spare: Vec<PairTie> = spread(&at_rest, FEATURE_SPARE_CELLS, |_| 0.0)
            .into_iter()
            .filter_map(|i| tie(rest[i]))
            .collect();
        let enough = inliers.len() >= MIN_FEATURE_INLIERS;
        Ok(PairMatch {
            a: i,
            b: j,
            patches: m.inliers.len(),
            inliers: if enough { ties.len() } else { 0 },
            ties: if enough { ties } else { vec![] },
            spare: if enough { spare } else { vec![] },
            features: true,
        })
    }

    /// Every frame's features and every candidate pair's matches (the first round's), in
    /// [`Self::feature_pairs`]' order, in the steps [`Self::feature_steps`] gives them, and
    /// the first step's solve when there were two.
    pub fn feature_matches(&self) -> Result<(Vec<PairMatch>, Option<StepGuide>), Error> {
        let pairs = self.feature_pairs()?;
        if pairs.is_empty() {
            return Ok((vec![], None));
        }
        let mut features: Vec<FrameFeatures> = timing::time("features: frames (wall)", || {
            (0..self.len())
                .into_par_iter()
                .map(|k| self.frame_features(k))
                .collect::<Result<_, _>>()
        })?;
        let steps = self.feature_steps(&pairs)?;
        let in_step = |s: u8| -> Vec<(usize, usize)> {
            pairs
                .iter()
                .zip(&steps)
                .filter_map(|(&p, &t)| (t == s).then_some(p))
                .collect()
        };
        let match_all = |pairs: &[(usize, usize)], basis: Basis<'_>, features: &[FrameFeatures]| {
            timing::time("features: pairs (wall)", || {
                pairs
                    .par_iter()
                    .map(|&(i, j)| self.feature_match(basis, (i, &features[i]), (j, &features[j])))
                    .collect::<Result<Vec<_>, Error>>()
            })
        };
        let second_pairs = in_step(2);
        if second_pairs.is_empty() {
            let first = match_all(&in_step(1), Basis::Recorded, &features)?;
            return Ok((first, None));
        }
        let first = match_all(&in_step(1), Basis::FirstStep, &features)?;
        let guide = self.step_guide(&first);
        let basis = guide.as_ref().map_or(Basis::Recorded, Basis::Stepped);
        if let Some(g) = &guide {
            features
                .par_iter_mut()
                .enumerate()
                .for_each(|(k, f)| self.step_features(g, k, f));
        }
        let second = match_all(&second_pairs, basis, &features)?;
        Ok((in_steps(&steps, first, second)?, guide))
    }

    /// The first round's matches: [`Self::feature_matches`] unless the ties come from
    /// correlation alone; none when no pair's features agree (correlation then starts). And
    /// the first step's solve, when there were two steps.
    pub fn first_round_matches(&self) -> Result<(Vec<PairMatch>, Option<StepGuide>), Error> {
        let (matches, guide) = self.feature_matches()?;
        Ok((Self::first_round_of(matches), guide))
    }

    /// The feature matches of every candidate pair as the first round takes them: all of
    /// them when any pair is reliable, else none.
    pub fn first_round_of(matches: Vec<PairMatch>) -> Vec<PairMatch> {
        if matches.iter().any(PairMatch::reliable) {
            matches
        } else {
            vec![]
        }
    }

    /// Frames `i` and `j`'s matches and the indices of those verified: guided by the recorded
    /// orientation where it is known well enough ([`FlightPlan::guide`]), and matched again in
    /// full when a guided pair predicted to overlap does not tie.
    fn verified_matches(
        &self,
        basis: Basis<'_>,
        (i, a): (usize, &FrameFeatures),
        (j, b): (usize, &FrameFeatures),
    ) -> Result<(PairTies, Vec<usize>), Error> {
        let opts = self.tie_options();
        let verify = |m: &PairTies| {
            timing::time("features: H-RANSAC", || {
                near_one_homography(m, a.size.width.max(a.size.height))
            })
        };
        if let Some(g) = self.guide(basis, (i, a), (j, b)) {
            let window = Some(Prediction {
                query_at: &g.query_at,
                radius: g.radius,
                accept: g.accept,
            });
            let m = match_frames_within(a, b, (i, j), &opts, window)?;
            let inliers = verify(&m);
            if inliers.len() >= MIN_FEATURE_INLIERS || g.inside < GUIDE_RETRY_OVERLAP {
                return Ok((m, inliers));
            }
            timing::add("features: guided, matched again", 0.0);
        }
        let m = match basis {
            Basis::FirstStep => {
                let k = FIRST_STEP_KEYPOINTS;
                match_frames(&strongest(a, k), &strongest(b, k), (i, j), &opts)?
            }
            _ => match_frames(a, b, (i, j), &opts)?,
        };
        let inliers = verify(&m);
        Ok((m, inliers))
    }
}

/// `f` with only its `k` strongest keypoints (by response, the earlier first among equals),
/// in their order in `f`; `f` itself when it has no more.
fn strongest(f: &FrameFeatures, k: usize) -> std::borrow::Cow<'_, FrameFeatures> {
    let kps = &f.features.keypoints;
    if kps.len() <= k {
        return std::borrow::Cow::Borrowed(f);
    }
    let mut order: Vec<usize> = (0..kps.len()).collect();
    order.sort_by(|&x, &y| kps[y].response.total_cmp(&kps[x].response).then(x.cmp(&y)));
    order.truncate(k);
    order.sort_unstable();
    let d = f.features.descriptors.len() / kps.len();
    let pick = |q: &usize| &f.features.descriptors[q * d..(q + 1) * d];
    std::borrow::Cow::Owned(FrameFeatures {
        features: aerorect_raster::features::Features {
            keypoints: order.iter().map(|&q| kps[q]).collect(),
            descriptors: order.iter().flat_map(pick).copied().collect(),
        },
        ground: match f.ground.len() == kps.len() {
            true => order.iter().map(|&q| f.ground[q]).collect(),
            false => f.ground.clone(),
        },
        path: f.path.clone(),
        size: f.size,
        factor: f.factor,
        seconds: f.seconds,
        bytes: Default::default(),
    })
}

/// The matches of both steps in the order of the pairs `steps` gives (1 or 2 per pair):
/// `first`'s and `second`'s each in their own order. An error when their counts are not the
/// steps'.
pub fn in_steps(
    steps: &[u8],
    first: Vec<PairMatch>,
    second: Vec<PairMatch>,
) -> Result<Vec<PairMatch>, Error> {
    let ones = steps.iter().filter(|&&s| s == 1).count();
    if first.len() != ones || second.len() != steps.len() - ones {
        return Err(Error::Invalid(format!(
            "{} first-step and {} second-step matches for {ones} and {} pairs",
            first.len(),
            second.len(),
            steps.len() - ones
        )));
    }
    let (mut first, mut second) = (first.into_iter(), second.into_iter());
    Ok(steps
        .iter()
        .filter_map(|&s| match s {
            1 => first.next(),
            _ => second.next(),
        })
        .collect())
}

/// The fundamental matrix's inliers that also lie within [`HOMOGRAPHY_SLACK`] of the long
/// side (`long_px`) of one homography (none when no homography fits, or when there are fewer
/// than [`MIN_FEATURE_INLIERS`] to fit).
fn near_one_homography(m: &PairTies, long_px: usize) -> Vec<usize> {
    let kept: Vec<usize> = (0..m.inliers.len()).filter(|&k| m.inliers[k]).collect();
    if kept.len() < MIN_FEATURE_INLIERS {
        // Too few to tie the pair whatever the homography keeps.
        return vec![];
    }
    let from: Vec<[f64; 2]> = kept.iter().map(|&k| m.first_px[k]).collect();
    let to: Vec<[f64; 2]> = kept.iter().map(|&k| m.second_px[k]).collect();
    let opts = aerorect_solve::ransac::RansacOptions {
        threshold: HOMOGRAPHY_SLACK * long_px as f64,
        ..Default::default()
    };
    match ransac_homography(&from, &to, &opts) {
        Ok(fit) => kept
            .into_iter()
            .zip(fit.inliers)
            .filter_map(|(k, ok)| ok.then_some(k))
            .collect(),
        Err(_) => vec![],
    }
}
