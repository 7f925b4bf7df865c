//! Calibration solve speed (starting values, the Levenberg-Marquardt adjustment with analytic
//! Jacobians, the report) on OpenCV's 13 chessboard views (702 corners, data/calib), per model.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;
use aerorect_solve::calib::{CalibrationOptions, Observation, calibrate};
use criterion::{Criterion, criterion_group, criterion_main};

fn opencv_corners() -> Vec<Observation> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_corners.csv");
    let mut rdr = csv::Reader::from_path(path).unwrap();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| r[i].parse::<f64>().unwrap();
            Observation {
                image: r[0].to_string(),
                world: [f(1), f(2), f(3)],
                pixel: [f(4), f(5)],
            }
        })
        .collect()
}

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
