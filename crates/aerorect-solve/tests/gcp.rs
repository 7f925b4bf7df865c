//! Known-truth tests for the GCP transforms and RANSAC: exact without noise, residuals
//! consistent with the noise with it.

use aerorect_core::{Homography, Mat3, PlaneTransform, PolyKind};
use aerorect_solve::SolveError;
use aerorect_solve::gcp::{
    GcpModel, fit_piecewise, fit_polynomial, fit_projective, fit_transform, residuals, rms,
};
use aerorect_solve::ransac::{RansacOptions, ransac_homography};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Raw-coordinate coefficients (u then v) of a smooth warp of a 1000 px frame, per order.
fn truth_coeffs(kind: PolyKind) -> [Vec<f64>; 2] {
    let all_u = [12.0, 0.93, 0.11, 2e-5, -3e-5, 1e-5, 4e-9, -2e-9, 3e-9, 1e-9];
    let all_v = [
        -7.0, -0.08, 1.05, -1e-5, 2e-5, 3e-5, -1e-9, 2e-9, 5e-9, -3e-9,
    ];
    let n = kind.terms().len();
    let pick = |all: &[f64]| match kind {
        PolyKind::Bilinear => vec![all[0], all[1], all[2], all[4]],
        _ => all[..n].to_vec(),
    };
    [pick(&all_u), pick(&all_v)]
}

fn eval_raw(kind: PolyKind, c: &[Vec<f64>; 2], p: [f64; 2]) -> [f64; 2] {
    let f = |c: &Vec<f64>| -> f64 {
        kind.terms()
            .iter()
            .zip(c)
            .map(|(&(i, j), a)| a * p[0].powi(i) * p[1].powi(j))
            .sum()
    };
    [f(&c[0]), f(&c[1])]
}

fn scatter(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| [rng.random_range(0.0..1000.0), rng.random_range(0.0..800.0)])
        .collect()
}

fn noisy(points: &[[f64; 2]], sigma: f64, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = Normal::new(0.0, sigma).expect("sigma");
    points
        .iter()
        .map(|p| [p[0] + d.sample(&mut rng), p[1] + d.sample(&mut rng)])
        .collect()
}

const KINDS: [PolyKind; 3] = [PolyKind::Bilinear, PolyKind::Quadratic, PolyKind::Cubic];

#[test]
fn polynomials_are_exact_without_noise() {
    for kind in KINDS {
        let truth = truth_coeffs(kind);
        let from = scatter(30, 1);
        let to: Vec<_> = from.iter().map(|&p| eval_raw(kind, &truth, p)).collect();
        let fit = fit_polynomial(kind, &from, &to).expect("fit");
        let raw = fit.raw_coefficients();
        for d in 0..2 {
            for (k, (got, want)) in raw[d].iter().zip(&truth[d]).enumerate() {
                let tol = 1e-9 * want.abs().max(1e-9) + 1e-12;
                assert!(
                    (got - want).abs() <= tol.max(1e-10),
                    "{kind:?} coord {d} term {k}: {got} vs {want}"
                );
            }
        }
        // And at points that were not fitted.
        for p in scatter(20, 2) {
            let (a, b) = (fit.map(p[0], p[1]), eval_raw(kind, &truth, p));
            assert!((a[0] - b[0]).abs() < 1e-8 && (a[1] - b[1]).abs() < 1e-8);
        }
    }
}

/// Least squares with n points and m terms leaves E[sum r^2] = 2 (n - m) sigma^2.
#[test]
fn residuals_match_the_noise() {
    let sigma = 0.5;
    for kind in KINDS {
        let truth = truth_coeffs(kind);
        let from = scatter(400, 3);
        let to: Vec<_> = from.iter().map(|&p| eval_raw(kind, &truth, p)).collect();
        let to = noisy(&to, sigma, 4);
        let model = fit_transform(GcpModel::Polynomial(kind), &from, &to).expect("fit");
        let m = kind.terms().len() as f64;
        let want = (2.0 * (400.0 - m) / 400.0).sqrt() * sigma;
        let got = rms(&residuals(&model, &from, &to));
        assert!(
            (got / want - 1.0).abs() < 0.1,
            "{kind:?}: rms {got}, expected {want}"
        );
    }
}

fn truth_h() -> Homography {
    Homography::new(Mat3::new(
        0.9, 0.2, 30.0, -0.1, 1.1, -12.0, 2e-4, -1e-4, 1.0,
    ))
    .expect("h")
}

#[test]
fn projective_is_exact_and_minimises_the_geometric_error() {
    let h = truth_h();
    let from = scatter(30, 5);
    let to: Vec<_> = from.iter().filter_map(|p| h.map(p[0], p[1])).collect();
    let fit = fit_projective(&from, &to).expect("fit");
    for p in scatter(10, 6) {
        let (a, b) = (
            fit.map(p[0], p[1]).expect("a"),
            h.map(p[0], p[1]).expect("b"),
        );
        assert!((a[0] - b[0]).abs() < 1e-8 && (a[1] - b[1]).abs() < 1e-8);
    }
    // With noise, Gauss-Newton's geometric error is no larger than the DLT's, and consistent
    // with the noise (8 parameters).
    let to = noisy(&to, 1.0, 7);
    let gn = PlaneTransform::Projective(fit_projective(&from, &to).expect("fit"));
    let dlt = PlaneTransform::Projective(aerorect_solve::fit_homography(&from, &to).expect("dlt"));
    let (e_gn, e_dlt) = (
        rms(&residuals(&gn, &from, &to)),
        rms(&residuals(&dlt, &from, &to)),
    );
    assert!(e_gn <= e_dlt + 1e-12, "{e_gn} > {e_dlt}");
    let want = (2.0 * 22.0 / 30.0f64).sqrt();
    assert!(e_gn > 0.5 * want && e_gn < 1.5 * want, "{e_gn} vs {want}");
}

#[test]
fn too_few_or_degenerate_points_are_refused() {
    let from = scatter(5, 8);
    assert_eq!(
        fit_polynomial(PolyKind::Quadratic, &from, &from).map(|_| ()),
        Err(SolveError::TooFewPoints { got: 5, need: 6 })
    );
    // Collinear points cannot fix the v and uv terms.
    let line: Vec<[f64; 2]> = (0..12).map(|k| [k as f64 * 10.0, k as f64 * 5.0]).collect();
    assert_eq!(
        fit_polynomial(PolyKind::Bilinear, &line, &line).map(|_| ()),
        Err(SolveError::Degenerate)
    );
    assert_eq!(
        fit_projective(&line, &line).map(|_| ()),
        Err(SolveError::Degenerate)
    );
    let mut bad = scatter(12, 9);
    bad[3][1] = f64::NAN;
    assert_eq!(
        fit_polynomial(PolyKind::Bilinear, &bad, &bad).map(|_| ()),
        Err(SolveError::NotFinite { index: 3 })
    );
}

#[test]
fn piecewise_interpolates_the_points_and_reproduces_an_affine_map() {
    let from = scatter(40, 10);
    let affine = |p: [f64; 2]| {
        [
            3.0 + 1.1 * p[0] - 0.2 * p[1],
            -4.0 + 0.1 * p[0] + 0.95 * p[1],
        ]
    };
    let to: Vec<_> = from.iter().map(|&p| affine(p)).collect();
    let pw = fit_piecewise(&from, &to).expect("fit");
    for (f, t) in from.iter().zip(&to) {
        let m = pw.map(f[0], f[1]).expect("vertex");
        assert!((m[0] - t[0]).abs() < 1e-8 && (m[1] - t[1]).abs() < 1e-8);
    }
    for p in scatter(200, 11) {
        if let (Some(m), Some(_)) = (pw.map(p[0], p[1]), pw.locate(p[0], p[1])) {
            let w = affine(p);
            assert!((m[0] - w[0]).abs() < 1e-8 && (m[1] - w[1]).abs() < 1e-8);
        }
    }
    // Every triangle of a Delaunay triangulation: each scatter point is found in some triangle
    // when it lies inside the hull, so the located share is large.
    let inside = scatter(200, 11)
        .iter()
        .filter(|p| pw.locate(p[0], p[1]).is_some())
        .count();
    assert!(inside > 120, "{inside}");
}

#[test]
fn ransac_rejects_gross_outliers_and_is_seeded() {
    let h = truth_h();
    let from = scatter(200, 12);
    let mut to: Vec<_> = from.iter().filter_map(|p| h.map(p[0], p[1])).collect();
    to = noisy(&to, 0.3, 13);
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let mut outlier = [false; 200];
    for (k, t) in to.iter_mut().enumerate() {
        if k % 10 < 4 {
            t[0] += rng.random_range(20.0..200.0);
            t[1] -= rng.random_range(20.0..200.0);
            outlier[k] = true;
        }
    }
    let opts = RansacOptions::default();
    let fit = ransac_homography(&from, &to, &opts).expect("ransac");
    for (k, (inl, out)) in fit.inliers.iter().zip(outlier).enumerate() {
        assert_eq!(*inl, !out, "pair {k}");
    }
    for p in scatter(10, 15) {
        let (a, b) = (
            fit.model.map(p[0], p[1]).expect("a"),
            h.map(p[0], p[1]).expect("b"),
        );
        assert!((a[0] - b[0]).hypot(a[1] - b[1]) < 0.3, "{a:?} vs {b:?}");
    }
    let again = ransac_homography(&from, &to, &opts).expect("ransac");
    assert_eq!(again.model, fit.model);
}

/// A stored peer result: GDAL 3.10's GCP transformer (through rasterio 1.4.4's GCPTransformer,
/// order 2 chosen by GDAL for 30 GCPs) on 30 grid GCPs of a 1024 x 1024 image mapped by a
/// perspective, evaluated georeferenced -> pixel (GDAL's +0.5 pixel-centre offsets removed).
/// bench/gcp_vs_gdal.py builds the same GCPs.
#[test]
fn quadratic_equals_gdal_gcp_transformer() {
    let h = Homography::new(Mat3::new(
        0.92, 0.15, 40.0, -0.06, 1.05, 25.0, 1.2e-4, 2.5e-4, 1.0,
    ))
    .expect("h");
    let (mut image, mut reference) = (vec![], vec![]);
    for gy in 0..5 {
        for gx in 0..6 {
            let (u, v) = (
                20.0 + gx as f64 * 983.0 / 5.0,
                20.0 + gy as f64 * 983.0 / 4.0,
            );
            image.push([u, v]);
            reference.push(h.map(u, v).expect("ground"));
        }
    }
    let fit = fit_polynomial(PolyKind::Quadratic, &reference, &image).expect("fit");
    let gdal = [
        ([160.0, 87.0], [125.92153993078149, 69.38870287264305]),
        ([460.0, 387.0], [468.2389352323723, 431.6191465326595]),
    ];
    for (r, want) in gdal {
        let got = fit.map(r[0], r[1]);
        assert!(
            (got[0] - want[0]).abs() < 1e-9 && (got[1] - want[1]).abs() < 1e-9,
            "{got:?} vs {want:?}"
        );
    }
}
