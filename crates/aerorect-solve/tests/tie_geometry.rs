//! Geometric verification of tie points against closed forms: a homography and a fundamental
//! matrix recovered by RANSAC from synthetic correspondences with outliers, and candidate pairs
//! against a brute-force oracle.

use aerorect_core::{Homography, Mat3};
use aerorect_solve::fundamental::{fit_fundamental, ransac_fundamental};
use aerorect_solve::pairs::{PairOptions, candidate_pairs, convex_overlap, nearest_neighbours};
use aerorect_solve::ransac::{
    RansacOptions, iterations_for, iterations_for_count, ransac_homography,
};
use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn skew(t: Vector3<f64>) -> Mat3 {
    Mat3::new(0.0, -t.z, t.y, t.z, 0.0, -t.x, -t.y, t.x, 0.0)
}

/// Two cameras K[I|0] and K[R|t] over hilly ground; F = K^-T [t]x R K^-1 (Hartley & Zisserman
/// eq. 9.2 for P = K[I|0], P' = K'[R|t]). Returns F and `n` projected pairs.
fn two_views(n: usize, rng: &mut ChaCha8Rng) -> (Mat3, Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let k = Mat3::new(1200.0, 0.0, 640.0, 0.0, 1200.0, 480.0, 0.0, 0.0, 1.0);
    let r = *Rotation3::from_euler_angles(0.05, -0.08, 2.9).matrix();
    let t = Vector3::new(-0.4, 0.1, 0.05);
    let kinv = k.try_inverse().expect("invertible");
    let f = kinv.transpose() * skew(t) * r * kinv;
    let (mut a, mut b) = (vec![], vec![]);
    while a.len() < n {
        // Depths 8..12 (hills of +-20 % of the height).
        let p = Vector3::new(
            rng.random_range(-3.0..3.0),
            rng.random_range(-2.0..2.0),
            1.0,
        );
        let x = p * rng.random_range(8.0..12.0);
        let (u, v) = (k * x, k * (r * x + t));
        a.push([u.x / u.z, u.y / u.z]);
        b.push([v.x / v.z, v.y / v.z]);
    }
    (f / f.norm(), a, b)
}

fn same_up_to_sign(a: &Mat3, b: &Mat3) -> f64 {
    (a - b).norm().min((a + b).norm())
}

#[test]
fn eight_point_fundamental_is_the_closed_form_of_two_cameras() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (truth, a, b) = two_views(40, &mut rng);
    let fit = fit_fundamental(&a, &b).expect("fit");
    assert!(
        same_up_to_sign(&fit.matrix, &truth) < 1e-7,
        "{}",
        fit.matrix
    );
    assert!(fit.matrix.determinant().abs() < 1e-12, "rank 2");
    for (x, y) in a.iter().zip(&b) {
        assert!(fit.sampson(*x, *y) < 1e-6);
    }
    // Sampson distance of a pair moved off its epipolar line by d pixels (perpendicular in the
    // second frame) is d |l| / sqrt(|l|^2 + |l2|^2) (l = F x, l2 = F^T x2 over their first two terms): below d, and near d / sqrt(2) for similar views.
    let l = fit.matrix * Vector3::new(a[0][0], a[0][1], 1.0);
    let n = (l.x * l.x + l.y * l.y).sqrt();
    let moved = [b[0][0] + 3.0 * l.x / n, b[0][1] + 3.0 * l.y / n];
    let s = fit.sampson(a[0], moved);
    assert!(s > 1.0 && s <= 3.0 + 1e-9, "{s}");
}

#[test]
fn ransac_fundamental_finds_the_inliers_among_forty_percent_outliers() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (truth, a, mut b) = two_views(200, &mut rng);
    let mut outlier = vec![false; a.len()];
    for i in 0..a.len() {
        b[i][0] += rng.random_range(-0.3..0.3);
        b[i][1] += rng.random_range(-0.3..0.3);
        if i % 5 < 2 {
            b[i] = [rng.random_range(0.0..1280.0), rng.random_range(0.0..960.0)];
            outlier[i] = true;
        }
    }
    let opts = RansacOptions {
        threshold: 1.5,
        max_iterations: 5000,
        ..RansacOptions::default()
    };
    let fit = ransac_fundamental(&a, &b, &opts).expect("ransac");
    let true_model = aerorect_solve::fundamental::Fundamental { matrix: truth };
    for i in 0..a.len() {
        if !outlier[i] {
            assert!(fit.inliers[i], "inlier {i} missed");
        } else if fit.inliers[i] {
            // An outlier may only be kept where it happens to lie near its true epipolar line.
            assert!(true_model.sampson(a[i], b[i]) < 3.0, "outlier {i} kept");
        }
    }
    // The fitted epipolar geometry puts every true correspondence within the noise.
    let worst = (0..a.len())
        .filter(|&i| !outlier[i])
        .map(|i| fit.model.sampson(a[i], b[i]))
        .fold(0.0, f64::max);
    assert!(worst < 1.0, "{worst}");
}

/// Samples for one all-inlier sample of 8 at 99.9 % with `m` inliers of `n`, by the closed form.
fn want_at_999(m: u64, n: u64) -> usize {
    let choose = |n: u64, k: u64| (0..k).fold(1.0f64, |c, i| c * (n - i) as f64 / (i + 1) as f64);
    let hit = choose(m, 8) / choose(n, 8);
    (0.001f64.ln() / (1.0 - hit).ln()).ceil() as usize
}

#[test]
fn ransac_gives_up_on_chance_matches_once_the_needed_consensus_would_have_been_drawn() {
    // Hartley & Zisserman, table 4.3 (p = 0.99, half the data outliers): 72 samples of 4,
    // 1177 of 8, drawn with replacement; 20 inliers of 30, eight drawn without replacement:
    // C(20, 8) / C(30, 8) = 125970 / 5852925 a sample.
    assert_eq!(iterations_for(0.5, 4, 0.99), 72);
    assert_eq!(iterations_for(0.5, 8, 0.99), 1177);
    let hit: f64 = 125_970.0 / 5_852_925.0;
    let want = (0.001f64.ln() / (1.0 - hit).ln()).ceil() as usize;
    assert_eq!(iterations_for_count(20, 30, 8, 0.999), want);
    let opts = RansacOptions {
        threshold: 1.0,
        max_iterations: 4000,
        ..RansacOptions::default()
    };
    let wanting = RansacOptions {
        min_inliers: 20,
        ..opts
    };
    // Thirty matches of which ten agree (the 8-12 chance inliers of two frames that share
    // nothing): no consensus of 20 exists. Without a least consensus RANSAC draws every
    // sample; with one it stops once 20 inliers of 30 would have been sampled.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (_, a, mut b) = two_views(30, &mut rng);
    for p in b.iter_mut().skip(10) {
        *p = [rng.random_range(0.0..1280.0), rng.random_range(0.0..960.0)];
    }
    let all = ransac_fundamental(&a, &b, &opts).expect("ransac");
    assert_eq!(all.iterations, 4000);
    let gave_up = ransac_fundamental(&a, &b, &wanting).expect("ransac");
    assert_eq!(gave_up.iterations, want_at_999(20, 30));
    assert!(gave_up.inlier_count() < 20, "{}", gave_up.inlier_count());
    // Exactly 20 true correspondences among 30: every seed still finds all of them.
    for seed in 1..=20 {
        let mut rng = ChaCha8Rng::seed_from_u64(100 + seed);
        let (_, a, mut b) = two_views(30, &mut rng);
        for p in b.iter_mut().skip(20) {
            *p = [rng.random_range(0.0..1280.0), rng.random_range(0.0..960.0)];
        }
        let fit = ransac_fundamental(&a, &b, &RansacOptions { seed, ..wanting }).expect("fit");
        assert!(fit.inliers[..20].iter().all(|&k| k), "seed {seed}: {fit:?}");
        assert!(fit.iterations < 4000, "seed {seed}: {}", fit.iterations);
    }
}

#[test]
fn ransac_homography_recovers_a_half_turn_with_scale_among_outliers() {
    // Opposite flight directions: a 180-degree turn, 0.8x scale and a shift.
    let truth = Homography::new(Mat3::new(
        -0.8, 0.01, 1100.0, -0.01, -0.8, 820.0, 1e-6, 2e-6, 1.0,
    ))
    .expect("homography");
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let from: Vec<[f64; 2]> = (0..300)
        .map(|_| [rng.random_range(0.0..1152.0), rng.random_range(0.0..864.0)])
        .collect();
    let mut to: Vec<[f64; 2]> = from
        .iter()
        .map(|p| truth.map(p[0], p[1]).expect("finite"))
        .collect();
    for (i, t) in to.iter_mut().enumerate() {
        if i % 3 == 0 {
            t[0] += rng.random_range(20.0..200.0);
            t[1] -= rng.random_range(20.0..200.0);
        }
    }
    let fit = ransac_homography(&from, &to, &RansacOptions::default()).expect("ransac");
    for (i, &inl) in fit.inliers.iter().enumerate() {
        assert_eq!(inl, i % 3 != 0, "pair {i}");
    }
    for p in [[0.0, 0.0], [1151.0, 863.0], [576.0, 432.0]] {
        let (m, t) = (
            fit.model.map(p[0], p[1]).expect("m"),
            truth.map(p[0], p[1]).expect("t"),
        );
        assert!((m[0] - t[0]).hypot(m[1] - t[1]) < 1e-6);
    }
}

#[test]
fn nearest_neighbours_equal_the_sorted_distance_oracle() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    // Strips: clustered x, as a flight gives; some repeated positions (ties broken by index).
    let mut c: Vec<[f64; 2]> = (0..300)
        .map(|i| {
            [
                (i / 30) as f64 * 40.0 + rng.random_range(-2.0..2.0),
                rng.random_range(0.0..600.0),
            ]
        })
        .collect();
    c[17] = c[3];
    for k in [1, 4, 9] {
        let mut got = nearest_neighbours(&c, k);
        got.sort_unstable();
        let mut want = vec![];
        for i in 0..c.len() {
            let mut d: Vec<(f64, usize)> = (0..c.len())
                .filter(|&j| j != i)
                .map(|j| ((c[i][0] - c[j][0]).powi(2) + (c[i][1] - c[j][1]).powi(2), j))
                .collect();
            d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            want.extend(d[..k].iter().map(|&(_, j)| (i, j)));
        }
        want.sort_unstable();
        assert_eq!(got, want, "k = {k}");
    }
}

#[test]
fn candidate_pairs_hold_the_delaunay_edges_and_the_overlapping_footprints() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let c: Vec<[f64; 2]> = (0..80)
        .map(|_| [rng.random_range(0.0..500.0), rng.random_range(0.0..500.0)])
        .collect();
    let only_delaunay = PairOptions {
        neighbours: 0,
        delaunay: true,
        max_distance: None,
    };
    let pairs = candidate_pairs(&c, None, &only_delaunay).expect("pairs");
    // Euler: a triangulation of n points with h on the hull has 3n - 3 - h edges.
    let hull = {
        let pts: Vec<delaunator::Point> = c
            .iter()
            .map(|p| delaunator::Point { x: p[0], y: p[1] })
            .collect();
        delaunator::triangulate(&pts).hull.len()
    };
    assert_eq!(pairs.len(), 3 * c.len() - 3 - hull);
    // Each point's nearest neighbour is a Delaunay neighbour (the nearest-neighbour graph is a
    // subgraph of the Delaunay triangulation).
    for (i, nn) in nearest_neighbours(&c, 1) {
        assert!(pairs.contains(&(i.min(nn), i.max(nn))), "{i}-{nn}");
    }
    // Axis-aligned footprints: overlap iff both intervals overlap (the oracle).
    let rects: Vec<[f64; 4]> = c
        .iter()
        .map(|p| {
            [
                p[0],
                p[1],
                p[0] + rng.random_range(5.0..60.0),
                p[1] + rng.random_range(5.0..60.0),
            ]
        })
        .collect();
    let fp: Vec<Vec<[f64; 2]>> = rects
        .iter()
        .map(|r| vec![[r[0], r[1]], [r[2], r[1]], [r[2], r[3]], [r[0], r[3]]])
        .collect();
    let none = PairOptions {
        neighbours: 0,
        delaunay: false,
        max_distance: None,
    };
    let got = candidate_pairs(&c, Some(&fp), &none).expect("pairs");
    let mut want = vec![];
    for i in 0..c.len() {
        for j in i + 1..c.len() {
            let (a, b) = (rects[i], rects[j]);
            if a[0] <= b[2] && b[0] <= a[2] && a[1] <= b[3] && b[1] <= a[3] {
                want.push((i, j));
            }
        }
    }
    assert_eq!(got, want);
    // Two diamonds whose bounding boxes overlap but which do not touch.
    let d1 = [[0.0, 1.0], [1.0, 0.0], [2.0, 1.0], [1.0, 2.0]];
    let d2 = [[1.6, 2.6], [2.6, 1.6], [3.6, 2.6], [2.6, 3.6]];
    assert!(!convex_overlap(&d1, &d2));
    assert!(convex_overlap(&d1, &[[1.2, 1.2], [3.0, 1.2], [3.0, 3.0]]));
}
