//! Calibration against OpenCV's own result on the same corners, and against synthetic truth.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;
use aerorect_solve::calib::{CalibrationError, CalibrationOptions, Observation, calibrate};
use aerorect_testkit::opencv_corners;

/// OpenCV 5.0 calibrateCamera on these 702 points, 5 coefficients, no flags (data/README):
/// RMS 0.40869, fx 536.0734, fy 536.0163, cx 342.3705, cy 235.5369.
#[test]
fn reaches_opencvs_result_on_its_own_corners() {
    let obs = opencv_corners();
    assert_eq!(obs.len(), 702);
    let mut opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    opts.fix = vec!["k4".into(), "k5".into(), "k6".into()];
    opts.stop_px = 1e-6;
    let r = calibrate(&obs, &opts).unwrap();
    for (got, want, name) in [
        (r.fx, 536.0734, "fx"),
        (r.fy, 536.0163, "fy"),
        (r.cx, 342.3705, "cx"),
        (r.cy, 235.5369, "cy"),
    ] {
        assert!((got - want).abs() < 0.5, "{name}: {got} vs OpenCV {want}");
    }
    assert!(
        (r.rms_px - 0.40869).abs() < 0.01,
        "RMS {} vs OpenCV 0.40869",
        r.rms_px
    );
    let k = r.distortion.model().params();
    assert!(
        (k[0] + 0.265090).abs() < 0.01 && (k[4] - 0.252316).abs() < 0.05,
        "{k:?}"
    );
    assert_eq!(r.views.len(), 13);
}

#[test]
fn fixed_aspect_ratio_matches_opencvs_flag() {
    // With CALIB_FIX_ASPECT_RATIO: RMS 0.40871, f 536.1079, cx 342.3741, cy 235.5948.
    let mut opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    opts.fix = vec!["k4".into(), "k5".into(), "k6".into()];
    opts.fixed_aspect = Some(1.0);
    opts.stop_px = 1e-6;
    let r = calibrate(&opencv_corners(), &opts).unwrap();
    assert!(
        (r.fx - r.fy).abs() < 1e-9 * r.fx,
        "aspect held at 1: {} {}",
        r.fx,
        r.fy
    );
    assert!(
        (r.fx - 536.1079).abs() < 0.5
            && (r.cx - 342.3741).abs() < 0.5
            && (r.cy - 235.5948).abs() < 0.5
    );
    assert!((r.rms_px - 0.40871).abs() < 0.01);
}

#[test]
fn degenerate_inputs_are_refused() {
    let obs = opencv_corners();
    let one: Vec<Observation> = obs
        .iter()
        .filter(|o| o.image == obs[0].image)
        .cloned()
        .collect();
    let opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    assert_eq!(
        calibrate(&one, &opts).unwrap_err(),
        CalibrationError::PlanarSingleImage
    );
    assert!(matches!(
        calibrate(&one[..5], &opts).unwrap_err(),
        CalibrationError::TooFewPoints { got: 5, .. }
    ));
    let mut few = obs.clone();
    few.push(Observation {
        image: "lonely".into(),
        world: [0.0, 0.0, 0.0],
        pixel: [1.0, 2.0],
    });
    assert!(matches!(
        calibrate(&few, &opts).unwrap_err(),
        CalibrationError::TooFewInImage { got: 1, .. }
    ));
    let mut nan = obs.clone();
    nan[7].pixel[1] = f64::NAN;
    assert!(matches!(
        calibrate(&nan, &opts).unwrap_err(),
        CalibrationError::NotFinite { index: 7, .. }
    ));
    let line: Vec<Observation> = (0..10)
        .map(|i| Observation {
            image: "a".into(),
            world: [i as f64, 2.0 * i as f64, 0.5 * i as f64],
            pixel: [i as f64, i as f64],
        })
        .collect();
    assert!(matches!(
        calibrate(&line, &opts).unwrap_err(),
        CalibrationError::Collinear { .. }
    ));
    let mut bad = opts.clone();
    bad.fix = vec!["k9".into()];
    assert_eq!(
        calibrate(&obs, &bad).unwrap_err(),
        CalibrationError::UnknownParameter("k9".into())
    );
}

/// `opencv` is OpenCV's default five coefficients (issue 14): on OpenCV's chessboard it gives
/// OpenCV's k (-0.265090, -0.046744, 0.001833, -0.000315, 0.252316) with standard deviations
/// far below the values' scale, and no warning that a term went undetermined.
#[test]
fn opencv_is_opencvs_default_five_coefficients() {
    let opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    let r = calibrate(&opencv_corners(), &opts).unwrap();
    let k = r.distortion.model().params();
    let want = [-0.265090, -0.046744, 0.001833, -0.000315, 0.252316];
    assert_eq!(k.len(), 5);
    for (i, (got, want)) in k.iter().zip(want).enumerate() {
        // k2 and k3 trade off along a ridge (correlation -0.98): compare them loosely.
        let tol = [0.002, 0.01, 1e-4, 1e-4, 0.02][i];
        assert!((got - want).abs() < tol, "k[{i}] {got} vs OpenCV {want}");
    }
    assert!((r.rms_px - 0.40869).abs() < 1e-4, "RMS {}", r.rms_px);
    for p in &r.parameters[5..] {
        let std = p.std.unwrap();
        assert!(std < 0.25, "{} std {std}", p.name);
    }
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
}

/// The rational terms cannot be told from k1..k3 on this single plane (k1 and k4 correlate
/// +1.000): `opencv-rational` holds them at zero with a warning, and the rest equals `opencv`.
#[test]
fn opencv_rational_on_one_plane_holds_the_rational_terms_with_a_warning() {
    let size = ImageSize::new(640, 480);
    let five = calibrate(
        &opencv_corners(),
        &CalibrationOptions::new(Distortion::zero("opencv").unwrap(), size),
    )
    .unwrap();
    let opts = CalibrationOptions::new(Distortion::zero("opencv-rational").unwrap(), size);
    let r = calibrate(&opencv_corners(), &opts).unwrap();
    assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
    assert!(
        r.warnings[0].contains("k4, k5, k6") && r.warnings[0].contains("k4"),
        "{}",
        r.warnings[0]
    );
    let k = r.distortion.model().params();
    assert_eq!(k.len(), 8);
    assert_eq!(&k[5..], &[0.0, 0.0, 0.0]);
    for (a, b) in k.iter().zip(five.distortion.model().params()) {
        assert!((a - b).abs() < 1e-9, "{k:?}");
    }
    assert!((r.fx - five.fx).abs() < 1e-6);
}

/// The hold is decided by the data, not the model: a wide lens (r up to 1.1) with a rational
/// denominator, seen as a 3-D field in several views, determines k4..k6, and `opencv-rational`
/// frees them (no warning) and recovers the truth.
#[test]
fn opencv_rational_is_fitted_when_the_points_determine_it() {
    use aerorect_core::distortion::{DistortionModel, OpenCv, OpenCvTerms};
    use nalgebra::{Rotation3, Vector3};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut truth = OpenCv::with_terms(OpenCvTerms::Rational);
    (truth.k1, truth.k2, truth.k4, truth.k5) = (-0.05, 0.01, 0.35, 0.05);
    let (f, cx, cy) = (400.0, 321.0, 238.0);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let mut obs = vec![];
    for (v, (w, t)) in [
        ([0.02, -0.03, 0.01], [0.0, 0.0, 0.0]),
        ([0.15, 0.1, -0.2], [0.2, -0.1, 0.3]),
        ([-0.12, 0.18, 0.4], [-0.2, 0.15, 0.2]),
    ]
    .iter()
    .enumerate()
    {
        let rot = Rotation3::from_scaled_axis(Vector3::from(*w));
        for i in 0..15 {
            for j in 0..11 {
                let z = [3.0, 3.6, 4.3][(i + j) % 3];
                let world = [-3.3 + i as f64 * 0.47, -2.4 + j as f64 * 0.48, z];
                let xc = rot * Vector3::from(world) + Vector3::from(*t);
                let q = truth.value([xc.x / xc.z, xc.y / xc.z]);
                let px = [
                    f * q[0] + cx + noise.sample(&mut rng),
                    f * q[1] + cy + noise.sample(&mut rng),
                ];
                if (0.0..639.0).contains(&px[0]) && (0.0..479.0).contains(&px[1]) {
                    obs.push(Observation {
                        image: format!("view{v}"),
                        world,
                        pixel: px,
                    });
                }
            }
        }
    }
    let mut opts = CalibrationOptions::new(
        Distortion::zero("opencv-rational").unwrap(),
        ImageSize::new(640, 480),
    );
    opts.fix = vec!["k3".into(), "k6".into(), "p1".into(), "p2".into()];
    let r = calibrate(&obs, &opts).unwrap();
    assert!(
        r.warnings.is_empty(),
        "{:?} {:?}",
        r.warnings,
        r.correlations
    );
    let k = r.distortion.model().params();
    for (i, name) in [(0, "k1"), (1, "k2"), (5, "k4"), (6, "k5")] {
        let std = r
            .parameters
            .iter()
            .find(|p| p.name == name)
            .unwrap()
            .std
            .unwrap();
        let want = truth.params()[i];
        assert!(
            (k[i] - want).abs() < 5.0 * std,
            "{name} {} vs {want} (std {std})",
            k[i]
        );
    }
}
