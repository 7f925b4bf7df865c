//! Extended: the nadir pair DJI_0010/0012, rectified from metadata alone and after the flight
//! adjustment, measured by the overlap correlator on the written frames (an estimator the
//! adjustment does not use).
#![allow(clippy::unwrap_used)]

use aerorect::drone::{DroneOptions, rectify_photo};
use aerorect::flight::{FlightOptions, adjust_flight};

#[test]
fn adjustment_brings_the_nadir_pair_within_a_pixel() {
    let (Some(a), Some(b)) = (
        aerorect_testkit::shared_data("drone-xmp/DJI_0010.JPG"),
        aerorect_testkit::shared_data("drone-xmp/DJI_0012.JPG"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let opts = DroneOptions {
        gsd_m: Some(0.1),
        ..Default::default()
    };
    let out = |tag: &str, k: usize| dir.path().join(format!("{tag}{k}.tif"));
    for (k, p) in [&a, &b].into_iter().enumerate() {
        rectify_photo(p, &out("raw", k), &opts, None).unwrap();
    }
    let flight = adjust_flight(&[a.clone(), b.clone()], &opts, &FlightOptions::default()).unwrap();
    assert!(flight.report.pairs[0].reliable && flight.report.unconnected.is_empty());
    for k in 0..2 {
        flight.write_frame(k, &out("adj", k), &opts).unwrap();
    }
    let before = aerorect::overlap::overlap_shift(&out("raw", 0), &out("raw", 1), 256).unwrap();
    let after = aerorect::overlap::overlap_shift(&out("adj", 0), &out("adj", 1), 256).unwrap();
    let norm = |v: [f64; 2]| v[0].hypot(v[1]);
    eprintln!(
        "misalignment {:.3} m -> {:.3} m",
        norm(before.median_m),
        norm(after.median_m)
    );
    assert!(norm(before.median_m) > 1.0, "{:?}", before.median_m);
    // Below one output pixel (0.1 m).
    assert!(norm(after.median_px) < 1.0, "{:?}", after.median_px);
}
