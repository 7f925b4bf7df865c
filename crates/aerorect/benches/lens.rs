//! Calibration of 13 views x 54 points (OpenCV's corners, 5-coefficient model) and an
//! undistortion map + remap of a 4000 x 3000 gray frame.
#![allow(clippy::unwrap_used)]

use aerorect::core::distortion::Distortion;
use aerorect::core::{Camera, ImageSize, Intrinsics};
use aerorect::raster::{AnyRaster, WarpOptions};
use aerorect::undistort::UndistortPlan;
use aerorect_solve::calib::{CalibrationOptions, Observation, calibrate};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn corners() -> Vec<Observation> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_corners.csv");
    aerorect::calibration::read_observations(&path).unwrap()
}

fn lens(c: &mut Criterion) {
    let obs = corners();
    let mut opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    opts.fix = vec!["k4".into(), "k5".into(), "k6".into()];
    let mut g = c.benchmark_group("lens");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    g.bench_function("calibrate_13x54_opencv5", |b| {
        b.iter(|| calibrate(&obs, &opts).unwrap())
    });
    let size = ImageSize::new(4000, 3000);
    let img = AnyRaster::U8(aerorect_testkit::textured_scene(size, 1, 255.0, 1));
    let k = Intrinsics::new(3000.0, 3000.0, 1999.5, 1499.5).unwrap();
    let mut d = Distortion::zero("opencv").unwrap();
    d.model_mut()
        .set_params(&[-0.265, -0.0467, 0.0018, -0.0003, 0.252]);
    let camera = Camera::new(k, Some(d), size);
    let warp = WarpOptions::default();
    g.bench_function("undistort_4000x3000_gray8_bilinear", |b| {
        b.iter(|| {
            UndistortPlan::new(&camera, false)
                .unwrap()
                .run(&img, &warp)
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, lens);
criterion_main!(benches);
