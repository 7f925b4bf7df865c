//! Flight adjustment speed: a simulated block of 10 x 10 frames (testkit's `dense_flight`,
//! 100 m over hills, attitudes recorded 0.5 degrees off), its tie points split into pairs of
//! views as a flight's matcher gives them (about 1,600 per frame, a 1,000-frame flight's last
//! solve has 2,065), positions free with a 3 m prior, the tie points held near the terrain.
#![allow(clippy::unwrap_used)]

use aerorect_solve::adjust::{AdjustOptions, TiePoint, adjust};
use aerorect_testkit::flight::{camera, dense_flight};
use criterion::{Criterion, criterion_group, criterion_main};

fn hills(x: f64, y: f64) -> f64 {
    25.0 + 20.0 * (x / 40.0).sin() * (y / 35.0).cos()
}

/// Each tie point's views taken two at a time (a last odd view is dropped).
fn pairs(ties: &[TiePoint]) -> Vec<TiePoint> {
    ties.iter()
        .flat_map(|t| {
            t.observations.chunks_exact(2).map(|o| TiePoint {
                ground: t.ground,
                observations: o.to_vec(),
                control: None,
            })
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let fl = dense_flight(10, 10, 0.5, &hills, 7, 600);
    let ties = pairs(&fl.ties);
    let opts = AdjustOptions {
        attitude_sigma_deg: 5.0,
        position_sigma_m: Some(3.0),
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&hills, 0.5)),
        standard_deviations: false,
        ..Default::default()
    };
    let cameras = [camera(800.0)];
    let once = adjust(&fl.recorded, &cameras, &ties, &opts).unwrap();
    eprintln!(
        "{} frames, {} tie points, {} observations: {} iterations, rms {:.3} px",
        fl.recorded.len(),
        once.report.tie_points,
        once.report.observations,
        once.report.iterations,
        once.report.rms_after_px
    );
    let mut g = c.benchmark_group("adjust");
    g.sample_size(10);
    g.bench_function("10x10 frames, paired ties, cold", |b| {
        b.iter(|| adjust(&fl.recorded, &cameras, &ties, &opts).unwrap())
    });
    let warm = AdjustOptions {
        start: Some(&once.corrections),
        settled: Some(1e-4),
        ..opts.clone()
    };
    g.bench_function("10x10 frames, paired ties, warm", |b| {
        b.iter(|| adjust(&fl.recorded, &cameras, &ties, &warm).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
