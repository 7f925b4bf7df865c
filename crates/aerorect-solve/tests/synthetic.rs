//! Calibration recovers known parameters from synthetic control points with 0.05 px noise.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_core::distortion::{Direction, Distortion};
use aerorect_solve::calib::{CalibrationOptions, Observation, calibrate};
use nalgebra::{Rotation3, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

const K: [f64; 4] = [1000.0, 990.0, 322.0, 241.0];
const NOISE: f64 = 0.05;

/// The observed pixel of world point `w` seen from pose (w_rot, t) through `d`.
fn observe(d: &Distortion, rot: &Rotation3<f64>, t: &Vector3<f64>, w: [f64; 3]) -> [f64; 2] {
    let xc = rot * Vector3::from(w) + t;
    let ideal = [xc.x / xc.z, xc.y / xc.z];
    let o = d.model().observed_from_ideal(ideal).unwrap();
    [K[0] * o[0] + K[2], K[1] * o[1] + K[3]]
}

fn noisy(obs: &mut [Observation], seed: u64) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let n = Normal::new(0.0, NOISE).unwrap();
    for o in obs {
        o.pixel[0] += n.sample(&mut rng);
        o.pixel[1] += n.sample(&mut rng);
    }
}

fn truth(kind: &str) -> Distortion {
    let mut d = Distortion::zero(kind).unwrap();
    let names = d.model().names();
    let mut p = vec![0.0; names.len()];
    for (i, n) in names.iter().enumerate() {
        p[i] = match *n {
            "k1" => -0.12,
            "k2" => 0.03,
            "p1" => 1.2e-3,
            "p2" => -6e-4,
            _ => 0.0,
        };
    }
    d.model_mut().set_params(&p);
    d
}

/// Parameters the models share with the intrinsics (affine film terms, offsets) are fixed.
fn fixes(kind: &str) -> Vec<String> {
    let f: &[&str] = match kind {
        "brown" => &[
            "k3", "a1", "a2", "a5", "a6", "a7", "b1", "b2", "b5", "b6", "b7", "dx0", "dy0",
        ],
        "improved" => &["dx0", "dy0"],
        "opencv" => &["k3", "k4", "k5", "k6"],
        _ => &[],
    };
    f.iter().map(|s| s.to_string()).collect()
}

fn check(kind: &str, obs: &[Observation]) {
    // A camera records only what falls on its 640 x 480 sensor (calibrate refuses the rest).
    let inside = |o: &&Observation| {
        (-0.5..=639.5).contains(&o.pixel[0]) && (-0.5..=479.5).contains(&o.pixel[1])
    };
    let obs: Vec<Observation> = obs.iter().filter(inside).cloned().collect();
    let mut opts =
        CalibrationOptions::new(Distortion::zero(kind).unwrap(), ImageSize::new(640, 480));
    opts.fix = fixes(kind);
    let r = calibrate(&obs, &opts).unwrap();
    for (got, want, name) in [
        (r.fx, K[0], "fx"),
        (r.fy, K[1], "fy"),
        (r.cx, K[2], "cx"),
        (r.cy, K[3], "cy"),
    ] {
        assert!((got - want).abs() < 1.0, "{kind} {name}: {got} vs {want}");
    }
    let (got, want) = (r.distortion.model().params(), truth(kind).model().params());
    for (i, n) in r.distortion.model().names().iter().enumerate() {
        // Noise-consistent tolerance: 5 sigma of the reported standard deviation, at least 1e-4.
        let std = r
            .parameters
            .iter()
            .find(|p| p.name == *n)
            .and_then(|p| p.std)
            .unwrap_or(0.0);
        assert!(
            (got[i] - want[i]).abs() <= (5.0 * std).max(1e-4),
            "{kind} {n}: {} vs {} (std {std})",
            got[i],
            want[i]
        );
    }
    // The residuals are the noise: RMS close to sqrt(2) * 0.05 px (fewer degrees of freedom).
    assert!(
        r.rms_px < 1.2 * NOISE * 2f64.sqrt() && r.rms_px > 0.6 * NOISE * 2f64.sqrt(),
        "{kind} rms {}",
        r.rms_px
    );
}

/// The paper's procedure: one image of a 3-D field, DLT start, distortion from zero.
#[test]
fn single_image_3d_field_every_model() {
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.05, -0.08, 0.02));
    let t = Vector3::new(0.1, -0.05, 0.3);
    for kind in ["tsai", "brown", "improved", "opencv"] {
        let d = truth(kind);
        let mut obs = vec![];
        for i in 0..12 {
            for j in 0..9 {
                let z = [4.0, 4.6, 5.3][(i + j) % 3];
                let w = [-1.6 + i as f64 * 0.29, -1.1 + j as f64 * 0.28, z];
                obs.push(Observation {
                    image: "field".into(),
                    world: w,
                    pixel: observe(&d, &rot, &t, w),
                });
            }
        }
        noisy(&mut obs, 5);
        check(kind, &obs);
    }
}

/// Several views of a planar target (Zhang start).
#[test]
fn planar_target_in_several_views_every_model() {
    let poses = [
        (
            Vector3::new(0.3, -0.2, 0.05),
            Vector3::new(-0.15, -0.1, 0.9),
        ),
        (
            Vector3::new(-0.25, 0.3, -0.1),
            Vector3::new(-0.1, -0.12, 1.0),
        ),
        (Vector3::new(0.1, 0.35, 0.2), Vector3::new(-0.2, -0.05, 0.8)),
        (
            Vector3::new(-0.35, -0.1, 0.0),
            Vector3::new(-0.12, -0.15, 1.1),
        ),
        (
            Vector3::new(0.05, 0.05, 0.3),
            Vector3::new(-0.15, -0.1, 0.7),
        ),
    ];
    for kind in ["tsai", "brown", "improved", "opencv"] {
        let d = truth(kind);
        let mut obs = vec![];
        for (v, (w, t)) in poses.iter().enumerate() {
            let rot = Rotation3::from_scaled_axis(*w);
            for i in 0..10 {
                for j in 0..7 {
                    let p = [i as f64 * 0.03, j as f64 * 0.03, 0.0];
                    obs.push(Observation {
                        image: format!("v{v}"),
                        world: p,
                        pixel: observe(&d, &rot, t, p),
                    });
                }
            }
        }
        noisy(&mut obs, 9);
        check(kind, &obs);
        assert_eq!(
            d.model().direction() == Direction::ObservedFromIdeal,
            kind == "opencv"
        );
    }
}
