//! Adjustment time and accuracy on a simulated flight of NX x NY frames over hills (1 degree
//! attitude errors, 0.3 px tie noise): `cargo run --release -p aerorect-solve --example
//! adjust_flight -- 40 25`. Run under `/usr/bin/time -v` for the peak memory.
#![allow(clippy::unwrap_used)]

use aerorect_solve::adjust::{AdjustOptions, adjust};
use aerorect_testkit::flight::{camera, flight};
use nalgebra::Rotation3;

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (nx, ny) = (
        args.first().copied().unwrap_or(10),
        args.get(1).copied().unwrap_or(10),
    );
    let hills = |x: f64, y: f64| 25.0 + 20.0 * (x / 40.0).sin() * (y / 35.0).cos();
    let t = std::time::Instant::now();
    let fl = flight(nx, ny, 1.0, &hills, 1);
    let simulated = t.elapsed().as_secs_f64();
    let opts = AdjustOptions {
        refine_focal: true,
        refine_principal_point: false,
        terrain: Some((&hills, 0.05)),
        ..Default::default()
    };
    let out = adjust(&fl.recorded, &[camera(800.0)], &fl.ties, &opts).unwrap();
    let worst = fl
        .truth
        .iter()
        .zip(&out.frames)
        .map(|(t, g)| {
            Rotation3::from_matrix_unchecked(g.world_from_camera * t.world_from_camera.transpose())
                .angle()
                .to_degrees()
        })
        .fold(0.0, f64::max);
    let r = &out.report;
    println!(
        "{} frames, {} tie points, {} observations: adjusted in {:.2} s ({} iterations, converged {}), rms {:.2} -> {:.3} px, worst attitude error {:.4} deg (simulation {:.1} s)",
        nx * ny,
        r.tie_points,
        r.observations,
        r.seconds,
        r.iterations,
        r.converged,
        r.rms_before_px,
        r.rms_after_px,
        worst,
        simulated
    );
}
