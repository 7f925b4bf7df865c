//! The two tie sources in the solve that ends the rounds: every reliable pair's features join
//! the correlation ties, each source weighted by how well its own ties agree.
//!
//! During the rounds a pair's correlation ties replace its features (the rounds' solves stay
//! small). The solve that ends them takes both: the features of the pairs correlation ties are
//! measurements of the same overlap, at the photos' resolution. How much each source is worth
//! is not known in advance: on rendered flights SIFT's ties agree better than the correlator's
//! (which sees frames resampled onto the coarse grid), on NGI's scanned aerial frames, reduced
//! to find their features, worse (their ties 3.2-4.2 m apart on the ground, correlation's
//! 1.4-1.9 m). So each source's weight is estimated from its own ties
//! (a variance component per source, as in a photogrammetric block adjustment): with the last
//! round's orientation, the median ground gap between where each tie's two frames put it is
//! taken per source, and a feature tie's weight becomes `(gap_correlation / gap_features)^2`
//! times the correlation tie's (whose sigma is the adjustment's pixel sigma).
//!
//! The features round weighs them too, before any correlation round: a sample of its reliable
//! pairs ([`SOURCE_SAMPLE_PAIRS`]) is rendered with the round's orientation and correlated, and
//! both sources' gaps are taken on those pairs alone. Without a DEM a tie's gap is taken
//! between its two rays ([`GapOn::Rays`]): the level ground would add the relief's parallax to
//! both sources' gaps alike (on the 1,000-frame fixed wing without its DEM, 2.9 m median for
//! ties that agree to a tenth of a pixel). Where the features agree at least as
//! well, a correlation round could only add ties that agree worse, and the rounds end with the
//! features (their spare ties too) in the last solve: on the 1,000-frame simulations the
//! features alone ended closer to the truth than both sources (fixed wing 0.0144 / 0.053 deg
//! median / max against 0.0157 / 0.063; nadir 0.0032 / 0.0133 against 0.0038 / 0.0163), and
//! the correlation round was a fifth of the flight's time. Without its DEM (GPS only, level
//! ground 25 m), weighed between the rays, the features held too: no correlation round,
//! 232.5 -> 126.5 s matched and adjusted, 0.068 / 0.476 -> 0.072 / 0.196 deg. On the senseFly
//! photos they do not, and the correlation rounds run as before.

use super::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Ties sampled per source for its median gap: enough for a median to 1 %, few enough to cost
/// nothing beside the solve.
const GAP_SAMPLE: usize = 20_000;

/// Reliable pairs of the features round sampled for its source weights (evenly taken in the
/// pairs' order): a correlated pair gives about 30 ties, so 64 give a median gap to a few
/// percent, for about 128 frames rendered.
pub const SOURCE_SAMPLE_PAIRS: usize = 64;

/// Each source's weight is held within this factor of the correlation tie's either way: a
/// source that seemed to agree a hundred times better than the other would be taken as exact.
const MAX_SOURCE_RATIO: f64 = 100.0;

/// Where a tie's gap is taken.
#[derive(Clone, Copy)]
pub(super) enum GapOn<'a> {
    /// On this ground (a DEM): where the two frames' orthos put the point ([`misalignment`]).
    Ground(GroundFn<'a>),
    /// Between the two frames' rays ([`ray_gap`]): without a DEM, whose level ground would
    /// add the relief's parallax to both sources' gaps alike.
    Rays,
}

/// The median gap (m) of the reliable pairs' ties of one source (`features`), with the
/// orientation `(poses, cameras)`, over at most [`GAP_SAMPLE`] of them evenly taken.
fn median_gap(
    matched: &[PairMatch],
    features: bool,
    (poses, cameras): (&[Pose], &[&Camera]),
    on: GapOn<'_>,
) -> Option<f64> {
    let source = || {
        matched
            .iter()
            .filter(move |m| m.features == features && m.reliable())
    };
    let count: usize = source().map(|m| m.solve_ties(true).count()).sum();
    let step = count.div_ceil(GAP_SAMPLE).max(1);
    let sample: Vec<TiePoint> = source()
        .flat_map(|m| m.solve_ties(true).map(move |t| (m.a, m.b, t)))
        .step_by(step)
        .map(|(a, b, t)| t.tie_point(a, b))
        .collect();
    let gap = match on {
        GapOn::Ground(ground) => misalignment(&sample, poses, cameras, ground),
        GapOn::Rays => {
            let mut d: Vec<f64> = sample
                .iter()
                .filter_map(|t| ray_gap(t, poses, cameras))
                .collect();
            median(&mut d).unwrap_or(f64::NAN)
        }
    };
    gap.is_finite().then_some(gap)
}

/// How well each source's ties agree, by a round's orientation, and the weight that gives a
/// feature tie (see the module).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SourceWeights {
    /// The median ground gap (m) of the reliable pairs' feature ties.
    pub feature_gap_m: f64,
    /// The same of the correlation ties.
    pub correlation_gap_m: f64,
    /// A feature tie's weight relative to a correlation tie's in the solve that ends the
    /// rounds: `(correlation_gap_m / feature_gap_m)^2`, within [`MAX_SOURCE_RATIO`] either way.
    pub feature_weight: f64,
    /// How many of the features round's reliable pairs were sampled and correlated for the
    /// gaps ([`SOURCE_SAMPLE_PAIRS`]; each gap is of the reliable ties of its source there);
    /// `None`: the gaps are of every reliable pair of a correlation round.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampled_pairs: Option<usize>,
}

impl SourceWeights {
    /// Both sources' gaps in `matched` by `orientation`; `None` when either has no reliable
    /// tie (nothing to weigh).
    pub(super) fn weigh(
        matched: &[PairMatch],
        orientation: (&[Pose], &[&Camera]),
        on: GapOn<'_>,
    ) -> Option<Self> {
        let correlation_gap_m = median_gap(matched, false, orientation, on)?;
        let feature_gap_m = median_gap(matched, true, orientation, on)?;
        let feature_weight = (correlation_gap_m / feature_gap_m)
            .powi(2)
            .clamp(1.0 / MAX_SOURCE_RATIO, MAX_SOURCE_RATIO);
        feature_weight.is_finite().then_some(Self {
            feature_gap_m,
            correlation_gap_m,
            feature_weight,
            sampled_pairs: None,
        })
    }

    /// Whether the features agree at least as well as correlation. Then the solve that ends
    /// the rounds is held by them, and another correlation round cannot move it: on the
    /// 1,000-frame fixed-wing simulation, 0.0157 / 0.0630 deg from the truth (median / max)
    /// after one correlation round and after two, the second 37 s. Measured on the features
    /// round's sample, no correlation round is run (see the module).
    pub(super) fn features_hold(&self) -> bool {
        self.feature_weight >= 1.0
    }

    /// The factor on every feature tie's weight that gives the typical one (the median of
    /// the reliable pairs' spread ties) [`Self::feature_weight`].
    pub(super) fn factor(&self, matched: &[PairMatch]) -> Option<f64> {
        let mut weights: Vec<f64> = matched
            .iter()
            .filter(|m| m.features && m.reliable())
            .flat_map(|m| m.ties.iter().map(|t| t.weight))
            .collect();
        weights.sort_by(f64::total_cmp);
        let factor = self.feature_weight / weights.get(weights.len() / 2)?;
        (factor.is_finite() && factor > 0.0).then_some(factor)
    }
}

impl FlightPlan {
    /// Where this flight's tie gaps are taken: on its DEM, else between the rays.
    pub(super) fn gap_on(&self) -> GapOn<'_> {
        match self.opts.dem.is_some() {
            true => GapOn::Ground(self.ground.as_ref()),
            false => GapOn::Rays,
        }
    }

    /// Both sources' weights on a sample of the features round's reliable pairs (`matched`,
    /// features only): each rendered with `orientation` and correlated; `None` when either
    /// source has no reliable tie there.
    pub(super) fn sampled_sources(
        &self,
        matched: &[PairMatch],
        orientation: &Orientation,
    ) -> Result<(Option<SourceWeights>, Sampled), Error> {
        let reliable: Vec<&PairMatch> = matched
            .iter()
            .filter(|m| m.features && m.reliable())
            .collect();
        let step = reliable.len().div_ceil(SOURCE_SAMPLE_PAIRS).max(1);
        let sample: Vec<&PairMatch> = reliable.into_iter().step_by(step).collect();
        let (rendered, correlated) = timing::time("sources: correlated sample (wall)", || {
            // Each frame rendered once for every sampled pair it is in (the senseFly photos'
            // 11 frames: 1.55 s of sample rendering them per pair).
            let frames: std::collections::BTreeSet<usize> =
                sample.iter().flat_map(|m| [m.a, m.b]).collect();
            let rendered: BTreeMap<usize, Rendered> = frames
                .into_par_iter()
                .map(|k| Ok((k, self.render_keeping(k, Some(orientation), false)?)))
                .collect::<Result<_, Error>>()?;
            let correlated: Vec<PairMatch> = sample
                .par_iter()
                .map(|m| match (rendered.get(&m.a), rendered.get(&m.b)) {
                    (Some(a), Some(b)) => self.match_rendered((m.a, a), (m.b, b)),
                    _ => Err(Error::Invalid(format!(
                        "pair ({}, {}) not rendered",
                        m.a, m.b
                    ))),
                })
                .collect::<Result<_, Error>>()?;
            Ok::<_, Error>((rendered, correlated))
        })?;
        let mut both: Vec<PairMatch> = sample.iter().map(|m| (*m).clone()).collect();
        both.extend(correlated.iter().cloned());
        let cams: Vec<&Camera> = orientation.cameras.iter().collect();
        let weights = SourceWeights::weigh(&both, (&orientation.poses, &cams), self.gap_on());
        let weights = weights.map(|w| SourceWeights {
            sampled_pairs: Some(sample.len()),
            ..w
        });
        let matched = correlated.into_iter().map(|m| ((m.a, m.b), m)).collect();
        Ok((weights, Sampled { rendered, matched }))
    }
}

/// What the features round's source sample rendered and correlated, with the orientation
/// the next round renders with: that round takes them rather than making them again (the
/// same frames and ties, bit for bit; within one process). On the senseFly photos the sample
/// is every reliable pair.
#[derive(Clone, Default)]
pub(super) struct Sampled {
    /// The sampled pairs' frames, by frame.
    rendered: BTreeMap<usize, Rendered>,
    /// The sampled pairs' correlation matches, by (a, b) as [`FlightPlan::match_rendered`]
    /// took them.
    matched: BTreeMap<(usize, usize), PairMatch>,
}

impl std::fmt::Debug for Sampled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sampled")
            .field("frames", &self.rendered.len())
            .field("pairs", &self.matched.len())
            .finish()
    }
}

impl Sampled {
    /// Frame `k` as the sample rendered it, taken out (each is used once).
    pub(super) fn take_rendered(&mut self, k: usize) -> Option<Rendered> {
        self.rendered.remove(&k)
    }

    /// Pair (a, b)'s correlation matches as the sample made them, taken out.
    pub(super) fn take_matched(&mut self, a: usize, b: usize) -> Option<PairMatch> {
        self.matched.remove(&(a, b))
    }
}

/// The matches the solve that ends the rounds takes, in `matched`'s order: every reliable
/// pair's correlation ties and features, each feature tie's weight times `factor`.
pub(super) fn both_sources(matched: &[PairMatch], factor: f64) -> Vec<PairMatch> {
    matched
        .iter()
        .map(|m| match m.features {
            false => m.clone(),
            true => {
                let scaled = |t: &PairTie| PairTie {
                    weight: t.weight * factor,
                    ..*t
                };
                PairMatch {
                    a: m.a,
                    b: m.b,
                    patches: m.patches,
                    inliers: m.inliers,
                    ties: m.ties.iter().map(scaled).collect(),
                    spare: m.spare.iter().map(scaled).collect(),
                    features: true,
                }
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use aerorect_core::{Intrinsics, Mat3};

    /// Two nadir frames at one point, 100 m over level ground at f = 1000 px: a tie whose two
    /// pixels differ by d px is d / 10 m apart on the ground.
    fn frames() -> (Vec<Pose>, Vec<Camera>) {
        let pose = Pose::new([0.0, 0.0, 100.0], &Mat3::identity());
        let camera = Camera::new(
            Intrinsics::new(1000.0, 1000.0, 500.0, 500.0).unwrap(),
            None,
            ImageSize::new(1000, 1000),
        );
        (vec![pose; 2], vec![camera.clone(), camera])
    }

    /// Frames 0 and 1's pair of these ties (from `features` or correlation), every one spread.
    fn of_ties(features: bool, ties: Vec<PairTie>) -> PairMatch {
        PairMatch {
            a: 0,
            b: 1,
            patches: ties.len(),
            inliers: ties.len(),
            ties,
            spare: vec![],
            features,
        }
    }

    /// A pair whose `n` ties differ between its frames by Gaussian errors of `sigma_px` per
    /// axis (the Rayleigh distribution's quantiles for their lengths, so that their median is
    /// exactly `sigma_px sqrt(2 ln 2)`), each of weight `weight`.
    fn pair(features: bool, sigma_px: f64, n: usize, weight: f64) -> PairMatch {
        let ties: Vec<PairTie> = (0..n)
            .map(|k| {
                let u = (k as f64 + 0.5) / n as f64;
                let r = sigma_px * (-2.0 * (1.0 - u).ln()).sqrt();
                let t = k as f64 * 2.399_963;
                let at = [
                    100.0 + (k % 25) as f64 * 30.0,
                    100.0 + (k / 25) as f64 * 30.0,
                ];
                PairTie {
                    ground: [0.0; 3],
                    pixel_a: at,
                    pixel_b: [at[0] + r * t.cos(), at[1] + r * t.sin()],
                    weight,
                }
            })
            .collect();
        of_ties(features, ties)
    }

    /// Each source's weight is its inverse variance relative to the other's: features with
    /// errors of 0.2 px beside correlation's 0.5 px weigh (0.5 / 0.2)^2 = 6.25 times as much,
    /// and a feature tie of nominal weight 0.25 gets 6.25 in the solve that ends the rounds.
    #[test]
    fn each_source_is_weighed_by_its_own_agreement() {
        let (poses, cameras) = frames();
        let cams: Vec<&Camera> = cameras.iter().collect();
        let level = |_: f64, _: f64| 0.0;
        let matched = vec![
            pair(false, 0.5, 500, 1.0),
            pair(true, 0.2, 500, 0.25),
            // Unreliable pairs (no ties) weigh nothing.
            pair(true, 5.0, 0, 0.25),
        ];
        let w = SourceWeights::weigh(&matched, (&poses, &cams), GapOn::Ground(&level)).unwrap();
        let median = |s: f64| s * (2.0 * 2f64.ln()).sqrt() / 10.0;
        assert!(
            (w.correlation_gap_m / median(0.5) - 1.0).abs() < 0.01,
            "{w:?}"
        );
        assert!((w.feature_gap_m / median(0.2) - 1.0).abs() < 0.01, "{w:?}");
        assert!((w.feature_weight / 6.25 - 1.0).abs() < 0.02, "{w:?}");
        assert!(w.features_hold());
        let both = both_sources(&matched, w.factor(&matched).unwrap());
        assert_eq!(both[0], matched[0]);
        for t in &both[1].ties {
            assert!((t.weight - w.feature_weight).abs() < 1e-12);
        }
        // Features 40 times worse than correlation weigh its hundredth at least.
        let worse = vec![pair(false, 0.5, 500, 1.0), pair(true, 20.0, 500, 1.0)];
        let w = SourceWeights::weigh(&worse, (&poses, &cams), GapOn::Ground(&level)).unwrap();
        assert_eq!(w.feature_weight, 1.0 / MAX_SOURCE_RATIO);
        assert!(!w.features_hold());
        // One source alone: nothing to weigh.
        assert!(
            SourceWeights::weigh(&matched[1..], (&poses, &cams), GapOn::Ground(&level)).is_none()
        );
    }

    /// A pair of the frames 30 m apart along x (otherwise as [`frames`]) whose `n` ties are
    /// off across the base by `across_px` times evenly spread fractions in -1..1 (median
    /// |error| half of it) and along it by `along_px` alternately either way.
    fn based(features: bool, across_px: f64, along_px: f64, n: usize) -> PairMatch {
        let ties: Vec<PairTie> = (0..n)
            .map(|k| {
                let u = 2.0 * (k as f64 + 0.5) / n as f64 - 1.0;
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                let at = [
                    350.0 + (k % 10) as f64 * 30.0,
                    200.0 + (k / 10 % 20) as f64 * 30.0,
                ];
                PairTie {
                    ground: [0.0; 3],
                    pixel_a: at,
                    pixel_b: [at[0] - 300.0 + sign * along_px, at[1] + across_px * u],
                    weight: 1.0,
                }
            })
            .collect();
        of_ties(features, ties)
    }

    /// Without a DEM each source's gap is taken between its rays: a feature tie's error along
    /// the base (a height the level ground does not know: its parallax) does not count
    /// against it. Features 5 px off along the base and 0.2 px across it hold against
    /// correlation's 0.5 px across by (0.5 / 0.2)^2 between the rays, and on the level
    /// ground would not.
    #[test]
    fn without_a_dem_the_sources_are_weighed_between_their_rays() {
        let (mut poses, cameras) = frames();
        poses[1] = Pose::new([30.0, 0.0, 100.0], &Mat3::identity());
        let cams: Vec<&Camera> = cameras.iter().collect();
        let matched = vec![based(false, 0.5, 0.0, 400), based(true, 0.2, 5.0, 400)];
        let w = SourceWeights::weigh(&matched, (&poses, &cams), GapOn::Rays).unwrap();
        // Half of the largest error across: 0.25 and 0.1 px, 0.1 m per px at 100 m.
        assert!((w.correlation_gap_m / 0.025 - 1.0).abs() < 0.02, "{w:?}");
        assert!((w.feature_gap_m / 0.01 - 1.0).abs() < 0.02, "{w:?}");
        assert!((w.feature_weight / 6.25 - 1.0).abs() < 0.05, "{w:?}");
        assert!(w.features_hold());
        let level = |_: f64, _: f64| 0.0;
        let on_level = SourceWeights::weigh(&matched, (&poses, &cams), GapOn::Ground(&level));
        assert!(!on_level.unwrap().features_hold(), "{on_level:?}");
    }

    fn round(turn: f64, held_by_features: bool) -> RoundSummary {
        RoundSummary {
            tie_points: 1,
            reliable_pairs: 1,
            rms_after_px: 0.1,
            largest_turn_deg: turn,
            median_turn_deg: turn,
            seconds: 0.0,
            final_solve: None,
            sources: None,
            held_by_features,
        }
    }

    /// Rounds the features held end settled whatever their last turn; others settle below
    /// the stop, and oscillate when the last turn is above half the smallest before it.
    #[test]
    fn rounds_held_by_features_are_settled() {
        let held = [round(7.5, false), round(0.023, true)];
        assert_eq!(settling(&held, 0.0128), (true, false));
        let open = [round(7.5, false), round(0.023, false)];
        assert_eq!(settling(&open, 0.0128), (false, false));
        let turns = [round(6.6, false), round(0.62, false), round(0.17, false)];
        assert!(!oscillates(&turns[..2], 0.17));
        assert!(oscillates(&turns, 0.357));
        assert!(!oscillates(&turns, 0.08));
    }

    /// The warning says the rounds oscillate only where the last turn rose above one before
    /// it; turns that still shrink, by less than half, stopped halving.
    #[test]
    fn the_warning_tells_rising_turns_from_turns_that_stopped_halving() {
        let rising = [round(6.27, false), round(0.34, false), round(0.45, false)];
        let w = rounds_warning(&rising, 0.0128, true);
        assert!(
            w.starts_with("the matching rounds oscillate in 3 rounds"),
            "{w}"
        );
        let slowing = [round(31.2, false), round(0.060, false), round(0.054, false)];
        assert!(oscillates(&slowing[..2], 0.054));
        let w = rounds_warning(&slowing, 0.0128, true);
        assert!(
            w.starts_with("the matching rounds stopped halving their turns in 3 rounds"),
            "{w}"
        );
        assert!(w.contains("31.200, 0.060, 0.054 deg per round"), "{w}");
        let capped = rounds_warning(&slowing, 0.0128, false);
        assert!(
            capped.starts_with("the matching rounds did not settle"),
            "{capped}"
        );
    }
}
