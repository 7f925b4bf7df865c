//! Calibration solve speed (starting values, the Levenberg-Marquardt adjustment with analytic
//! Jacobians, the report) on OpenCV's 13 chessboard views (702 corners, data/calib), per model.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;
use aerorect_solve::calib::{CalibrationOptions, calibrate};
use aerorect_testkit::opencv_corners;
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let obs = opencv_corners();
    for model in ["opencv", "tsai", "improved", "brown"] {
        let mut opts =
            CalibrationOptions::new(Distortion::zero(model).unwrap(), ImageSize::new(640, 480));
        opts.stop_px = 1e-6;
        assert!(calibrate(&obs, &opts).unwrap().rms_px < 0.45);
        c.bench_function(&format!("calibrate 13 views {model}"), |b| {
            b.iter(|| calibrate(&obs, &opts))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = bench
}
criterion_main!(benches);
