//! Shift estimators and the simulation helpers against independent truths.
#![allow(clippy::unwrap_used, clippy::needless_range_loop)]

use aerorect_core::ImageSize;
use aerorect_raster::Raster;
use aerorect_raster::shift::sim::{add_noise, crlb_rms, shifted_fourier, shifted_linear, variance};
use aerorect_raster::shift::{
    JointTransformCorrelator, JtcOptions, PhaseCorrelator, PhaseOptions, ShiftError,
    ShiftEstimator, SubPixel,
};
use aerorect_testkit::textured_scene;
use rand::SeedableRng;

/// Sum of Gaussian blobs at fixed places, moved by (dx, dy): an analytic, band-limited scene.
fn blobs(n: usize, dx: f64, dy: f64) -> Vec<f32> {
    let centres = [
        (40.0, 50.0, 6.0),
        (90.0, 30.0, 4.0),
        (70.0, 95.0, 8.0),
        (20.0, 100.0, 3.0),
        (100.0, 100.0, 5.0),
    ];
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64, (i / n) as f64);
            centres
                .iter()
                .map(|&(cx, cy, s)| {
                    (-((x - cx - dx).powi(2) + (y - cy - dy).powi(2)) / (2.0 * s * s)).exp()
                })
                .sum::<f64>() as f32
        })
        .collect()
}

fn estimators(n: usize) -> Vec<(&'static str, Box<dyn ShiftEstimator>)> {
    vec![
        (
            "jtc",
            Box::new(JointTransformCorrelator::new(n, n, JtcOptions::default()).unwrap()),
        ),
        (
            "jtc-plain",
            Box::new(
                JointTransformCorrelator::new(
                    n,
                    n,
                    JtcOptions {
                        laplacian: false,
                        spectral_filter: false,
                        binarize: false,
                        subpixel: SubPixel::Parabola,
                    },
                )
                .unwrap(),
            ),
        ),
        (
            "phase",
            Box::new(PhaseCorrelator::new(n, n, PhaseOptions::phase()).unwrap()),
        ),
        (
            "xcorr",
            Box::new(PhaseCorrelator::new(n, n, PhaseOptions::xcorr()).unwrap()),
        ),
    ]
}

#[test]
fn a_moved_blob_scene_gives_the_shift_with_the_documented_sign() {
    let n = 128;
    let r = blobs(n, 0.0, 0.0);
    for (name, mut est) in estimators(n) {
        for &(dx, dy) in &[(3.4, -1.8), (-2.25, 0.6), (0.0, 4.0)] {
            let t = blobs(n, dx, dy);
            let e = est.estimate(&r, &t).unwrap();
            // The JTC's 3 x 3 centroid is coarse on this sparse scene, and phase correlation
            // whitens frequencies where smooth blobs carry only round-off; the sign is the point.
            let tol = match name {
                "xcorr" => 0.02,
                "phase" => 0.3,
                _ => 0.4,
            };
            assert!(
                (e.dx - dx).abs() < tol && (e.dy - dy).abs() < tol,
                "{name}: ({}, {}) for ({dx}, {dy})",
                e.dx,
                e.dy
            );
            assert!(e.confidence > 0.0 && e.confidence <= 1.0);
        }
    }
}

fn scene() -> Raster<f32> {
    textured_scene(ImageSize::new(400, 400), 1, 1.0, 17)
}

#[test]
fn integer_shifts_of_a_texture_are_exact_and_fourier_shifts_sub_pixel() {
    let s = scene();
    let size = ImageSize::new(128, 128);
    let r = shifted_linear(&s, 130.0, 140.0, size, 0.0, 0.0);
    for (name, mut est) in estimators(128) {
        let t = shifted_linear(&s, 130.0, 140.0, size, -3.0, 2.0);
        let e = est.estimate(&r, &t).unwrap();
        let tol = match name {
            "jtc" => 0.1,
            "jtc-plain" => 0.2,
            _ => 0.01,
        };
        assert!(
            (e.dx + 3.0).abs() < tol && (e.dy - 2.0).abs() < tol,
            "{name}: ({}, {})",
            e.dx,
            e.dy
        );
        let t = shifted_fourier(&s, 130, 140, size, 1.3, -0.45);
        let e = est.estimate(&r, &t).unwrap();
        let tol = if name.starts_with("jtc") { 0.2 } else { 0.02 };
        assert!(
            (e.dx - 1.3).abs() < tol && (e.dy + 0.45).abs() < tol,
            "{name} fourier: ({}, {})",
            e.dx,
            e.dy
        );
    }
}

#[test]
fn fourier_shift_by_whole_pixels_equals_the_crop() {
    let s = scene();
    let size = ImageSize::new(64, 64);
    let a = shifted_fourier(&s, 150, 150, size, 2.0, -3.0);
    let b = shifted_linear(&s, 150.0, 150.0, size, 2.0, -3.0);
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "{worst}");
}

#[test]
fn bad_frames_are_refused() {
    let mut est = PhaseCorrelator::new(16, 16, PhaseOptions::default()).unwrap();
    let good: Vec<f32> = (0..256).map(|i| (i % 7) as f32).collect();
    assert_eq!(
        est.estimate(&good, &[1.0; 256]).unwrap_err(),
        ShiftError::Constant { frame: "current" }
    );
    let mut nan = good.clone();
    nan[37] = f32::NAN;
    assert!(matches!(
        est.estimate(&nan, &good).unwrap_err(),
        ShiftError::NonFinite {
            frame: "reference",
            index: 37,
            ..
        }
    ));
    assert!(matches!(
        est.estimate(&good, &good[..200]).unwrap_err(),
        ShiftError::SizeMismatch {
            got: 200,
            want: 256,
            ..
        }
    ));
    assert!(matches!(
        JointTransformCorrelator::new(4, 40, JtcOptions::default()),
        Err(ShiftError::TooSmall { .. })
    ));
}

#[test]
fn crlb_of_a_separable_sinusoid_has_the_closed_form() {
    // I = sin(kx x) + sin(ky y): central differences give Ix = sin(kx) cos(kx x), Iy likewise;
    // over the 48 interior columns/rows (whole periods) sum cos^2 = 24 and sum Ix Iy = 0.
    let (n, s2) = (50usize, 0.01);
    let (kx, ky) = (
        2.0 * std::f64::consts::PI / 8.0,
        2.0 * std::f64::consts::PI / 12.0,
    );
    let img: Vec<f32> = (0..n * n)
        .map(|i| ((kx * (i % n) as f64).sin() + (ky * (i / n) as f64).sin()) as f32)
        .collect();
    let jxx = kx.sin().powi(2) * 24.0 * 48.0 / (2.0 * s2);
    let jyy = ky.sin().powi(2) * 24.0 * 48.0 / (2.0 * s2);
    let want = (1.0 / jxx + 1.0 / jyy).sqrt();
    let got = crlb_rms(&img, ImageSize::new(n, n), s2);
    assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
}

#[test]
fn noise_has_the_requested_snr() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let clean = scene().plane(0).to_vec();
    for snr in [-2.0, 4.0, 20.0] {
        let mut noisy = clean.clone();
        let var = add_noise(&mut noisy, snr, &mut rng);
        let noise: Vec<f32> = noisy.iter().zip(&clean).map(|(a, b)| a - b).collect();
        let measured = 10.0 * (variance(&clean) / variance(&noise)).log10();
        assert!((measured - snr).abs() < 0.05, "{measured} vs {snr}");
        assert!((variance(&noise) / var - 1.0).abs() < 0.02);
    }
}

/// A frame against itself has moved by nothing: every JTC variant must say so. One way, the
/// spectral filter's weight 2 - 2 cos(2 pi x / 6w) (not symmetric about the cross peak at 2w)
/// and the binarised spectrum's background pulled the peak by up to 0.26 px on small frames.
#[test]
fn a_frame_against_itself_has_not_moved() {
    let s = scene();
    let mut worst = 0.0f64;
    for (w, h) in [(32, 32), (48, 40), (64, 64), (160, 120), (128, 128)] {
        for (x0, y0) in [(10.0, 20.0), (130.0, 140.0), (250.0, 60.0)] {
            let f = shifted_linear(&s, x0, y0, ImageSize::new(w, h), 0.0, 0.0);
            for subpixel in [SubPixel::Gaussian, SubPixel::Centroid, SubPixel::Parabola] {
                for (laplacian, spectral_filter, binarize) in [
                    (true, true, true),
                    (false, true, false),
                    (false, false, false),
                    (true, false, true),
                ] {
                    let opts = JtcOptions {
                        laplacian,
                        spectral_filter,
                        binarize,
                        subpixel,
                    };
                    let mut jtc = JointTransformCorrelator::new(w, h, opts).unwrap();
                    let e = jtc.estimate(&f, &f).unwrap();
                    let m = e.dx.abs().max(e.dy.abs());
                    if m > 1e-3 {
                        eprintln!("{w}x{h} at ({x0}, {y0}) {opts:?}: ({}, {})", e.dx, e.dy);
                    }
                    worst = worst.max(m);
                }
            }
        }
    }
    assert!(worst < 1e-3, "worst {worst}");
}

/// A shift by linear interpolation blurs the moved frame with the kernel [1 - f, f], whose
/// phase is not linear in frequency: the high frequencies put the content nearer the whole
/// pixel than the true shift f (the kernel's centroid, where the low frequencies put it).
/// Correlation weighting every frequency alike was pulled towards whole pixels (here by 0.16 px
/// RMS for phase correlation, 0.06 px for cross-correlation); the shipped options smooth the
/// correlation surface and must stay within the bounds over fractions across the pixel.
/// (Phase correlation at 20 dB is left out: on this scene, whose variance sits in its low
/// frequencies, whitening lets the noise dominate, 0.13 px RMS with or without smoothing.)
#[test]
fn linear_interpolation_shifts_are_not_pulled_to_whole_pixels() {
    let s = scene();
    let size = ImageSize::new(128, 128);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for (name, opts, snr, bound) in [
        ("phase", PhaseOptions::phase(), None, 0.04),
        ("xcorr", PhaseOptions::xcorr(), None, 0.02),
        ("xcorr", PhaseOptions::xcorr(), Some(20.0), 0.03),
    ] {
        let mut est = PhaseCorrelator::new(128, 128, opts).unwrap();
        let mut sum = 0.0;
        let fractions = [0.1, 0.2, 0.3, 0.4, 0.6, 0.7, 0.8, 0.9];
        for (i, f) in fractions.iter().enumerate() {
            let (dx, dy) = (1.0 + f, -2.0 + (1.0 - f) * (i % 3) as f64 / 2.0);
            let mut r = shifted_linear(&s, 140.0, 130.0, size, 0.0, 0.0);
            let mut t = shifted_linear(&s, 140.0, 130.0, size, dx, dy);
            if let Some(db) = snr {
                add_noise(&mut r, db, &mut rng);
                add_noise(&mut t, db, &mut rng);
            }
            let e = est.estimate(&r, &t).unwrap();
            sum += (e.dx - dx).powi(2) + (e.dy - dy).powi(2);
        }
        let rms = (sum / fractions.len() as f64).sqrt();
        assert!(rms < bound, "{name} at SNR {snr:?} dB: RMS {rms} px");
    }
}
