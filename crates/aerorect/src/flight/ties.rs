//! A pair's tie points as the adjustment takes them, and how far apart a pair's frames put
//! them on the ground.

use super::*;

/// Where a frame pixel's ray meets the level `z` (world x, y).
pub(super) fn on_level(pose: &Pose, camera: &Camera, px: [f64; 2], z: f64) -> Option<[f64; 2]> {
    pose.level_point(
        pose.world_direction(camera.ray_from_pixel(px[0], px[1])?),
        z,
    )
}

/// What matching one pair of frames (indices `a`, `b`) found, as the adjustment takes it; it
/// travels between processes as [`exact_json`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairMatch {
    pub a: usize,
    pub b: usize,
    pub patches: usize,
    pub inliers: usize,
    /// The pair's tie points (none unless at least 8 matches agree): for correlation, those
    /// [`spread`] keeps, which every round's solve takes.
    pub ties: Vec<PairTie>,
    /// The pair's other reliable ties, those [`spread`] left out (every other inlier): only
    /// the solve that ends the rounds takes them too (see
    /// [`super::FlightOptions::final_all_ties`]). Empty for a pair that does not tie or has
    /// no more ties than the spread's cells.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub spare: Vec<PairTie>,
    /// Whether they come from features (3-D points anywhere) rather than correlation on the
    /// level ground.
    #[serde(default)]
    pub features: bool,
}

/// A tie point of a pair: its first guess on the ground, its pixel in each frame and weight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PairTie {
    pub ground: [f64; 3],
    pub pixel_a: [f64; 2],
    pub pixel_b: [f64; 2],
    pub weight: f64,
}

impl PairMatch {
    /// The ties a solve takes: the spread ones, and with `all` the spare ones after them.
    pub(super) fn solve_ties(&self, all: bool) -> impl Iterator<Item = &PairTie> {
        let spare: &[PairTie] = if all { &self.spare } else { &[] };
        self.ties.iter().chain(spare)
    }

    /// Whether the pair gives tie points (correlation: at least [`super::correlate::MIN_CORRELATION_INLIERS`] matches agree; features:
    /// at least [`super::MIN_FEATURE_INLIERS`]); a pair gives ties only when it qualifies.
    pub(super) fn reliable(&self) -> bool {
        !self.ties.is_empty()
    }
}

impl PairTie {
    pub(super) fn tie_point(&self, a: usize, b: usize) -> TiePoint {
        let obs = |frame, pixel| Observation {
            frame,
            pixel,
            weight: self.weight,
        };
        TiePoint {
            ground: self.ground,
            observations: vec![obs(a, self.pixel_a), obs(b, self.pixel_b)],
            control: None,
        }
    }
}

/// The ground under a flight: height at (x, y) in its world CRS.
pub(super) type GroundFn<'a> = &'a (dyn Fn(f64, f64) -> f64 + Sync);

/// Median ground distance between the two frames' rays of each tie (at the height where the
/// first frame's ray meets the ground: see [`tie_gap`]).
pub(super) fn misalignment(
    ties: &[TiePoint],
    poses: &[Pose],
    cameras: &[&Camera],
    ground: GroundFn<'_>,
) -> f64 {
    let mut d: Vec<f64> = ties
        .iter()
        .filter_map(|t| tie_gap(t, poses, cameras, ground).map(|g| g[0].hypot(g[1])))
        .collect();
    median(&mut d).unwrap_or(f64::NAN)
}

/// The median of `v` (the upper one of an even count), reordering it; none when empty.
pub(super) fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let k = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(k, f64::total_cmp);
    Some(*m)
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

/// The two frames' ground points of a two-frame tie, b to a, at the height where frame a's
/// ray meets the ground with these poses: where the two orthos put the point. (At the tie's
/// own first guess instead, a start 5-30 degrees off put that height metres wrong and the
/// gap of well-adjusted rays metres wide on long baselines.)
pub(super) fn tie_gap(
    t: &TiePoint,
    poses: &[Pose],
    cameras: &[&Camera],
    ground: GroundFn<'_>,
) -> Option<[f64; 2]> {
    let [a, b] = [t.observations.first()?, t.observations.get(1)?];
    let pa = on_ground(&poses[a.frame], cameras[a.frame], a.pixel, ground)?;
    let pb = on_level(&poses[b.frame], cameras[b.frame], b.pixel, pa[2])?;
    Some([pa[0] - pb[0], pa[1] - pb[1]])
}

/// How far apart (m) the two frames' rays of a two-frame tie pass (the length of their
/// common perpendicular): its disagreement without a ground, wherever its point is. The part
/// of an error along the pair's base moves the point's height instead, and is not seen.
pub(super) fn ray_gap(t: &TiePoint, poses: &[Pose], cameras: &[&Camera]) -> Option<f64> {
    let [a, b] = [t.observations.first()?, t.observations.get(1)?];
    let ray = |o: &Observation| -> Option<aerorect_core::Vec3> {
        let d = cameras
            .get(o.frame)?
            .ray_from_pixel(o.pixel[0], o.pixel[1])?;
        Some(poses.get(o.frame)?.world_direction(d).normalize())
    };
    let normal = ray(a)?.cross(&ray(b)?);
    let sine = normal.norm();
    let [ca, cb] = [poses.get(a.frame)?.centre, poses.get(b.frame)?.centre];
    let base = aerorect_core::Vec3::new(cb[0] - ca[0], cb[1] - ca[1], cb[2] - ca[2]);
    (sine > 1e-9).then(|| base.dot(&normal).abs() / sine)
}

/// Where the ray of `pixel` meets the ground (three steps of the height under it).
pub(super) fn on_ground(
    pose: &Pose,
    camera: &Camera,
    pixel: [f64; 2],
    ground: &(dyn Fn(f64, f64) -> f64 + Sync),
) -> Option<[f64; 3]> {
    let mut z = ground(pose.centre[0], pose.centre[1]);
    let mut p = on_level(pose, camera, pixel, z)?;
    for _ in 0..3 {
        z = ground(p[0], p[1]);
        p = on_level(pose, camera, pixel, z)?;
    }
    Some([p[0], p[1], z])
}

/// The cells per side of the grid over a pair's inliers that [`spread`] keeps one feature tie
/// per cell of: at most 36 per pair. Features tie the first round, from attitudes degrees off;
/// correlation refines the pairs it ties in later rounds, so a pair's features need only hold
/// it, and up to 150 of them (half a few pixels apart) made the first solve the longest.
/// The solve that ends the rounds takes more of them (the rest, thinned by
/// [`FEATURE_SPARE_CELLS`], travel as [`PairMatch::spare`]; see
/// [`super::FlightOptions::final_all_ties`]).
pub const FEATURE_SPREAD_CELLS: usize = 6;

/// The cells per side of the grid that thins a pair's other inliers, one per cell, to its
/// spare ties (at most 144 beside the 36). On the 1,000-frame fixed-wing simulation, whose
/// pairs have about 230 inliers, the solve that ends the rounds with every inlier took
/// 3,486,946 ties, 54 s and 10.3 GB (the whole flight), 0.0134 / 0.0536 deg from the truth
/// (median / max); thinned, 2,064,977 ties, 35 s and 6.9 GB, 0.0157 / 0.0632 deg; at 8 cells
/// 1,507,493 ties, 39 s (8 iterations instead of 5), 0.0189 / 0.0791 deg.
pub const FEATURE_SPARE_CELLS: usize = 12;

/// The same for correlation ties (patches overlapping by half): at most 64 per pair in the
/// rounds' solves. At 36 the 100-frame simulation's median attitude error after adjustment rose
/// from 0.008 to 0.011 degrees. The solve that ends the rounds takes every reliable tie
/// instead (the rest travel as [`PairMatch::spare`]; see
/// [`super::FlightOptions::final_all_ties`]).
pub const CORRELATION_SPREAD_CELLS: usize = 8;

/// The indices (ascending) of a well-spread subset of `points` (a pair's ties in one frame's
/// pixels): over a `n`-square grid on their bounding box, the point of the highest `score` in
/// each cell (the first of equals). A pair's redundant ties add to the solve's time in
/// proportion and little to its geometry.
pub(super) fn spread(points: &[[f64; 2]], n: usize, score: impl Fn(usize) -> f64) -> Vec<usize> {
    if points.len() <= n * n {
        return (0..points.len()).collect();
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let cell = |p: &[f64; 2], k: usize| {
        let span = (hi[k] - lo[k]).max(1e-9);
        (((p[k] - lo[k]) / span * n as f64) as usize).min(n - 1)
    };
    let mut best: Vec<Option<usize>> = vec![None; n * n];
    for (i, p) in points.iter().enumerate() {
        let c = cell(p, 1) * n + cell(p, 0);
        if best[c].is_none_or(|b| score(i) > score(b)) {
            best[c] = Some(i);
        }
    }
    let mut out: Vec<usize> = best.into_iter().flatten().collect();
    out.sort_unstable();
    out
}

/// `items` split into those whose index is in `kept` (ascending, as [`spread`] gives them) and
/// the rest, each in its order: a pair's ties for every round's solve and its spare ones.
pub(super) fn split_kept<T>(
    items: impl IntoIterator<Item = T>,
    kept: &[usize],
) -> (Vec<T>, Vec<T>) {
    let (mut kept_items, mut rest) = (Vec::new(), Vec::new());
    let mut next = kept.iter().peekable();
    for (k, item) in items.into_iter().enumerate() {
        match next.next_if_eq(&&k) {
            Some(_) => kept_items.push(item),
            None => rest.push(item),
        }
    }
    (kept_items, rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two nadir frames 100 m up and 30 m apart along x (f = 1000 px): a tie's error along
    /// the base moves its point's height and leaves the rays meeting (gap 0); one of e px
    /// across it (frame b's ray moved e / 10 m sideways at the ground, through the pair's
    /// midpoint) leaves them the length of the common perpendicular of the two lines apart,
    /// written out here for the directions (15, 0, -100) and (-15, e / 10, -100).
    #[test]
    fn rays_gap_across_the_base_and_meet_along_it() {
        let camera = Camera::new(
            aerorect_core::Intrinsics::new(1000.0, 1000.0, 500.0, 500.0).unwrap(),
            None,
            ImageSize::new(1000, 1000),
        );
        let cameras = [&camera, &camera];
        let at = |x: f64| Pose::new([x, 0.0, 100.0], &aerorect_core::Mat3::identity());
        let poses = [at(0.0), at(30.0)];
        let tie = |b: [f64; 2]| {
            PairTie {
                ground: [15.0, 0.0, 0.0],
                pixel_a: [650.0, 500.0],
                pixel_b: b,
                weight: 1.0,
            }
            .tie_point(0, 1)
        };
        let exact = ray_gap(&tie([350.0, 500.0]), &poses, &cameras).unwrap();
        assert!(exact < 1e-9, "{exact}");
        let along = ray_gap(&tie([357.0, 500.0]), &poses, &cameras).unwrap();
        assert!(along < 1e-9, "{along}");
        for e in [0.3, 2.0, 25.0] {
            let got = ray_gap(&tie([350.0, 500.0 - e]), &poses, &cameras).unwrap();
            // |base . (da x db)| / |da x db| with base (30, 0, 0), da (15, 0, -100),
            // db (-15, s, -100), s = e / 10: da x db = (100 s, 3000, 15 s).
            let s = e / 10.0;
            let want = 30.0 * 100.0 * s
                / ((100.0 * s).powi(2) + 3000f64.powi(2) + (15.0 * s).powi(2)).sqrt();
            assert!(
                (got - want).abs() < 1e-9 * want.max(1.0),
                "{e}: {got} vs {want}"
            );
            assert!((got / s - 1.0).abs() < 0.01 || e > 10.0, "{e}: {got}");
        }
        // Parallel rays (both frames at one point) have no common perpendicular.
        assert!(ray_gap(&tie([650.0, 500.0]), &[poses[0], poses[0]], &cameras).is_none());
    }

    #[test]
    fn split_kept_is_a_filter_by_index_and_its_complement() {
        let items: Vec<u32> = (0..12).map(|k| 100 + k).collect();
        let kept = [0, 3, 4, 11];
        let (a, b) = split_kept(items.iter().copied(), &kept);
        let want: Vec<u32> = (0..12)
            .filter(|k| kept.contains(k))
            .map(|k| 100 + k as u32)
            .collect();
        let rest: Vec<u32> = (0..12)
            .filter(|k| !kept.contains(k))
            .map(|k| 100 + k as u32)
            .collect();
        assert_eq!((a, b), (want, rest));
        assert_eq!(split_kept(items, &[]).0, Vec::<u32>::new());
    }

    #[test]
    fn spread_keeps_the_best_tie_of_each_cell() {
        // A 20 x 20 grid of ties: a 4 x 4 grid of cells over them keeps 16, one per cell of
        // 5 x 5 ties, the highest score of each.
        let points: Vec<[f64; 2]> = (0..400)
            .map(|k| [(k % 20) as f64, (k / 20) as f64])
            .collect();
        let score = |k: usize| ((k * 7919) % 400) as f64;
        let kept = spread(&points, 4, score);
        assert_eq!(kept.len(), 16);
        assert!(kept.windows(2).all(|w| w[0] < w[1]));
        for &k in &kept {
            let cell = |p: [f64; 2]| {
                (
                    (p[0] / 5.0).min(3.0) as usize,
                    (p[1] / 5.0).min(3.0) as usize,
                )
            };
            let best = (0..400)
                .filter(|&j| cell(points[j]) == cell(points[k]))
                .map(score)
                .fold(f64::MIN, f64::max);
            assert_eq!(score(k), best);
        }
        // Few ties are all kept.
        assert_eq!(spread(&points[..10], 4, score), (0..10).collect::<Vec<_>>());
    }
}
