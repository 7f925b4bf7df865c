#![allow(clippy::needless_range_loop)]
//! The conformance test every model passes: both directions round-trip, the point and parameter
//! Jacobians agree with central differences, and the serialised form round-trips.

use super::*;

fn models() -> Vec<Distortion> {
    let mut out = vec![];
    let mut t = Tsai::default();
    t.set_params(&[-0.21, 0.05]);
    out.push(Distortion::Tsai(t));
    let mut b = Brown::default();
    b.set_params(&[
        -0.2, 0.04, -0.01, 1e-3, -2e-3, 1e-3, -2e-3, 3e-3, 1e-3, -1e-3, 2e-3, 1e-3, -3e-3, 2e-3,
        1e-3, 2e-3, -1e-3,
    ]);
    out.push(Distortion::Brown(b));
    let mut i = Improved::default();
    i.set_params(&[-0.18, 0.03, 1.5e-3, -8e-4, 2e-3, -1e-3]);
    out.push(Distortion::Improved(i));
    let mut o = OpenCv::default();
    o.set_params(&[-0.265, -0.0467, 0.0018, -0.0003, 0.252]);
    out.push(Distortion::OpenCv(o));
    let mut o = OpenCv::with_terms(OpenCvTerms::Rational);
    o.set_params(&[-0.265, -0.0467, 0.0018, -0.0003, 0.252, 0.01, -0.02, 0.005]);
    out.push(Distortion::OpenCv(o));
    let mut o = OpenCv::with_terms(OpenCvTerms::ThinPrism);
    o.set_params(&[-0.2, 0.04, 1e-3, -5e-4, 0.01, 2e-3, -1e-3, -1.5e-3, 5e-4]);
    out.push(Distortion::OpenCv(o));
    let mut o = OpenCv::with_terms(OpenCvTerms::RationalThinPrism);
    o.set_params(&[
        -0.2, 0.04, 1e-3, -5e-4, 0.01, 0.02, -0.01, 0.003, 2e-3, -1e-3, -1.5e-3, 5e-4,
    ]);
    out.push(Distortion::OpenCv(o));
    out
}

fn grid() -> Vec<[f64; 2]> {
    let mut g = vec![];
    for i in -4..=4 {
        for j in -3..=3 {
            g.push([i as f64 * 0.1, j as f64 * 0.1]);
        }
    }
    g
}

#[test]
fn both_directions_round_trip() {
    for d in models() {
        let m = d.model();
        for p in grid() {
            let o = m
                .observed_from_ideal(p)
                .unwrap_or_else(|| panic!("{}: no observed point for {p:?}", d.kind()));
            let back = m
                .ideal_from_observed(o)
                .unwrap_or_else(|| panic!("{}: no ideal point", d.kind()));
            assert!(
                (back[0] - p[0]).abs() < 1e-10 && (back[1] - p[1]).abs() < 1e-10,
                "{}: {p:?} -> {o:?} -> {back:?}",
                d.kind()
            );
        }
    }
}

#[test]
fn jacobians_match_central_differences() {
    let h = 1e-6;
    for d in models() {
        let m = d.model();
        for p in grid() {
            let c = m.closed(p);
            for k in 0..2 {
                let (mut a, mut b) = (p, p);
                a[k] += h;
                b[k] -= h;
                let (va, vb) = (m.closed(a).value, m.closed(b).value);
                for i in 0..2 {
                    let num = (va[i] - vb[i]) / (2.0 * h);
                    assert!(
                        (c.d_point[i][k] - num).abs() < 1e-6,
                        "{} d_point[{i}][{k}] at {p:?}: {} vs {num}",
                        d.kind(),
                        c.d_point[i][k]
                    );
                }
            }
            let theta = m.params();
            for j in 0..theta.len() {
                let mut dm = d.clone();
                let mut t = theta.clone();
                t[j] += h;
                dm.model_mut().set_params(&t);
                let va = dm.model().closed(p).value;
                t[j] -= 2.0 * h;
                dm.model_mut().set_params(&t);
                let vb = dm.model().closed(p).value;
                for i in 0..2 {
                    let num = (va[i] - vb[i]) / (2.0 * h);
                    assert!(
                        (c.d_params[j][i] - num).abs() < 1e-6,
                        "{} d/d{} at {p:?}",
                        d.kind(),
                        m.names()[j]
                    );
                }
            }
        }
    }
}

#[test]
fn serialisation_round_trips_by_name() {
    for d in models() {
        let text = toml::to_string(&d).expect("serialises");
        assert!(
            text.contains(&format!("model = \"{}\"", d.kind())),
            "{text}"
        );
        let back: Distortion = toml::from_str(&text).expect("parses");
        assert_eq!(back, d);
    }
    let e = toml::from_str::<Distortion>("model = \"tsai\"\nk1 = 0.1\nk3 = 0.2\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("k3"), "{e}");
}

#[test]
fn closed_into_equals_closed() {
    for d in models() {
        let m = d.model();
        let mut d_params = vec![[f64::NAN; 2]; m.names().len()];
        for p in grid() {
            let c = m.closed(p);
            let (value, d_point) = m.closed_into(p, &mut d_params);
            assert_eq!((value, d_point), (c.value, c.d_point), "{}", d.kind());
            assert_eq!(d_params, c.d_params, "{} at {p:?}", d.kind());
        }
    }
}

#[test]
fn fast_paths_equal_the_closed_form() {
    for d in models() {
        let m = d.model();
        for p in grid() {
            let c = m.closed(p);
            let (v, dp) = m.value_d_point(p);
            // The fast paths may evaluate the same polynomial in another order (Horner).
            let close = |a: [f64; 2], b: [f64; 2]| {
                (a[0] - b[0]).abs() < 1e-14 && (a[1] - b[1]).abs() < 1e-14
            };
            assert!(close(m.value(p), c.value), "{}", d.kind());
            assert!(close(v, c.value), "{}", d.kind());
            for i in 0..2 {
                for j in 0..2 {
                    assert!((dp[i][j] - c.d_point[i][j]).abs() < 1e-15, "{}", d.kind());
                }
            }
        }
    }
}

#[test]
fn zero_models_are_the_identity() {
    for kind in Distortion::NAMES {
        let d = Distortion::zero(kind).expect("known");
        let p = [0.3, -0.2];
        assert_eq!(d.model().ideal_from_observed(p), Some(p));
        assert_eq!(d.model().observed_from_ideal(p), Some(p));
    }
}

#[test]
fn a_non_invertible_point_gives_none() {
    // Strong barrel distortion folds over beyond r = 1/sqrt(3 |k1|): no observed point there.
    let o = OpenCv {
        k1: -0.9,
        ..Default::default()
    };
    assert!(o.ideal_from_observed([0.7, 0.0]).is_none());
}

#[test]
fn each_opencv_variant_has_opencvs_coefficients_in_opencvs_order() {
    let names = |kind: &str| {
        Distortion::zero(kind)
            .expect("known")
            .model()
            .names()
            .to_vec()
    };
    assert_eq!(names("opencv"), ["k1", "k2", "p1", "p2", "k3"]);
    assert_eq!(
        names("opencv-rational"),
        ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]
    );
    assert_eq!(
        names("opencv-thin-prism"),
        ["k1", "k2", "p1", "p2", "k3", "s1", "s2", "s3", "s4"]
    );
    assert_eq!(names("opencv-rational-thin-prism").len(), 12);
    // The thin prism adds s1 r^2 + s2 r^4 to x and s3 r^2 + s4 r^4 to y (OpenCV's
    // cvProjectPoints2): at (0.3, 0.4), r^2 = 0.25.
    let mut o = OpenCv::with_terms(OpenCvTerms::ThinPrism);
    (o.s1, o.s2, o.s3, o.s4) = (0.1, 0.2, 0.3, 0.4);
    let v = o.value([0.3, 0.4]);
    assert!(
        (v[0] - (0.3 + 0.1 * 0.25 + 0.2 * 0.0625)).abs() < 1e-15,
        "{v:?}"
    );
    assert!(
        (v[1] - (0.4 + 0.3 * 0.25 + 0.4 * 0.0625)).abs() < 1e-15,
        "{v:?}"
    );
}

#[test]
fn an_older_opencv_file_with_rational_terms_loads_as_the_rational_model() {
    let d: Distortion =
        toml::from_str("model = \"opencv\"\nk1 = -0.2\nk4 = 0.01\nk6 = 0.003\n").expect("parses");
    assert_eq!(d.kind(), "opencv-rational");
    let Distortion::OpenCv(o) = &d else {
        panic!("{d:?}")
    };
    assert_eq!((o.k1, o.k4, o.k5, o.k6), (-0.2, 0.01, 0.0, 0.003));
    assert_eq!(d.model().params().len(), 8);
    // The default model writes only its five coefficients.
    let text = toml::to_string(&Distortion::zero("opencv").expect("known")).expect("writes");
    assert!(!text.contains("k4") && !text.contains("s1"), "{text}");
}
