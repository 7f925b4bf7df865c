//! End-to-end properties of simulate -> rectify -> evaluate on the bundled real photo.
#![allow(clippy::unwrap_used)]

use aerorect::core::attitude::SixAngleDegrees;
use aerorect::core::{
    AltitudeScale, Camera, ImageSize, Intrinsics, RectifyLimits, SixAngleAttitude,
};
use aerorect::evaluate::{evaluate, rectified_psnr};
use aerorect::io::decode_image_bytes;
use aerorect::raster::{AnyRaster, Interp, WarpOptions};
use aerorect::rectify::RectifyPlan;
use aerorect::sensitivity::{SensitivityConfig, run};
use aerorect::simulate::SimulatePlan;
use aerorect_solve::fit_homography;

fn scene() -> AnyRaster {
    decode_image_bytes(aerorect::demo::SCENE_JPEG, "aero1.jpg").unwrap()
}

/// A 320 x 240 pinhole, fx = fy = 400 px, principal point at the centre.
fn setup(att: SixAngleDegrees) -> (Camera, SixAngleAttitude) {
    let k = Intrinsics::new(400.0, 400.0, 159.5, 119.5).unwrap();
    (
        Camera::new(k, None, ImageSize::new(320, 240)),
        SixAngleAttitude::from_degrees(&att).unwrap(),
    )
}

const ATT: SixAngleDegrees = SixAngleDegrees {
    azimuth: 35.0,
    elevation: 18.0,
    image_rotation: -4.0,
    pitch: 2.0,
    roll: 3.0,
    yaw: -20.0,
};

fn round_trip_psnr(true_att: SixAngleDegrees, used_att: SixAngleDegrees, interp: Interp) -> f64 {
    let (cam, truth) = setup(true_att);
    let used = SixAngleAttitude::from_degrees(&used_att).unwrap();
    let scene = scene();
    let sim = SimulatePlan::new(cam.clone(), &truth, scene.size());
    let opts = WarpOptions {
        interp,
        ..Default::default()
    };
    let oblique = sim.render(&scene, &opts).unwrap();
    let plan = RectifyPlan::new(cam.clone(), used, None, RectifyLimits::default(), opts).unwrap();
    let (out, _) = plan.run(&oblique).unwrap();
    let (psnr, n) = rectified_psnr(&out, &plan.geometry, &cam, &scene, 2.0).unwrap();
    assert!(n > 100_000, "compared {n} samples");
    psnr
}

#[test]
fn simulate_then_rectify_reproduces_the_scene() {
    let bicubic = round_trip_psnr(ATT, ATT, Interp::Bicubic);
    let bilinear = round_trip_psnr(ATT, ATT, Interp::Bilinear);
    assert!(bicubic > 32.0, "bicubic round trip PSNR {bicubic:.2} dB");
    assert!(bilinear > 30.0, "bilinear round trip PSNR {bilinear:.2} dB");
    assert!(
        bicubic > bilinear,
        "bicubic keeps more detail: {bicubic:.2} vs {bilinear:.2}"
    );
    // Control: the same measure with a 0.5 degree yaw error must fall well below the bar.
    let wrong = round_trip_psnr(
        ATT,
        SixAngleDegrees {
            yaw: ATT.yaw + 0.5,
            ..ATT
        },
        Interp::Bicubic,
    );
    assert!(
        wrong < 25.0,
        "a wrong attitude must not pass: {wrong:.2} dB"
    );
}

#[test]
fn check_points_evaluate_to_zero_and_fit_the_paper_homography() {
    let (cam, att) = setup(ATT);
    let frame = cam.size;
    let sim = SimulatePlan::new(cam.clone(), &att, scene().size());
    let pts = sim.checkpoints(25);
    assert_eq!(pts.len(), 25);
    let s = evaluate(&cam, &att, &pts).unwrap();
    assert!(s.rmse < 1e-9, "RMSE {} (the issue asks for < 0.01)", s.rmse);
    // Spread over the frame: they span most of it in both directions.
    let span = |f: fn(&aerorect::core::CheckPoint) -> f64| {
        pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
            - pts.iter().map(f).fold(f64::INFINITY, f64::min)
    };
    assert!(span(|p| p.u_oblique) > 0.5 * 320.0 && span(|p| p.v_oblique) > 0.4 * 240.0);
    // An independent DLT fit of the pairs reproduces F = K R K^-1 at the frame corners.
    let from: Vec<[f64; 2]> = pts.iter().map(|p| [p.u_oblique, p.v_oblique]).collect();
    let to: Vec<[f64; 2]> = pts.iter().map(|p| [p.u_standard, p.v_standard]).collect();
    let h = fit_homography(&from, &to).unwrap();
    for c in frame.corner_pixels() {
        let (a, b) = (
            h.map(c[0], c[1]).unwrap(),
            sim.standard_from_oblique.map(c[0], c[1]).unwrap(),
        );
        assert!(
            (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
            "{a:?} vs {b:?}"
        );
    }
    // A perturbed attitude gives a non-zero error.
    let off = SixAngleAttitude::from_degrees(&SixAngleDegrees {
        roll: ATT.roll + 0.05,
        ..ATT
    })
    .unwrap();
    assert!(evaluate(&cam, &off, &pts).unwrap().rmse > 0.1);
}

#[test]
fn altitude_normalisation_scales_the_rectified_image_about_the_principal_point() {
    let (cam, att) = setup(ATT);
    let intr = cam.intrinsics;
    let opts = WarpOptions::default();
    let limits = RectifyLimits::default();
    let plain = RectifyPlan::new(cam.clone(), att, None, limits, opts).unwrap();
    let alt = AltitudeScale::new(1500.0, 1000.0).unwrap();
    let scaled = RectifyPlan::new(cam, att, Some(alt), limits, opts).unwrap();
    // The same oblique pixel lands 1.5 times as far from the principal point.
    for p in [[10.0, 20.0], [300.0, 200.0]] {
        let a = plain.geometry.base_from_oblique.map(p[0], p[1]).unwrap();
        let b = scaled.geometry.base_from_oblique.map(p[0], p[1]).unwrap();
        assert!(((b[0] - intr.cx) - 1.5 * (a[0] - intr.cx)).abs() < 1e-9);
        assert!(((b[1] - intr.cy) - 1.5 * (a[1] - intr.cy)).abs() < 1e-9);
    }
    let ratio = scaled.geometry.output_size.width as f64 / plain.geometry.output_size.width as f64;
    assert!((ratio - 1.5).abs() < 0.02, "{ratio}");
}

#[test]
fn monte_carlo_agrees_with_first_order_error_propagation() {
    let (_, att) = setup(ATT);
    let k = Intrinsics::new(1000.0, 1000.0, 255.5, 255.5).unwrap();
    let cfg = SensitivityConfig {
        camera: Camera::new(k, None, ImageSize::new(512, 512)),
        attitude: att,
        sigma_arcmin: 3.0,
        draws: 4000,
        grid: 5,
        seed: 7,
    };
    let row = run(&cfg).unwrap();
    assert_eq!(row.checkpoints, 25);
    let rel = (row.rms_of_rmse - row.predicted_rms_of_rmse).abs() / row.predicted_rms_of_rmse;
    assert!(
        rel < 0.03,
        "MC {} vs first order {}",
        row.rms_of_rmse,
        row.predicted_rms_of_rmse
    );
    assert!(row.rmse <= row.rms_of_rmse, "mean <= RMS (Jensen)");
    assert!(
        (row.rmse * row.rmse - row.urms * row.urms - row.vrms * row.vrms).abs()
            < 0.2 * row.rmse * row.rmse
    );
    // Errors scale linearly with sigma.
    let half = run(&SensitivityConfig {
        sigma_arcmin: 1.5,
        ..cfg.clone()
    })
    .unwrap();
    assert!(
        (half.predicted_rms_of_rmse * 2.0 - row.predicted_rms_of_rmse).abs()
            < 1e-6 * row.predicted_rms_of_rmse
    );
}

#[test]
fn undistortion_inverts_a_rendered_distortion() {
    use aerorect::core::distortion::Distortion;
    use aerorect::raster::{LensDirection, LensMap, warp};
    use aerorect::undistort::UndistortPlan;
    let AnyRaster::U8(scene) = scene() else {
        panic!("u8")
    };
    let k = Intrinsics::new(500.0, 505.0, 319.5, 239.5).unwrap();
    for kind in ["opencv", "improved"] {
        let mut d = Distortion::zero(kind).unwrap();
        let mut p = vec![0.0; d.model().names().len()];
        p[0] = -0.2;
        p[1] = 0.04;
        d.model_mut().set_params(&p);
        // The recorded frame: each observed pixel takes the ideal scene at its ideal position.
        let record = LensMap::within(k, d.clone(), LensDirection::IdealFromObserved);
        let opts = WarpOptions {
            interp: Interp::Bicubic,
            ..Default::default()
        };
        let recorded = warp(&scene, &record, scene.size(), &opts).unwrap();
        let plan = UndistortPlan::new(&Camera::new(k, Some(d), scene.size()), false).unwrap();
        let AnyRaster::U8(back) = plan.run(&AnyRaster::U8(recorded), &opts).unwrap() else {
            panic!("u8")
        };
        // Compare the central 60 % (the corners leave the frame under barrel distortion).
        let (mut se, mut n) = (0.0, 0);
        for b in 0..3 {
            for y in 96..384 {
                for x in 128..512 {
                    let e = back.get(b, x, y).unwrap() as f64 - scene.get(b, x, y).unwrap() as f64;
                    se += e * e;
                    n += 1;
                }
            }
        }
        let psnr = 10.0 * (255.0f64.powi(2) / (se / n as f64)).log10();
        assert!(psnr > 35.0, "{kind}: {psnr} dB");
    }
}

#[test]
fn the_papers_model_comparison_has_noise_consistent_errors() {
    // Noise 0.1 px per axis: the mean 2-D error of a correct model on check points is about
    // sigma sqrt(pi / 2) = 0.125 px (plus the estimation error of a single-image fit).
    let rows = aerorect::lens_compare::compare(0.1, 1).unwrap();
    let get = |m: &str| rows.iter().find(|r| r.model == m).unwrap().clone();
    let (tsai, brown, improved) = (get("tsai"), get("brown"), get("improved"));
    assert!(
        improved.check_mean_error_px < 1.25 * 0.1 * (std::f64::consts::PI / 2.0).sqrt(),
        "{improved:?}"
    );
    assert!(
        tsai.check_mean_error_px > 1.3 * improved.check_mean_error_px,
        "Tsai has no tangential terms: {tsai:?}"
    );
    assert!(
        brown.check_mean_error_px < 1.05 * improved.check_mean_error_px,
        "{brown:?}"
    );
    assert!(
        brown.mean_error_px <= improved.mean_error_px + 1e-9,
        "more parameters fit the calibration points at least as well"
    );
}
