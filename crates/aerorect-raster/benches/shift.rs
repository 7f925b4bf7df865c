//! Shift estimators per frame pair: JTC (the paper's processing), cross-correlation and phase
//! correlation, on 128, 256 and 512 frames (single-threaded: the estimators use one core).
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_raster::shift::sim::shifted_linear;
use aerorect_raster::shift::{
    JointTransformCorrelator, JtcOptions, PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting,
};
use aerorect_testkit::textured_scene;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn shift_benches(c: &mut Criterion) {
    let scene = textured_scene::<f32>(ImageSize::new(1100, 1100), 1, 1.0, 3);
    let mut g = c.benchmark_group("shift");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for n in [128usize, 256, 512] {
        let size = ImageSize::new(n, n);
        let r = shifted_linear(&scene, 20.0, 20.0, size, 0.0, 0.0);
        let t = shifted_linear(&scene, 20.0, 20.0, size, 1.37, -2.61);
        let mut estimators: Vec<(&str, Box<dyn ShiftEstimator>)> = vec![
            (
                "jtc",
                Box::new(JointTransformCorrelator::new(n, n, JtcOptions::default()).unwrap()),
            ),
            (
                "xcorr",
                Box::new(
                    PhaseCorrelator::new(
                        n,
                        n,
                        PhaseOptions {
                            weighting: Weighting::None,
                            window: true,
                        },
                    )
                    .unwrap(),
                ),
            ),
            (
                "phase",
                Box::new(
                    PhaseCorrelator::new(
                        n,
                        n,
                        PhaseOptions {
                            weighting: Weighting::Phase,
                            window: true,
                        },
                    )
                    .unwrap(),
                ),
            ),
        ];
        for (name, est) in estimators.iter_mut() {
            g.bench_function(BenchmarkId::new(*name, n), |b| {
                b.iter(|| est.estimate(&r, &t).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, shift_benches);
criterion_main!(benches);
