//! Tie points by correlation: frames rendered on the matching grid with the last round's
//! orientation, patches of each overlapping pair phase-correlated, RANSAC keeping the
//! matches one homography explains.

use super::*;
use aerorect_solve::significance::{ChanceModel, meaningful};

/// The fewest correlation matches one homography must explain for a pair to give ties.
pub const MIN_CORRELATION_INLIERS: usize = 8;

/// The overlap of two frames' grids in A's pixels: [c0, r0, c1, r1) and B's offset.
pub(super) fn overlap(ga: &OrthoGrid, gb: &OrthoGrid) -> Option<([i64; 4], [i64; 2])> {
    let g = ga.gsd;
    let off = [
        ((gb.top_left[0] - ga.top_left[0]) / g).round() as i64,
        ((ga.top_left[1] - gb.top_left[1]) / g).round() as i64,
    ];
    let [c0, r0, c1, r1] = aerorect_geo::common_window(ga.size, gb.size, off);
    (c1 > c0 && r1 > r0).then_some(([c0, r0, c1, r1], off))
}

/// A patch of a raster at (c, r) of `side` px, or `None` if it has nodata or no texture
/// (variance at most [`MIN_PATCH_VARIANCE`]).
pub(super) fn patch(img: &Raster<f32>, c: usize, r: usize, side: usize) -> Option<Vec<f32>> {
    let w = img.size().width;
    let mut out = Vec::with_capacity(side * side);
    for y in r..r + side {
        out.extend_from_slice(&img.plane(0)[y * w + c..y * w + c + side]);
    }
    // A fold, not `any`: no early exit, so the test vectorises (patches are nearly always
    // whole).
    if !out.iter().fold(true, |ok, v| ok & v.is_finite()) {
        return None;
    }
    (variance(&out) > MIN_PATCH_VARIANCE).then_some(out)
}

/// A patch whose gray values vary less than this (squared levels) has no texture to match.
const MIN_PATCH_VARIANCE: f64 = 4.0;

/// Lanes of [`variance`]'s sums.
const SUM_LANES: usize = 16;

/// Population variance of `v` (at least one value): mean, then mean squared deviation, each
/// summed in [`SUM_LANES`] f32 running sums that vectorise and are then added in f64 (one
/// serial f32 sum per pass was 2-6 % of a flight's CPU, and less accurate).
fn variance(v: &[f32]) -> f64 {
    let n = v.len() as f64;
    let mean = (lane_sum(v, |x| x) / n) as f32;
    lane_sum(v, |x| (x - mean) * (x - mean)) / n
}

/// The sum of `f` over `v` in [`SUM_LANES`] running f32 sums, added in f64 at the end.
fn lane_sum(v: &[f32], f: impl Fn(f32) -> f32) -> f64 {
    let mut lanes = [0f32; SUM_LANES];
    let chunks = v.chunks_exact(SUM_LANES);
    let tail: f64 = chunks.remainder().iter().map(|&x| f(x) as f64).sum();
    for c in chunks {
        for (l, &x) in lanes.iter_mut().zip(c) {
            *l += f(x);
        }
    }
    lanes.iter().map(|&l| l as f64).sum::<f64>() + tail
}

/// Matched patch centres: position in A's grid and in B's grid, with confidence.
pub(super) type Match = ([f64; 2], [f64; 2], f64);

/// Patches of `side` px over the pair's overlap, each of B's taken `prior` px away from A's,
/// phase-correlated: the matches and the number of patches compared.
pub(super) fn match_patches(
    a: &Rendered,
    b: &Rendered,
    side: usize,
    prior: [i64; 2],
) -> Result<(Vec<Match>, usize), Error> {
    let Some(([c0, r0, c1, r1], off)) = overlap(&a.coarse_plan.grid, &b.coarse_plan.grid) else {
        return Ok((vec![], 0));
    };
    let mut pc = PhaseCorrelator::new(
        side,
        side,
        PhaseOptions {
            weighting: Weighting::Phase,
            window: true,
            smooth: 0.0,
        },
    )
    .map_err(Error::from)?;
    let (mut out, mut tried) = (Vec::new(), 0);
    let step = (side / 2) as i64;
    let (bw, bh) = (b.coarse.size().width as i64, b.coarse.size().height as i64);
    let mut r = r0;
    while r + side as i64 <= r1 {
        let mut c = c0;
        while c + side as i64 <= c1 {
            let (cb, rb) = (c - off[0] + prior[0], r - off[1] + prior[1]);
            let inside_b = cb >= 0 && rb >= 0 && cb + side as i64 <= bw && rb + side as i64 <= bh;
            let pa = patch(&a.coarse, c as usize, r as usize, side);
            let pb = if inside_b {
                patch(&b.coarse, cb as usize, rb as usize, side)
            } else {
                None
            };
            if let (Some(pa), Some(pb)) = (pa, pb) {
                tried += 1;
                if let Ok(e) = pc.estimate(&pa, &pb)
                    && e.confidence > 0.08
                    && e.dx.abs().max(e.dy.abs()) < side as f64 / 4.0
                {
                    let h = side as f64 / 2.0 - 0.5;
                    let at_a = [c as f64 + h, r as f64 + h];
                    let at_b = [cb as f64 + h + e.dx, rb as f64 + h + e.dy];
                    out.push((at_a, at_b, e.confidence));
                }
            }
            c += step;
        }
        r += step;
    }
    Ok((out, tried))
}

/// Coarse to fine: large patches find the pair's overall offset (attitude errors move frames
/// by metres), then `side` patches are matched around it.
pub(super) fn match_pair(
    a: &Rendered,
    b: &Rendered,
    side: usize,
) -> Result<(Vec<Match>, usize), Error> {
    let (ga, gb) = (&a.coarse_plan.grid, &b.coarse_plan.grid);
    // The largest power-of-two patch (up to 256 px) that fits the overlap.
    let fits = overlap(ga, gb).map_or(0, |([c0, r0, c1, r1], _)| {
        (c1 - c0).min(r1 - r0).max(0) as usize
    });
    let big = [256, 128, 64]
        .into_iter()
        .find(|&s| s <= fits)
        .unwrap_or(side);
    let (coarse, _) = match_patches(a, b, big, [0, 0])?;
    let mut prior = [0i64; 2];
    if !coarse.is_empty() {
        let off = overlap(ga, gb).map_or([0, 0], |o| o.1);
        for k in 0..2 {
            let mut d: Vec<f64> = coarse
                .iter()
                .map(|m| m.1[k] - (m.0[k] - off[k] as f64))
                .collect();
            d.sort_by(f64::total_cmp);
            prior[k] = d[d.len() / 2].round() as i64;
        }
    }
    match_patches(a, b, side, prior)
}

/// Tie points of one pair (frame indices `i`, `j`) as rendered.
pub(super) fn pair_ties(
    (i, a): (usize, &Rendered),
    (j, b): (usize, &Rendered),
    side: usize,
    ground_z: &(dyn Fn(f64, f64) -> f64 + Send + Sync),
    relief: bool,
) -> Result<PairMatch, Error> {
    let (matches, tried) = match_pair(a, b, side)?;
    let mut report = PairMatch {
        a: i,
        b: j,
        patches: tried,
        inliers: 0,
        ties: vec![],
        spare: vec![],
        features: false,
    };
    let from: Vec<[f64; 2]> = matches.iter().map(|m| m.0).collect();
    let to: Vec<[f64; 2]> = matches.iter().map(|m| m.1).collect();
    let Some(inliers) = consensus(&from, &to, relief, side) else {
        return Ok(report);
    };
    let mut ties = Vec::new();
    let mut at_a = Vec::new();
    for (m, keep) in matches.iter().zip(&inliers) {
        let (Some(pa), Some(pb)) = (
            a.coarse_plan.frame_pixel_of_unmasked(m.0[0], m.0[1]),
            b.coarse_plan.frame_pixel_of_unmasked(m.1[0], m.1[1]),
        ) else {
            continue;
        };
        if !*keep {
            continue;
        }
        let g = a.coarse_plan.grid.centre_of(m.0[0], m.0[1]);
        at_a.push(m.0);
        ties.push(PairTie {
            ground: [g[0], g[1], ground_z(g[0], g[1])],
            pixel_a: pa,
            pixel_b: pb,
            weight: m.2.clamp(0.05, 1.0),
        });
    }
    report.inliers = ties.len();
    if ties.len() >= MIN_CORRELATION_INLIERS {
        // The pair ties; the rounds' solves take its ties spread over the overlap (the most
        // confident match per cell), and `inliers` counts those; the rest are spare, for the
        // solve that ends the rounds.
        let kept = spread(&at_a, CORRELATION_SPREAD_CELLS, |k| ties[k].weight);
        (report.ties, report.spare) = split_kept(ties, &kept);
        report.inliers = report.ties.len();
    }
    Ok(report)
}

/// A fundamental matrix over the level ground replaces the homography when it explains at
/// least this many times the homography's matches: the relief shows (its parallax varies
/// across the overlap). Below it the ground is flat for the pair, where the homography is the
/// tighter test (a fundamental matrix fits a plane's matches in many ways).
pub const RELIEF_INLIER_GAIN: f64 = 1.2;

/// The fundamental matrix's RANSAC threshold (Sampson distance, px of the matching grid):
/// half the homography's, as a line admits what a point would refuse.
pub const EPIPOLAR_THRESHOLD_PX: f64 = 0.5;

/// Which matches (`from` in A's grid, `to` in B's) one model explains: a homography (within
/// 1 px of the matching grid); or, with `relief` (rendered over the level ground, the hills
/// not modelled), a fundamental matrix (within [`EPIPOLAR_THRESHOLD_PX`]) where it explains
/// [`RELIEF_INLIER_GAIN`] times as many. Two frames rendered over one plane are two
/// homographies of their photos, so the orthos keep the photos' epipolar geometry and a hill's
/// patches, which the homography refuses by their parallax, keep to it; they are the ties
/// that carry the hill's height into the solve and the tie surface.
///
/// A model whose consensus chance would give as often ([`chance_models`]) is not one: `None`
/// when neither is meaningful.
fn consensus(from: &[[f64; 2]], to: &[[f64; 2]], relief: bool, side: usize) -> Option<Vec<bool>> {
    let ransac = RansacOptions {
        threshold: 1.0,
        ..RansacOptions::default()
    };
    let (plane_chance, epipolar_chance) = chance_models(side, ransac.threshold);
    let plane = ransac_homography(from, to, &ransac)
        .ok()
        .map(|f| f.inliers)
        .filter(|v| meaningful(v, &plane_chance));
    if !relief {
        return plane;
    }
    let tight = RansacOptions {
        threshold: EPIPOLAR_THRESHOLD_PX,
        ..ransac
    };
    let epipolar = aerorect_solve::fundamental::ransac_fundamental(from, to, &tight)
        .ok()
        .map(|f| f.inliers)
        .filter(|v| meaningful(v, &epipolar_chance));
    let count = |v: &Option<Vec<bool>>| v.as_ref().map_or(0, |v| v.iter().filter(|&&b| b).count());
    match epipolar.is_some() && count(&epipolar) as f64 >= RELIEF_INLIER_GAIN * count(&plane) as f64
    {
        true => epipolar,
        false => plane,
    }
}

/// How the homography (within `threshold` px) and the fundamental matrix (Sampson distance
/// within [`EPIPOLAR_THRESHOLD_PX`]) meet chance matches of `side`-px patches. A patch's
/// match lands anywhere in the square of `side / 2` px its shift is searched over
/// ([`match_patches`] keeps shifts under `side / 4` each way): a given homography takes it
/// within a disc of radius `threshold` (pi t^2 of the square's area), a fundamental matrix
/// within a band about the epipolar line across the square, sqrt 2 times the Sampson
/// distance each side of it (a pair's error all in B's point). On the five drone-xmp DJI
/// frames, nadir against 65-70 degree oblique over a city, the cross pairs' fundamental
/// matrices held 11-27 of 55-178 matches, 10^9 to 10^17 false alarms (their homographies 6-8,
/// 10^4 to 10^8); the pairs that tie (165-4,856 inliers), under 10^-200.
fn chance_models(side: usize, threshold: f64) -> (ChanceModel, ChanceModel) {
    let square = (side as f64 / 2.0).max(1.0);
    let plane = ChanceModel {
        sample: 4,
        models: 1,
        alpha: std::f64::consts::PI * threshold * threshold / (square * square),
    };
    let epipolar = ChanceModel {
        sample: 8,
        models: 1,
        alpha: 2.0 * std::f64::consts::SQRT_2 * EPIPOLAR_THRESHOLD_PX / square,
    };
    (plane, epipolar)
}

/// The pairs (i < j) of these grids that overlap.
pub(super) fn overlapping(grids: &[OrthoGrid]) -> Vec<(usize, usize)> {
    (0..grids.len())
        .flat_map(|i| (i + 1..grids.len()).map(move |j| (i, j)))
        .filter(|&(i, j)| overlap(&grids[i], &grids[j]).is_some())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane sums give the f64 two-pass variance to f32 precision, for lengths below, at
    /// and past the lanes, and on a large offset (where one serial f32 sum drifts).
    #[test]
    fn variance_is_the_two_pass_variance() {
        for len in [1, 7, 16, 17, 64 * 64, 64 * 64 + 5] {
            let v: Vec<f32> = (0..len)
                .map(|i| 200.0 + 3.0 * ((i * 37 % 101) as f32 / 101.0 - 0.5))
                .collect();
            let n = len as f64;
            let mean = v.iter().map(|&x| x as f64).sum::<f64>() / n;
            let want = v.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / n;
            let got = variance(&v);
            assert!(
                (got - want).abs() <= 1e-4 * want.max(1e-3),
                "{len}: {got} vs {want}"
            );
        }
    }

    /// Where a ground point (x, y, z) falls on the level ground z = 0 seen from camera
    /// centre `c`, in 0.1 m pixels: its position in that frame's level-ground ortho.
    fn on_level_ground(c: [f64; 3], p: [f64; 3]) -> [f64; 2] {
        let t = c[2] / (c[2] - p[2]);
        [
            (c[0] + t * (p[0] - c[0])) / 0.1,
            (c[1] + t * (p[1] - c[1])) / 0.1,
        ]
    }

    /// Two frames 100 m up, 30 m apart along x, over a grid of ground points with heights
    /// `height(x, y)`; every tenth match moved 3-6 px across the baseline (a wrong match).
    fn matches(height: impl Fn(f64, f64) -> f64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<bool>) {
        let (ca, cb) = ([0.0, 0.0, 100.0], [30.0, 0.0, 100.0]);
        let (mut from, mut to, mut wrong) = (vec![], vec![], vec![]);
        for i in 0..20 {
            for j in 0..20 {
                let (x, y) = (-10.0 + 2.5 * i as f64, -25.0 + 2.5 * j as f64);
                let p = [x, y, height(x, y)];
                let k = from.len();
                let mut b = on_level_ground(cb, p);
                if k % 10 == 3 {
                    b[1] += 3.0 + (k % 4) as f64;
                }
                from.push(on_level_ground(ca, p));
                to.push(b);
                wrong.push(k % 10 == 3);
            }
        }
        (from, to, wrong)
    }

    fn kept(inliers: &[bool], wrong: &[bool], of_wrong: bool) -> f64 {
        let n = wrong.iter().filter(|&&w| w == of_wrong).count();
        let k = (0..wrong.len())
            .filter(|&i| wrong[i] == of_wrong && inliers[i])
            .count();
        k as f64 / n as f64
    }

    #[test]
    fn over_hills_the_epipolar_consensus_keeps_what_the_homography_refuses() {
        // Hills of +-6 m: at a base of 0.3 the parallax varies by some 36 px (0.1 m pixels).
        let (from, to, wrong) = matches(|x, y| 6.0 * (x / 9.0).sin() * (y / 11.0).cos());
        let plane = consensus(&from, &to, false, 64).unwrap();
        let hills = consensus(&from, &to, true, 64).unwrap();
        let (p, h) = (kept(&plane, &wrong, false), kept(&hills, &wrong, false));
        eprintln!("true matches kept: homography {p:.2}, epipolar {h:.2}");
        assert!(p < 0.5 && h > 0.95, "{p} {h}");
        // A wrong match off its epipolar line stays out.
        assert!(
            kept(&hills, &wrong, true) < 0.1,
            "{}",
            kept(&hills, &wrong, true)
        );
    }

    #[test]
    fn over_flat_ground_the_homography_decides() {
        let (from, to, wrong) = matches(|_, _| 0.0);
        let plane = consensus(&from, &to, false, 64).unwrap();
        assert_eq!(consensus(&from, &to, true, 64).unwrap(), plane);
        assert_eq!(kept(&plane, &wrong, false), 1.0);
        assert_eq!(kept(&plane, &wrong, true), 0.0);
    }

    /// Chance matches of 64-px patches: B's point anywhere in the 32-px square its shift is
    /// searched over, about a common offset; the pair's matches in a 20 x 12 grid.
    fn chance_matches(seed: u64) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let from: Vec<[f64; 2]> = (0..240)
            .map(|k| [16.0 * (k % 20) as f64, 16.0 * (k / 20) as f64])
            .collect();
        let to = from
            .iter()
            .map(|f| {
                let s: [f64; 2] = [rng.random_range(-16.0..16.0), rng.random_range(-16.0..16.0)];
                [f[0] + 5.0 + s[0], f[1] - 3.0 + s[1]]
            })
            .collect();
        (from, to)
    }

    /// Chance matches tie nothing under either model, though RANSAC's fundamental matrix
    /// finds a band of more than [`MIN_CORRELATION_INLIERS`] of them (the premise, checked);
    /// a pair whose true matches (the offset, 0.2 px of noise) are one in five still ties,
    /// all of them kept.
    #[test]
    fn chance_matches_tie_nothing_and_a_weak_true_pair_ties() {
        let tight = RansacOptions {
            threshold: EPIPOLAR_THRESHOLD_PX,
            ..RansacOptions::default()
        };
        for seed in 1..=4 {
            let (from, chance) = chance_matches(seed);
            let band = aerorect_solve::fundamental::ransac_fundamental(&from, &chance, &tight)
                .unwrap()
                .inlier_count();
            assert!(band > MIN_CORRELATION_INLIERS, "seed {seed}: {band}");
            for relief in [false, true] {
                assert_eq!(consensus(&from, &chance, relief, 64), None, "seed {seed}");
            }
            let weak: Vec<[f64; 2]> = (from.iter().zip(&chance).enumerate())
                .map(|(k, (f, c))| match k % 5 {
                    0 => [f[0] + 5.0 + 0.2 * ((k % 7) as f64 / 3.0 - 1.0), f[1] - 3.0],
                    _ => *c,
                })
                .collect();
            for relief in [false, true] {
                let inliers = consensus(&from, &weak, relief, 64).unwrap();
                assert!((0..240).step_by(5).all(|k| inliers[k]), "seed {seed}");
            }
        }
    }
}
