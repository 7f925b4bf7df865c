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

/// A strongly folding lens of every model, in [`Distortion::NAMES`] order.
fn folding_models() -> Vec<Distortion> {
    let coefficients: [&[f64]; 7] = [
        &[-0.4, 0.0],
        &[
            -0.4, 0.02, 0.0, 1e-3, -1e-3, 1e-3, -5e-4, 1e-3, 5e-4, -5e-4, 5e-4, -1e-3, 1e-3, 5e-4,
            -5e-4, 1e-3, -1e-3,
        ],
        &[-0.4, 0.02, 1e-3, -1e-3, 1e-3, -1e-3],
        &[-0.4, 0.06, 1e-3, -5e-4, 0.0],
        &[-0.3, 0.05, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0],
        &[-0.4, 0.06, 0.0, 0.0, 0.0, 2e-3, -1e-3, -1.5e-3, 5e-4],
        &[
            -0.35, 0.05, 1e-3, -5e-4, 0.0, 0.05, 0.0, 0.0, 2e-3, -1e-3, -1.5e-3, 5e-4,
        ],
    ];
    Distortion::NAMES
        .iter()
        .zip(coefficients)
        .map(|(kind, c)| {
            let mut d = Distortion::zero(kind).expect("known");
            d.model_mut().set_params(c);
            d
        })
        .collect()
}

/// Dense march (independent of the domain's bisection): the value along the ray from the axis
/// to `a` increases at each of `steps` steps with a positive Jacobian determinant.
fn monotonic_to(m: &dyn DistortionModel, a: [f64; 2], steps: usize) -> bool {
    let r = a[0].hypot(a[1]);
    let u = [a[0] / r, a[1] / r];
    let v0 = m.value([0.0, 0.0]);
    let mut last = 0.0;
    (1..=steps).all(|i| {
        let t = i as f64 / steps as f64;
        let (v, j) = m.value_d_point([t * a[0], t * a[1]]);
        let along = (v[0] - v0[0]) * u[0] + (v[1] - v0[1]) * u[1];
        let ok = along > last && j[0][0] * j[1][1] - j[0][1] * j[1][0] > 0.0;
        last = along;
        ok
    })
}

#[test]
fn radial_valid_domain_is_the_closed_form_fold() {
    // x (1 + k1 r^2) folds where d/dr = 1 + 3 k1 r^2 = 0, whichever way the model goes.
    let k1: f64 = -0.4;
    let fold = 1.0 / (3.0 * -k1).sqrt();
    let o = OpenCv {
        k1,
        ..Default::default()
    };
    let t = Tsai { k1, k2: 0.0 };
    for (d, direction) in [
        (Distortion::OpenCv(o), Direction::ObservedFromIdeal),
        (Distortion::Tsai(t), Direction::IdealFromObserved),
    ] {
        let v = d.valid_domain();
        assert_eq!(v.direction, direction);
        assert!((v.radius - fold).abs() < 1e-5, "{}: {v:?}", d.kind());
        // The rim's image: r (1 + k1 r^2) at the fold.
        let image = fold * (1.0 + k1 * fold * fold);
        assert!((v.image_radius - image).abs() < 1e-5, "{v:?}");
    }
    // The P4 RTK's DewarpData lens (issue 28): 1 + 3 k1 u + 5 k2 u^2 + 7 k3 u^3 = 0 at u = r^2.
    let p4 = OpenCv {
        k1: -0.267,
        k2: 0.112,
        k3: -0.033,
        ..Default::default()
    };
    let r = p4.valid_domain().radius;
    let slope = |r: f64| {
        let u = r * r;
        1.0 + 3.0 * p4.k1 * u + 5.0 * p4.k2 * u * u + 7.0 * p4.k3 * u * u * u
    };
    assert!(slope(r * 0.999) > 0.0 && slope(r * 1.001) < 0.0, "{r}");
    assert!((1.3..1.4).contains(&r), "{r}");
}

#[test]
fn every_model_is_monotonic_inside_its_valid_domain_and_folds_just_beyond() {
    for d in folding_models() {
        let m = d.model();
        let v = d.valid_domain();
        assert!(v.is_bounded(), "{}: {v:?}", d.kind());
        let mut folds_beyond = false;
        for i in 0..360 {
            let a = (i as f64).to_radians();
            let u = [a.cos(), a.sin()];
            let at = |r: f64| [r * u[0], r * u[1]];
            assert!(
                monotonic_to(m, at(v.radius), 4000),
                "{} at {i} deg: not monotonic inside {v:?}",
                d.kind()
            );
            folds_beyond |= !monotonic_to(m, at(1.02 * v.radius), 4000);
        }
        assert!(folds_beyond, "{}: the domain {v:?} is too small", d.kind());
    }
}

#[test]
fn a_lens_that_never_folds_has_an_unbounded_domain() {
    for kind in Distortion::NAMES {
        let d = Distortion::zero(kind).expect("known");
        assert!(!d.valid_domain().is_bounded(), "{kind}");
    }
    let pincushion = OpenCv {
        k1: 0.1,
        k2: 0.01,
        ..Default::default()
    };
    assert!(!pincushion.valid_domain().is_bounded());
}

#[test]
fn the_gated_directions_refuse_points_beyond_the_fold() {
    for d in folding_models() {
        let m = d.model();
        let v = d.valid_domain();
        let (inside, beyond) = (0.9 * v.radius, 1.3 * v.radius);
        for a in [0.3f64, 2.0, 4.0] {
            let (c, s) = (a.cos(), a.sin());
            let q = [inside * c, inside * s];
            let far = [beyond * c, beyond * s];
            let value = m.value(q);
            // The closed form's argument inside: both directions answer and agree.
            let (to_value, back) = match v.direction {
                Direction::ObservedFromIdeal => (
                    m.observed_from_ideal_within(&v, q),
                    m.ideal_from_observed_within(&v, value),
                ),
                Direction::IdealFromObserved => (
                    m.ideal_from_observed_within(&v, q),
                    m.observed_from_ideal_within(&v, value),
                ),
            };
            assert_eq!(to_value, Some(value), "{}", d.kind());
            let back = back.unwrap_or_else(|| panic!("{}: no inverse inside", d.kind()));
            assert!((back[0] - q[0]).abs() < 1e-9 && (back[1] - q[1]).abs() < 1e-9);
            // Beyond the fold: no answer, though the plain closed form has one.
            let refused = match v.direction {
                Direction::ObservedFromIdeal => m.observed_from_ideal_within(&v, far),
                Direction::IdealFromObserved => m.ideal_from_observed_within(&v, far),
            };
            assert_eq!(refused, None, "{}", d.kind());
        }
    }
}
