//! The flight adjustment on simulated flights with known truth: frames on a grid over the
//! ground, attitudes recorded with 1 degree errors, tie points observed in the true frames with
//! 0.3 px noise.
#![allow(clippy::unwrap_used)]

use aerorect_core::Vec3;
use aerorect_solve::adjust::{AdjustFrame, AdjustOptions, Observation, TiePoint, adjust};
use aerorect_testkit::flight::{camera, flight, nadir};
use nalgebra::{Rotation3, Vector3};

/// Remaining rotation error of each adjusted frame against the truth, degrees.
fn errors(truth: &[AdjustFrame], got: &[AdjustFrame]) -> Vec<Vec3> {
    truth
        .iter()
        .zip(got)
        .map(|(t, g)| {
            let d = Rotation3::from_matrix_unchecked(
                g.world_from_camera * t.world_from_camera.transpose(),
            );
            d.scaled_axis() * 1f64.to_degrees()
        })
        .collect()
}

/// The simulated ground of most tests: 25 +- 20 m, repeating every 250 m east, 220 m north.
fn hills(x: f64, y: f64) -> f64 {
    25.0 + 20.0 * (x / 40.0).sin() * (y / 35.0).cos()
}

/// Ridges about the zero height: +-30 m, repeating every 280 m east, 190 m north.
fn ridges(x: f64, y: f64) -> f64 {
    30.0 * (x / 45.0).sin() * (y / 30.0).cos()
}

fn max_norm(v: &[Vec3]) -> f64 {
    v.iter().map(|e| e.norm()).fold(0.0, f64::max)
}

#[test]
fn one_degree_attitude_errors_are_recovered_over_hills() {
    // Over relief the common tilt is observable too: every frame is recovered absolutely.
    let fl = flight(5, 4, 1.0, &hills, 3);
    let before = max_norm(&errors(&fl.truth, &fl.recorded));
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&hills, 0.05)),
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let after = max_norm(&errors(&fl.truth, &out.frames));
    let r = &out.report;
    eprintln!(
        "{} frames, {} ties: worst rotation error {before:.3} -> {after:.4} deg, rms {:.2} -> {:.3} px, {} iterations, {:.2} s",
        fl.truth.len(),
        r.tie_points,
        r.rms_before_px,
        r.rms_after_px,
        r.iterations,
        r.seconds
    );
    assert!(r.converged);
    assert!(after < 0.05, "{after}");
    assert!(r.rms_after_px < 0.5 && r.rms_before_px > 5.0);
    // The reported standard deviations are of the size of the errors left.
    let sd = r
        .frames
        .iter()
        .map(|f| f.rotation_sigma_deg[0])
        .fold(0.0, f64::max);
    assert!(sd > 0.0 && sd < 0.05, "{sd}");
}

#[test]
fn frames_agree_after_adjustment_on_flat_ground() {
    // Over flat ground a tilt common to all frames moves them together: the ties cannot see it,
    // the prior holds it. Frames must agree with each other (relative errors vanish).
    let flat = |_: f64, _: f64| 0.0;
    let fl = flight(6, 5, 1.0, &flat, 5);
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&flat, 0.05)),
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let e = errors(&fl.truth, &out.frames);
    let mean = e.iter().fold(Vec3::zeros(), |a, v| a + v) / e.len() as f64;
    let relative: Vec<Vec3> = e.iter().map(|v| v - mean).collect();
    assert!(max_norm(&relative) < 0.05, "{}", max_norm(&relative));
    assert!(out.report.rms_after_px < 0.5);
}

#[test]
fn focal_length_error_is_recovered_with_the_attitudes() {
    let fl = flight(5, 4, 1.0, &ridges, 9);
    let opts = AdjustOptions {
        refine_focal: true,
        refine_principal_point: false,
        terrain: Some((&ridges, 0.05)),
        ..Default::default()
    };
    // The camera recorded 0.5 % long.
    let out = adjust(&fl.recorded, &[camera(804.0)], &fl.ties, &opts).unwrap();
    let f = out.cameras[0].intrinsics.fx;
    assert!((f - 800.0).abs() < 0.8, "{f}");
    assert!(max_norm(&errors(&fl.truth, &out.frames)) < 0.05);
}

#[test]
fn a_contradicting_frame_is_down_weighted_not_followed() {
    let mut fl = flight(5, 4, 1.0, &hills, 11);
    // Frame 7's observations are shifted by 15 px (a wrong match set).
    for t in &mut fl.ties {
        for o in &mut t.observations {
            if o.frame == 7 {
                o.pixel[0] += 15.0;
            }
        }
    }
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&hills, 0.05)),
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let e = errors(&fl.truth, &out.frames);
    let others = e
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != 7)
        .map(|(_, v)| v.norm())
        .fold(0.0, f64::max);
    assert!(others < 0.1, "{others}");
}

#[test]
fn ties_that_name_no_frame_are_refused() {
    let t = TiePoint {
        ground: [0.0; 3],
        observations: vec![Observation {
            frame: 3,
            pixel: [1.0, 1.0],
            weight: 1.0,
        }],
        control: None,
    };
    let f = AdjustFrame {
        camera: 0,
        centre: [0.0, 0.0, 100.0],
        world_from_camera: nadir(),
        position_sigma_m: None,
        attitude_sigma_deg: None,
    };
    let e = adjust(
        std::slice::from_ref(&f),
        &[camera(800.0)],
        std::slice::from_ref(&t),
        &AdjustOptions::default(),
    );
    assert_eq!(
        e.unwrap_err().to_string(),
        "tie point 0: 1 view(s), at least 2 needed"
    );
    let two = TiePoint {
        observations: vec![t.observations[0], t.observations[0]],
        ..t
    };
    let e = adjust(
        std::slice::from_ref(&f),
        &[camera(800.0)],
        &[two],
        &AdjustOptions::default(),
    );
    assert_eq!(
        e.unwrap_err().to_string(),
        "tie point 0: a view in frame 3, of 1 frames"
    );
    // A frame naming a camera that was not given is said so (it was "the points are
    // degenerate").
    let f1 = AdjustFrame { camera: 1, ..f };
    let e = adjust(&[f1], &[camera(800.0)], &[], &AdjustOptions::default());
    assert_eq!(
        e.unwrap_err().to_string(),
        "frame 0 names camera 1, but 1 camera(s) were given"
    );
}

#[test]
fn a_wrong_radial_lens_is_corrected_with_the_attitudes() {
    let fl = flight(5, 4, 1.0, &ridges, 13);
    let opts = AdjustOptions {
        refine_focal: true,
        refine_principal_point: false,
        refine_radial: true,
        terrain: Some((&ridges, 0.05)),
        ..Default::default()
    };
    // The ties were seen through a pinhole; the camera is recorded with k1 = 0.05.
    let mut wrong = camera(800.0);
    wrong.distortion = Some(aerorect_core::distortion::Distortion::OpenCv(
        aerorect_core::distortion::OpenCv {
            k1: 0.05,
            ..Default::default()
        },
    ));
    let out = adjust(&fl.recorded, &[wrong], &fl.ties, &opts).unwrap();
    let Some(aerorect_core::distortion::Distortion::OpenCv(lens)) = &out.cameras[0].distortion
    else {
        panic!("no OpenCV lens")
    };
    assert!(lens.k1.abs() < 0.005 && lens.k2.abs() < 0.02, "{lens:?}");
    assert!(max_norm(&errors(&fl.truth, &out.frames)) < 0.05);
}

#[test]
fn a_common_boresight_error_goes_to_the_camera() {
    let mut fl = flight(6, 5, 0.3, &ridges, 17);
    // Every frame's camera turned by the same 2 degrees about its own x and y.
    let b = Rotation3::new(Vector3::new(2f64.to_radians(), -1.5f64.to_radians(), 0.0));
    for f in &mut fl.recorded {
        f.world_from_camera *= b.into_inner();
    }
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        refine_boresight: true,
        attitude_sigma_deg: 0.3,
        terrain: Some((&ridges, 0.05)),
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let got = out.report.cameras[0].boresight_deg;
    assert!(
        (got[0] + 2.0).abs() < 0.1 && (got[1] - 1.5).abs() < 0.1,
        "{got:?}"
    );
    assert!(max_norm(&errors(&fl.truth, &out.frames)) < 0.1);
}

/// Frames from one point 120 m up (a hover: pitched 40-75 degrees off nadir at three
/// headings), recorded 1 degree off, with ties on level ground seen by two or more of them.
fn hover(seed: u64) -> aerorect_testkit::flight::Flight {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let cam = camera(800.0);
    let centre = [0.0, 0.0, 120.0];
    let (mut truth, mut recorded) = (Vec::new(), Vec::new());
    for (k, (tilt, heading)) in [(40f64, 0f64), (50.0, 12.0), (75.0, -10.0)]
        .into_iter()
        .enumerate()
    {
        let r = Rotation3::new(Vector3::z() * heading.to_radians()).into_inner()
            * Rotation3::new(Vector3::x() * tilt.to_radians()).into_inner();
        let e = [0.7, -0.8, 0.6].map(|v: f64| (v * (1.0 + 0.1 * k as f64)).to_radians());
        let f = |m| AdjustFrame {
            camera: 0,
            centre,
            world_from_camera: m,
            position_sigma_m: None,
            attitude_sigma_deg: None,
        };
        truth.push(f(r));
        recorded.push(f(Rotation3::new(Vector3::from(e)).into_inner() * r));
    }
    let mut ties = Vec::new();
    for _ in 0..3000 {
        let g = Vec3::new(
            rng.random_range(-150.0..150.0),
            rng.random_range(0.0..400.0),
            0.0,
        );
        let observations: Vec<Observation> = truth
            .iter()
            .enumerate()
            .filter_map(|(k, f)| {
                let d = f.world_from_camera.transpose() * (g - Vec3::from(f.centre));
                let p = cam.pixel_from_camera_point(d)?;
                let inside = p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= 999.0 && p[1] <= 749.0;
                inside.then_some(Observation {
                    frame: k,
                    pixel: p,
                    weight: 1.0,
                })
            })
            .collect();
        if observations.len() >= 2 {
            // The first guess 3 m off the truth.
            ties.push(TiePoint {
                ground: [g.x + 3.0, g.y - 2.0, 0.0],
                observations,
                control: None,
            });
        }
    }
    aerorect_testkit::flight::Flight {
        truth,
        recorded,
        ties,
    }
}

fn level(_: f64, _: f64) -> f64 {
    0.0
}

/// The hover tests' solve: positions free at 5 m, the ties held to the level ground at 0.1 m.
fn hover_options() -> AdjustOptions<'static> {
    AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        position_sigma_m: Some(5.0),
        terrain: Some((&level, 0.1)),
        ..Default::default()
    }
}

/// The largest attitude error (degrees) of `frames` against `truth` once their common error
/// (what the ties of frames from one point cannot see) is taken out.
fn worst_relative_error(truth: &[AdjustFrame], frames: &[AdjustFrame]) -> f64 {
    let e = errors(truth, frames);
    let common = e.iter().fold(Vec3::zeros(), |a, v| a + v) / e.len() as f64;
    max_norm(&e.iter().map(|v| v - common).collect::<Vec<_>>())
}

#[test]
fn frames_from_one_point_hold_their_positions_and_are_turned_right() {
    let fl = hover(21);
    assert!(fl.ties.len() > 300, "{}", fl.ties.len());
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &hover_options()).unwrap();
    let r = &out.report;
    // The gauge freedom is found: the three frames, zero baseline, about 200 m range.
    assert_eq!(r.gauge.len(), 1, "{:?}", r.gauge);
    assert_eq!(r.gauge[0].frames, vec![0, 1, 2]);
    assert!(r.gauge[0].baseline_m < 1e-9 && r.gauge[0].range_m > 100.0);
    // Held: every position as recorded.
    for f in &out.frames {
        assert_eq!(f.centre, [0.0, 0.0, 120.0]);
    }
    // On level ground their common turn is the priors' (the ties cannot see it): the frames
    // must agree with each other.
    let worst = worst_relative_error(&fl.truth, &out.frames);
    eprintln!(
        "hover: {} ties, worst attitude error {worst:.4} deg, rms {:.2} -> {:.3} px, {} iterations ({:?})",
        r.tie_points, r.rms_before_px, r.rms_after_px, r.iterations, r.termination
    );
    assert!(r.converged, "{:?}", r.termination);
    assert!(worst < 0.05, "{worst}");
    assert!(r.rms_after_px < 0.1);
}

/// The same hover with each fix off by a few decimetres (a GPS's noise; the truth is one
/// point): held at the fixes' mean, the frames agree with each other as from one point (held
/// as recorded, the fake baseline's parallax leaves 0.16 px and bends them 0.035 deg). With
/// RTK priors (a receiver whose centimetres make the same baseline real) they stay where
/// recorded.
#[test]
fn frames_from_one_point_with_noisy_fixes_are_held_at_their_mean() {
    let mut fl = hover(21);
    let noise = [
        [0.15, -0.10, 0.05],
        [-0.10, 0.12, -0.04],
        [0.0, -0.05, 0.10],
    ];
    for (f, d) in fl.recorded.iter_mut().zip(noise) {
        f.centre = [d[0], d[1], 120.0 + d[2]];
    }
    let mean = [0.05 / 3.0, -0.03 / 3.0, 120.0 + 0.11 / 3.0];
    let opts = hover_options();
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let r = &out.report;
    assert_eq!(r.gauge.len(), 1, "{:?}", r.gauge);
    let at = r.gauge[0].held_at.unwrap();
    for (f, k) in out.frames.iter().zip(0..) {
        for i in 0..3 {
            assert!((at[i] - mean[i]).abs() < 1e-9, "{at:?}");
            assert!(
                (f.centre[i] - mean[i]).abs() < 1e-9,
                "frame {k}: {:?}",
                f.centre
            );
        }
    }
    let worst = worst_relative_error(&fl.truth, &out.frames);
    eprintln!(
        "noisy hover: worst relative attitude error {worst:.4} deg, rms {:.3} px, {} iterations ({:?})",
        r.rms_after_px, r.iterations, r.termination
    );
    assert!(r.converged, "{:?}", r.termination);
    assert!(
        worst < 0.005 && r.rms_after_px < 0.01,
        "{worst} {}",
        r.rms_after_px
    );
    // RTK standard deviations (2 cm): the 0.3-m baseline is real, held as recorded.
    for f in &mut fl.recorded {
        f.position_sigma_m = Some([0.02; 3]);
    }
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    assert_eq!(out.report.gauge[0].held_at, None);
    for (f, r) in out.frames.iter().zip(&fl.recorded) {
        assert_eq!(f.centre, r.centre);
    }
    let bent = worst_relative_error(&fl.truth, &out.frames);
    eprintln!(
        "held as recorded: worst relative attitude error {bent:.4} deg, rms {:.3} px",
        out.report.rms_after_px
    );
    // Had these been noise, the baseline's parallax would show in the residuals and turns.
    assert!(out.report.rms_after_px > 0.1 && bent > 0.01, "{bent}");
}

#[test]
fn a_solve_cut_by_its_iteration_limit_says_so_and_gives_its_result() {
    let fl = flight(4, 3, 1.0, &hills, 5);
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&hills, 0.05)),
        max_iterations: 1,
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let r = &out.report;
    assert_eq!(r.iterations, 1);
    assert_eq!(
        r.termination,
        aerorect_solve::adjust::Termination::MaxIterations
    );
    assert!(!r.converged);
    // One step already lowers the residuals (the result is the step's, not the start's).
    assert!(r.rms_after_px < 0.5 * r.rms_before_px, "{r:?}");
    // Unlimited, the same flight stops by a tolerance.
    let full = adjust(
        &fl.recorded,
        &[camera(800.0)],
        &fl.ties,
        &AdjustOptions {
            max_iterations: 50,
            ..opts
        },
    )
    .unwrap();
    assert!(full.report.converged, "{:?}", full.report.termination);
}

/// A flight whose first `wrong` ties are wrong matches: each keeps two views, the second
/// 25 px off along both image axes (partly along the epipolar line, so the point could
/// absorb it by moving along its first ray, which the terrain prior resists).
fn with_wrong_matches(seed: u64, wrong: usize) -> aerorect_testkit::flight::Flight {
    let mut fl = flight(5, 4, 1.0, &hills, seed);
    for t in fl.ties.iter_mut().take(wrong) {
        t.observations.truncate(2);
        t.observations[1].pixel[0] += 25.0;
        t.observations[1].pixel[1] += 25.0;
    }
    fl
}

#[test]
fn wrong_matches_do_not_keep_the_solve_crawling() {
    // The loop's steps weight an observation in Huber's linear arm by k / |r|, which claims a
    // curvature along its residual that the cost (2 k |r|) lacks; a wrong match's point then
    // slides along its ray a few percent of the way per step unless it is moved to its own
    // minimum after each step (without that: 252 iterations here, and 12 iterations left the
    // frames 0.019 of their standard deviation from the minimum). The solve must stop by a
    // tolerance in few iterations at the minimum: where a solve held to tolerances a million
    // times tighter ends.
    let fl = with_wrong_matches(21, 40);
    let cams = [camera(800.0)];
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&hills, 2.0)),
        max_iterations: 500,
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &cams, &fl.ties, &opts).unwrap();
    let r = &out.report;
    let tolerances = aerorect_solve::adjust::Tolerances {
        function: 1e-12,
        gradient: 1e-14,
        parameter: 1e-14,
    };
    let best = adjust(
        &fl.recorded,
        &cams,
        &fl.ties,
        &AdjustOptions {
            tolerances,
            ..opts.clone()
        },
    )
    .unwrap();
    let twelve = AdjustOptions {
        max_iterations: 12,
        ..opts.clone()
    };
    let cut = adjust(&fl.recorded, &cams, &fl.ties, &twelve).unwrap();
    // How far a solve's frames are from the tight one's, in each frame's own standard deviation.
    let gap = |got: &[AdjustFrame]| {
        errors(&best.frames, got)
            .iter()
            .zip(&r.frames)
            .map(|(e, f)| {
                (0..3)
                    .map(|k| e[k].abs() / f.rotation_sigma_deg[k])
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    };
    let worst = max_norm(&errors(&fl.truth, &out.frames));
    eprintln!(
        "{} iterations ({:?}), tight {} ({:?}); from the tight minimum: {:.1e} sigma, after 12 \
         iterations {:.1e}; worst error {worst:.4} deg",
        r.iterations,
        r.termination,
        best.report.iterations,
        best.report.termination,
        gap(&out.frames),
        gap(&cut.frames),
    );
    assert!(r.converged, "{:?}", r.termination);
    assert!(r.iterations <= 40, "{}", r.iterations);
    assert!(gap(&out.frames) < 0.005, "{}", gap(&out.frames));
    assert!(gap(&cut.frames) < 0.005, "{}", gap(&cut.frames));
    // The wrong matches pull a little (Huber bounds each one's pull), the same at the minimum.
    assert!(worst < 0.2, "{worst}");
}

#[test]
fn the_solution_does_not_depend_on_the_number_of_threads() {
    // The normal equations are summed in fixed parts in parallel and the parts added in
    // order: one thread and three give the same bits. Enough frames that the tie points fill
    // many parts and more than one chunk, positions and focal length solved for too.
    let fl = flight(14, 12, 1.0, &hills, 11);
    assert!(fl.ties.len() > 5000, "{} ties", fl.ties.len());
    let frames: Vec<AdjustFrame> = fl
        .recorded
        .iter()
        .map(|f| AdjustFrame {
            position_sigma_m: Some([2.0; 3]),
            ..f.clone()
        })
        .collect();
    let opts = AdjustOptions {
        terrain: Some((&hills, 0.05)),
        ..Default::default()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| adjust(&frames, &[camera(800.0)], &fl.ties, &opts).unwrap())
    };
    let (one, three) = (run(1), run(3));
    let bits = |o: &aerorect_solve::adjust::Adjusted| -> Vec<u64> {
        o.frames
            .iter()
            .flat_map(|f| f.world_from_camera.iter().chain(&f.centre).copied())
            .chain(o.cameras.iter().map(|c| c.intrinsics.fx))
            .map(f64::to_bits)
            .collect()
    };
    assert_eq!(bits(&one), bits(&three));
    assert_eq!(one.report.iterations, three.report.iterations);
    // And the solve is still the solve: every frame back within 0.05 degrees, as in the
    // tests above.
    let worst = max_norm(&errors(&fl.truth, &one.frames));
    assert!(worst < 0.05, "{worst}");
}

/// Without a DEM the level ground is a guess: tie points held to it firmly bend the frames
/// over hills, and held per frame at a loose sigma ([`AdjustOptions::terrain_sigma_by_frame`])
/// they follow the hills where the positions fix the block. The same sigma per frame as the
/// terrain's is the same solve, bit for bit.
#[test]
fn per_frame_terrain_sigma_frees_ties_from_a_level_guess() {
    let fl = flight(5, 4, 1.0, &hills, 13);
    let level = |_: f64, _: f64| 25.0;
    let solve = |by_frame: Option<&[f64]>| {
        let opts = AdjustOptions {
            refine_focal: false,
            refine_principal_point: false,
            terrain: Some((&level, 2.0)),
            terrain_sigma_by_frame: by_frame,
            ..Default::default()
        };
        adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap()
    };
    let n = fl.truth.len();
    let firm = solve(None);
    let same = solve(Some(&vec![2.0; n]));
    let loose = solve(Some(&vec![1000.0; n]));
    let (e_firm, e_loose) = (
        max_norm(&errors(&fl.truth, &firm.frames)),
        max_norm(&errors(&fl.truth, &loose.frames)),
    );
    eprintln!("level guess held at 2 m: worst {e_firm:.4} deg; at 1000 m: {e_loose:.4} deg");
    assert!(
        e_loose < 0.1 && e_firm > 4.0 * e_loose,
        "{e_firm} {e_loose}"
    );
    for (a, b) in firm.frames.iter().zip(&same.frames) {
        assert_eq!(a.world_from_camera, b.world_from_camera);
    }
}
