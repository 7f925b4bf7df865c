//! Shift estimators per frame pair: JTC (the paper's binarised processing on the joint image,
//! and without binarisation in its cross-spectrum form), cross-correlation and phase
//! correlation, on 128, 256 and 512 frames, each in a one-thread rayon pool. The binarised JTC
//! splits its stages over two threads when it has them: `jtc-2t` is that case in a two-thread
//! pool (the others use one core whatever the pool). `*-track` feeds a stream (each frame
//! against the previous one, as `track` does), where the previous frame's spectrum is reused.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_raster::shift::sim::shifted_linear;
use aerorect_raster::shift::{
    JointTransformCorrelator, JtcOptions, PhaseCorrelator, PhaseOptions, ShiftEstimator,
};
use aerorect_testkit::textured_scene;
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn estimator(name: &str, n: usize) -> Box<dyn ShiftEstimator + Send> {
    let phase = |opts| Box::new(PhaseCorrelator::new(n, n, opts).unwrap());
    match name {
        "jtc" => Box::new(JointTransformCorrelator::new(n, n, JtcOptions::default()).unwrap()),
        "jtc-linear" => Box::new(
            JointTransformCorrelator::new(
                n,
                n,
                JtcOptions {
                    binarize: false,
                    ..JtcOptions::default()
                },
            )
            .unwrap(),
        ),
        "xcorr" => phase(PhaseOptions::xcorr()),
        _ => phase(PhaseOptions::phase()),
    }
}

fn shift_benches(c: &mut Criterion) {
    let scene = textured_scene::<f32>(ImageSize::new(1100, 1100), 1, 1.0, 3);
    let mut g = c.benchmark_group("shift");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    let (one, two) = (pool(1), pool(2));
    for n in [128usize, 256, 512] {
        let size = ImageSize::new(n, n);
        let r = shifted_linear(&scene, 20.0, 20.0, size, 0.0, 0.0);
        let t = shifted_linear(&scene, 20.0, 20.0, size, 1.37, -2.61);
        let mut jtc = estimator("jtc", n);
        g.bench_function(BenchmarkId::new("jtc-2t", n), |b| {
            b.iter(|| two.install(|| jtc.estimate(&r, &t).unwrap()))
        });
        for name in ["jtc", "jtc-linear", "xcorr", "phase"] {
            let mut est = estimator(name, n);
            g.bench_function(BenchmarkId::new(name, n), |b| {
                b.iter(|| one.install(|| est.estimate(&r, &t).unwrap()))
            });
            if name != "jtc" {
                // A stream r, t, r, t, ...: each call's reference is the previous call's current.
                let mut est = estimator(name, n);
                let mut flip = false;
                g.bench_function(BenchmarkId::new(format!("{name}-track"), n), |b| {
                    b.iter(|| {
                        flip = !flip;
                        let (a, b) = if flip { (&r, &t) } else { (&t, &r) };
                        one.install(|| est.estimate(a, b).unwrap())
                    })
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, shift_benches);
criterion_main!(benches);
