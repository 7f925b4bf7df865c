//! Gauge freedoms: motions of the frames the ties cannot see, held before solving.
//!
//! Frames taken from one point (a hover, a panorama) see the ground along the same rays: a
//! common shift of their positions, and any shift along those rays, leaves every tie where it
//! was. Such frames are found geometrically: the frames the ties join (a connected set) whose
//! centres all lie within [`ONE_POINT_RATIO`] of their distance to the ground they tie. Their
//! positions are held (the attitudes, the cameras and the points are solved): at their fixes'
//! mean where the fixes lie within the GPS's noise of each other ([`NOISE_BASELINE_SIGMAS`]),
//! else as recorded.

use super::{AdjustFrame, TiePoint};
use aerorect_core::Vec3;
use serde::Serialize;

/// Frames whose largest baseline is below this fraction of their median range to their tie
/// points are taken as seen from one point (0.02: rays from the two ends meet at a
/// ground point at less than 1.2 degrees).
pub const ONE_POINT_RATIO: f64 = 0.02;

/// Whether frames whose largest baseline is `baseline_m` see what lies `range_m` from them as
/// from one point ([`ONE_POINT_RATIO`]).
pub fn one_point(baseline_m: f64, range_m: f64) -> bool {
    range_m > 0.0 && baseline_m < ONE_POINT_RATIO * range_m
}

/// A one-point set is held at its fixes' mean when its baseline is within this many standard
/// deviations of the difference of two fixes (sqrt 2 times the smallest position prior of the
/// set's frames, per axis). Such fixes differ by the receiver's noise, and held as recorded
/// they give rays from one point a parallax the photos do not have: two DJI frames hovering
/// 437 m from the ground they tie, their fixes 0.19 m apart (5 m priors), turned 4.6 and
/// 3.9 degrees from their recorded gimbal angles (1 degree priors) and ran to the solve's
/// iteration limit, to fit it. An RTK receiver's centimetres keep a real baseline as recorded.
pub const NOISE_BASELINE_SIGMAS: f64 = 3.0;

/// A gauge freedom found and how it was held.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct GaugeHold {
    /// The frames concerned (indices into the adjustment's frames).
    pub frames: Vec<usize>,
    /// Their largest baseline and median range to their tie points (m).
    pub baseline_m: f64,
    pub range_m: f64,
    /// What was held, in words.
    pub held: String,
    /// The point the frames' positions are held at: their fixes' mean where those differ by
    /// the receiver's noise ([`NOISE_BASELINE_SIGMAS`]); `None` where each is held as recorded.
    pub held_at: Option<[f64; 3]>,
}

/// The sets of frames the ties join (union-find over the tie points' observations), each
/// sorted, the frames no tie reaches left out.
pub fn connected(frames: usize, ties: &[TiePoint]) -> Vec<Vec<usize>> {
    connected_by(
        frames,
        ties.iter().flat_map(|t| {
            let first = t.observations.first().map(|o| o.frame);
            t.observations
                .iter()
                .filter_map(move |o| Some((first?, o.frame)))
        }),
    )
}

/// The sets of frames that links (a, b) join (union-find), each sorted, the frames no link
/// reaches left out.
pub fn connected_by(
    frames: usize,
    links: impl IntoIterator<Item = (usize, usize)>,
) -> Vec<Vec<usize>> {
    let mut parent: Vec<usize> = (0..frames).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut seen = vec![false; frames];
    for (a, b) in links {
        seen[a] = true;
        seen[b] = true;
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra] = rb;
    }
    let mut sets: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for f in (0..frames).filter(|&f| seen[f]) {
        let r = root(&mut parent, f);
        sets.entry(r).or_default().push(f);
    }
    sets.into_values().collect()
}

/// The connected sets of two or more frames seen from one point (`sigma_m`: the position prior
/// of a frame that gives none of its own).
pub(super) fn one_point_sets(
    frames: &[AdjustFrame],
    ties: &[TiePoint],
    sigma_m: f64,
) -> Vec<GaugeHold> {
    let mut out = Vec::new();
    for set in connected(frames.len(), ties) {
        if set.len() < 2 {
            continue;
        }
        let c: Vec<Vec3> = set.iter().map(|&f| Vec3::from(frames[f].centre)).collect();
        let baseline = c
            .iter()
            .flat_map(|a| c.iter().map(move |b| (a - b).norm()))
            .fold(0.0, f64::max);
        let mut ranges: Vec<f64> = ties
            .iter()
            .flat_map(|t| t.observations.iter().map(move |o| (o.frame, t.ground)))
            .filter(|(f, _)| set.binary_search(f).is_ok())
            .map(|(f, g)| (Vec3::from(g) - Vec3::from(frames[f].centre)).norm())
            .collect();
        // The median observation's range; the order of the rest does not matter (a sort of
        // the 1,000-frame flight's 3.2 M ranges was a third of a second on one thread).
        let mid = ranges.len() / 2;
        let range = match ranges.is_empty() {
            true => 0.0,
            false => *ranges.select_nth_unstable_by(mid, f64::total_cmp).1,
        };
        if one_point(baseline, range) {
            let sigma = set
                .iter()
                .flat_map(|&f| frames[f].position_sigma_or(sigma_m))
                .fold(f64::INFINITY, f64::min);
            let noise = baseline <= NOISE_BASELINE_SIGMAS * std::f64::consts::SQRT_2 * sigma;
            let held_at = noise.then(|| (c.iter().sum::<Vec3>() / c.len() as f64).into());
            let how = match noise {
                true => "positions held at their fixes' mean (they differ by the GPS's noise)",
                false => "positions held as recorded",
            };
            out.push(GaugeHold {
                frames: set,
                baseline_m: baseline,
                range_m: range,
                held: format!(
                    "{how}: frames from one point cannot place themselves from their ties"
                ),
                held_at,
            });
        }
    }
    out
}
