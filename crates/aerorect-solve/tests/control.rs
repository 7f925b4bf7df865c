//! Ground control in the adjustment, on a simulated flight with known truth: 100 frames over
//! hills, GPS off by a common 3 m plus 1 m of noise per axis, attitudes off 1 degree per axis,
//! tie points at 0.3 px noise; five ground control points marked at 0.5 px noise and ten check
//! points kept out of the solve. The check points' positions, intersected from their marks
//! through the adjusted frames, are compared with their surveyed ones.
#![allow(clippy::unwrap_used)]

use aerorect_core::Vec3;
use aerorect_solve::adjust::{
    AdjustFrame, AdjustOptions, Adjusted, Control, Datum, Observation, OrientedFrames, TiePoint,
    adjust,
};
use aerorect_testkit::flight::{camera, flight, marks};
use nalgebra::Rotation3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn hills(x: f64, y: f64) -> f64 {
    25.0 + 20.0 * (x / 140.0).sin() * (y / 120.0).cos() + 6.0 * (x / 47.0 + y / 61.0).sin()
}

/// The common GPS offset of the block (3 m).
const GPS_OFFSET: [f64; 3] = [2.0, -2.0, 1.0];

/// Frames of a 10 x 10 block with their recorded positions off, and the surveyed points with
/// their marks: (ground control, check points).
struct Scene {
    truth: Vec<AdjustFrame>,
    recorded: Vec<AdjustFrame>,
    ties: Vec<TiePoint>,
    gcps: Vec<(Vec3, Vec<Observation>)>,
    checks: Vec<(Vec3, Vec<Observation>)>,
}

fn scene(seed: u64) -> Scene {
    let fl = flight(10, 10, 1.0, &hills, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 100);
    let gps = Normal::new(0.0, 1.0).unwrap();
    let mut recorded = fl.recorded.clone();
    for f in &mut recorded {
        for (c, o) in f.centre.iter_mut().zip(GPS_OFFSET) {
            *c += o + gps.sample(&mut rng);
        }
    }
    let point = |x: f64, y: f64, rng: &mut ChaCha8Rng| {
        let g = Vec3::new(x, y, hills(x, y));
        (g, marks(&fl.truth, g, 0.5, rng))
    };
    // The block spans 0..450 m by 0..360 m: control at the corners and the centre.
    let gcps = [
        (20.0, 20.0),
        (430.0, 20.0),
        (20.0, 340.0),
        (430.0, 340.0),
        (225.0, 180.0),
    ]
    .map(|(x, y)| point(x, y, &mut rng))
    .to_vec();
    // Check points anywhere inside the block, each seen in three frames or more.
    let mut checks = Vec::new();
    while checks.len() < 10 {
        let (x, y) = (rng.random_range(40.0..410.0), rng.random_range(40.0..320.0));
        let p = point(x, y, &mut rng);
        if p.1.len() >= 3 {
            checks.push(p);
        }
    }
    Scene {
        truth: fl.truth,
        recorded,
        ties: fl.ties,
        gcps,
        checks,
    }
}

/// The control points as the adjustment takes them: marks at 1 px (the default), surveyed
/// at 2 cm horizontally and 5 cm vertically.
fn control(gcps: &[(Vec3, Vec<Observation>)]) -> Vec<TiePoint> {
    gcps.iter()
        .map(|(g, obs)| TiePoint {
            ground: [g.x, g.y, g.z],
            observations: obs
                .iter()
                .map(|o| Observation { weight: 0.25, ..*o })
                .collect(),
            control: Some(Control {
                ground: [g.x, g.y, g.z],
                sigma_m: [0.02, 0.02, 0.05],
            }),
        })
        .collect()
}

/// The check points' root mean square errors (XY, Z) in metres, each intersected from its
/// marks through `frames`.
fn check_rmse(frames: OrientedFrames<'_>, checks: &[(Vec3, Vec<Observation>)]) -> (f64, f64) {
    let (mut xy, mut z) = (0.0, 0.0);
    for (g, obs) in checks {
        let got = frames
            .intersect(obs, [g.x, g.y, g.z])
            .unwrap_or_else(|| panic!("{g} {obs:?}"));
        xy += (got[0] - g.x).powi(2) + (got[1] - g.y).powi(2);
        z += (got[2] - g.z).powi(2);
    }
    let n = checks.len() as f64;
    ((xy / n).sqrt(), (z / n).sqrt())
}

fn solve(s: &Scene, gcps: &[(Vec3, Vec<Observation>)], datum: Datum) -> Adjusted {
    let mut ties = s.ties.clone();
    ties.extend(control(gcps));
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        position_sigma_m: Some(5.0),
        datum,
        max_iterations: 100,
        ..Default::default()
    };
    adjust(&s.recorded, &[camera(800.0)], &ties, &opts).unwrap()
}

/// The frames' attitude errors against the truth, degrees: (median, worst).
fn turns_deg(truth: &[AdjustFrame], got: &[AdjustFrame]) -> (f64, f64) {
    let mut t: Vec<f64> = truth
        .iter()
        .zip(got)
        .map(|(t, g)| {
            Rotation3::from_matrix_unchecked(g.world_from_camera * t.world_from_camera.transpose())
                .angle()
                .to_degrees()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[t.len() - 1])
}

/// The ground sample distance of the simulated frames over their hills (m): 100 m above
/// ground of about 25 m at 800 px focal length.
const GSD_M: f64 = 75.0 / 800.0;

#[test]
fn five_control_points_bring_the_check_points_within_a_ground_sample_distance() {
    let s = scene(7);
    let cameras = [camera(800.0)];
    let recorded = OrientedFrames {
        frames: &s.recorded,
        cameras: &cameras,
    };
    let before = check_rmse(recorded, &s.checks);
    let free = solve(&s, &[], Datum::Recorded);
    let without = check_rmse(free.oriented(), &s.checks);
    let out = solve(&s, &s.gcps, Datum::Similarity);
    let after = check_rmse(out.oriented(), &s.checks);
    let d = out.report.datum.as_ref().unwrap();
    eprintln!(
        "check points RMSE XY / Z: recorded {:.3} / {:.3} m, adjusted without control {:.3} / {:.3} m, with five GCPs {:.3} / {:.3} m (GSD {GSD_M:.3} m); datum shift {:?} m, rotation {:?} deg, scale {:.0} ppm; attitude error median / worst {:?} deg",
        before.0,
        before.1,
        without.0,
        without.1,
        after.0,
        after.1,
        d.shift_m,
        d.rotation_deg,
        d.scale_ppm,
        turns_deg(&s.truth, &out.frames)
    );
    // The recorded block is metres off; its own overlaps cannot move it back.
    assert!(before.0 > 1.0, "{before:?}");
    assert!(without.0 > 1.0, "{without:?}");
    // ODM documents about 2.5 GSD horizontally and 4 vertically with control.
    assert!(after.0 < 1.5 * GSD_M, "{after:?}");
    assert!(after.1 < 3.0 * GSD_M, "{after:?}");
    // The datum takes the common offset (a recorded position belongs at c + shift), not the
    // attitudes.
    for (s, o) in d.shift_m.iter().zip(GPS_OFFSET) {
        assert!((s + o).abs() < 0.5, "{d:?}");
    }
    // Frames at the block's edge trade a little attitude for their 1 m of GPS noise.
    let (median, worst) = turns_deg(&s.truth, &out.frames);
    assert!(median < 0.1 && worst < 0.5, "{median} {worst}");
}

#[test]
fn with_two_control_points_the_datum_is_a_shift() {
    let s = scene(8);
    let out = solve(&s, &s.gcps[..2], Datum::Shift);
    let d = out.report.datum.as_ref().unwrap();
    assert_eq!(d.model, Datum::Shift);
    assert_eq!(d.scale_ppm, 0.0);
    let after = check_rmse(out.oriented(), &s.checks);
    assert!(after.0 < 3.0 * GSD_M, "{after:?}");
    for (s, o) in d.shift_m.iter().zip(GPS_OFFSET) {
        assert!((s + o).abs() < 0.5, "{d:?}");
    }
}

#[test]
fn a_control_point_projects_where_it_was_marked_and_marks_intersect_at_it() {
    let s = scene(9);
    let cameras = [camera(800.0)];
    let truth = OrientedFrames {
        frames: &s.truth,
        cameras: &cameras,
    };
    for (g, obs) in &s.gcps {
        // Marks have 0.5 px noise: the true frames put the point within 2 px of each.
        for o in obs {
            let p = truth.pixel_of(o.frame, [g.x, g.y, g.z]).unwrap();
            assert!(
                (p[0] - o.pixel[0]).hypot(p[1] - o.pixel[1]) < 2.5,
                "{p:?} {o:?}"
            );
        }
        let x = truth
            .intersect(obs, [g.x + 5.0, g.y - 5.0, g.z + 10.0])
            .unwrap();
        assert!((Vec3::from(x) - g).norm() < 0.3, "{x:?} {g}");
        // The frames posed once give the same numbers, bit for bit.
        let posed = truth.posed();
        assert_eq!(
            posed.intersect(obs, [g.x + 5.0, g.y - 5.0, g.z + 10.0]),
            Some(x)
        );
        for o in obs {
            assert_eq!(posed.pixel_of(o.frame, x), truth.pixel_of(o.frame, x));
        }
        assert_eq!(posed.pixel_of(s.truth.len(), x), None);
        // The ray of a mark meets the surveyed height near the point.
        let r = truth
            .ray_at_height(obs[0].frame, obs[0].pixel, g.z)
            .unwrap();
        assert!((r[0] - g.x).hypot(r[1] - g.y) < 0.3, "{r:?}");
    }
    // One mark gives no intersection.
    assert!(truth.intersect(&s.gcps[0].1[..1], [0.0; 3]).is_none());
    assert!(
        truth
            .posed()
            .intersect(&s.gcps[0].1[..1], [0.0; 3])
            .is_none()
    );
}

#[test]
fn a_gps_fix_the_images_contradict_is_down_weighted_and_the_images_win() {
    // No ground control: the block's common shift is held at the GPS sigma over the root of
    // the frames' count; one frame's fix is 40 m off.
    let s = scene(10);
    let mut recorded = s.recorded.clone();
    let bad = 44;
    recorded[bad].centre[0] += 40.0;
    let solve = |huber: Option<f64>| {
        let opts = AdjustOptions {
            refine_focal: false,
            refine_principal_point: false,
            position_sigma_m: Some(5.0),
            datum: Datum::Shift,
            datum_shift_sigma_m: [5.0 / 10.0; 3],
            position_huber: huber,
            max_iterations: 100,
            ..Default::default()
        };
        adjust(&recorded, &[camera(800.0)], &s.ties, &opts).unwrap()
    };
    let quadratic = solve(None);
    let robust = solve(Some(3.0));
    let turn = |a: &Adjusted| turns_deg(&s.truth[bad..=bad], &a.frames[bad..=bad]).1;
    let moved = |a: &Adjusted| {
        let c = a.frames[bad].centre;
        let t = s.truth[bad].centre;
        ((c[0] - t[0]).powi(2) + (c[1] - t[1]).powi(2) + (c[2] - t[2]).powi(2)).sqrt()
    };
    let w = robust.report.frames[bad].position_weight;
    eprintln!(
        "frame {bad} with its fix 40 m off: quadratic prior {:.2} m from the truth, {:.3} deg; robust {:.2} m, {:.3} deg, weight {w:.3}",
        moved(&quadratic),
        turn(&quadratic),
        moved(&robust),
        turn(&robust)
    );
    // A well-tied block already puts the frame back with the quadratic prior (37 of its 40 m,
    // the rest the block's common 3 m); the robust one finds the fix, down-weights it alone
    // and does no worse.
    assert!(moved(&quadratic) < 5.0);
    assert!(w < 0.5, "{w}");
    assert!(
        moved(&robust) < moved(&quadratic) + 0.1,
        "{} {}",
        moved(&robust),
        moved(&quadratic)
    );
    let others = robust
        .report
        .frames
        .iter()
        .enumerate()
        .filter(|(k, f)| *k != bad && f.position_weight < 1.0)
        .count();
    assert!(others <= 2, "{others} other frames down-weighted");
}

/// The GPS drift of [`a_gps_drift_in_time_is_solved_where_the_strips_alternate`]: where the
/// last frame's fix is, less the first's (m; east, north, up), beyond the common offset.
const DRIFT_M: [f64; 3] = [15.0, -10.0, 110.0];

#[test]
fn a_gps_drift_in_time_is_solved_where_the_strips_alternate() {
    // The block is flown in strips east and west in turn (frame j * 10 + i is the i-th from
    // the west on strip j), its fixes drifting linearly in time. The ties sit on the known
    // terrain (as over a DEM), so the block's tilt is the ground's.
    let s = scene(11);
    let (nx, n) = (10, s.recorded.len());
    let times: Vec<f64> = (0..n)
        .map(|k| {
            let (j, i) = (k / nx, k % nx);
            let t = j * nx + if j % 2 == 0 { i } else { nx - 1 - i };
            t as f64 / (n - 1) as f64 - 0.5
        })
        .collect();
    let mut recorded = s.recorded.clone();
    for (f, t) in recorded.iter_mut().zip(&times) {
        for (c, d) in f.centre.iter_mut().zip(DRIFT_M) {
            *c += d * (t + 0.5);
        }
    }
    let terrain = |x: f64, y: f64| hills(x, y);
    let solve = |drift: Option<&[f64]>| {
        // The flight's robust GPS: the common shift held at a fix's sigma over the root of
        // the frames' count, or at a fix's sigma where the fixes drift.
        let opts = AdjustOptions {
            refine_focal: false,
            refine_principal_point: false,
            position_sigma_m: Some(5.0),
            datum: Datum::Shift,
            datum_shift_sigma_m: [if drift.is_some() { 5.0 } else { 0.5 }; 3],
            position_huber: Some(3.0),
            gps_drift_times: drift,
            terrain: Some((&terrain, 1.0)),
            max_iterations: 100,
            ..Default::default()
        };
        adjust(&recorded, &[camera(800.0)], &s.ties, &opts).unwrap()
    };
    let without = solve(None);
    let with = solve(Some(&times));
    let centre_error = |a: &Adjusted| {
        let mut e: Vec<f64> = a
            .frames
            .iter()
            .zip(&s.truth)
            .map(|(g, t)| (Vec3::from(g.centre) - Vec3::from(t.centre)).norm())
            .collect();
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    };
    let d = with.report.datum.as_ref().unwrap().drift.clone().unwrap();
    eprintln!(
        "GPS drifting {DRIFT_M:?} m over the flight: attitude error median / worst {:?} deg without the drift, {:?} with ({:?} m, sigma {:?}); centres {:.2} / {:.2} m from the truth",
        turns_deg(&s.truth, &without.frames),
        turns_deg(&s.truth, &with.frames),
        d.over_flight_m,
        d.sigma_m,
        centre_error(&without),
        centre_error(&with),
    );
    // The recorded positions belong `drift t` back: the solved drift is the recorded one's
    // opposite, to within the block's 1 m of GPS noise.
    for ((got, want), sigma) in d.over_flight_m.iter().zip(DRIFT_M).zip(d.sigma_m) {
        assert!((got + want).abs() < 3.0 && sigma < 2.0, "{d:?}");
    }
    // 0.058 / 0.20 deg and 0.12 m with the drift; 0.157 / 0.43 deg and 4.2 m without (Huber's
    // loss alone down-weights the fixes far from the common shift).
    let (median, worst) = turns_deg(&s.truth, &with.frames);
    assert!(median < 0.08 && worst < 0.3, "{median} {worst}");
    assert!(turns_deg(&s.truth, &without.frames).0 > 2.0 * median);
    assert!(centre_error(&with) < 0.5, "{}", centre_error(&with));
    assert!(centre_error(&without) > 2.0, "{}", centre_error(&without));
    // With the drift taken out, no fix is left contradicted.
    assert!(with.report.frames.iter().all(|f| f.position_weight == 1.0));
}

/// Two marks' rays meet at the point they were projected from; rays a few pixels apart pass
/// closest at the midpoint, equally far from each, where the intersection started far off
/// ends too; a ray with itself (parallel) meets nowhere.
#[test]
fn two_rays_meet_at_their_point_or_halfway_between_them() {
    let s = scene(9);
    let cameras = [camera(800.0)];
    let truth = OrientedFrames {
        frames: &s.truth,
        cameras: &cameras,
    };
    let (g, obs) = &s.gcps[0];
    let exact: Vec<Observation> = obs
        .iter()
        .map(|o| Observation {
            pixel: truth.pixel_of(o.frame, [g.x, g.y, g.z]).unwrap(),
            ..*o
        })
        .collect();
    let x = truth.rays_meet(&exact[0], &exact[1]).unwrap();
    assert!((Vec3::from(x) - g).norm() < 1e-6, "{x:?} {g}");
    let off = Observation {
        pixel: [exact[1].pixel[0] + 3.0, exact[1].pixel[1] - 2.0],
        ..exact[1]
    };
    let m = Vec3::from(truth.rays_meet(&exact[0], &off).unwrap());
    // Distance from m to each ray (centre c, direction through the pixel's world point).
    let gap = |o: &Observation| {
        let f = &s.truth[o.frame];
        let c = Vec3::from(f.centre);
        let through = Vec3::from(truth.ray_at_height(o.frame, o.pixel, g.z - 50.0).unwrap());
        let d = (through - c).normalize();
        ((m - c) - d * (m - c).dot(&d)).norm()
    };
    let (ga, gb) = (gap(&exact[0]), gap(&off));
    assert!(ga > 1e-3 && (ga - gb).abs() < 1e-6 * ga, "{ga} {gb}");
    let pair = [exact[0], off];
    let from_mid = truth.intersect(&pair, m.into()).unwrap();
    let from_far = truth
        .intersect(&pair, [g.x + 5.0, g.y - 5.0, g.z + 10.0])
        .unwrap();
    assert!((Vec3::from(from_mid) - Vec3::from(from_far)).norm() < 1e-5);
    assert!(truth.rays_meet(&exact[0], &exact[0]).is_none());
}
