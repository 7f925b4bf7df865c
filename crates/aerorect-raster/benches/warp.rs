//! Warp engine throughput: gray8, rgb8, rgba8, gray16, f32 x nearest, bilinear, bicubic x 1 and 2 threads.
//! Criterion reports elements/s: read it as output pixels per second. Each kernel also runs
//! once with `Coordinates::Exact` at 1 thread (`<kernel>-exact`), to show what the default fast
//! coordinates save.
#![allow(clippy::unwrap_used)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{Coordinates, Interp, Raster, Sample, WarpOptions, warp_into};
use aerorect_testkit::textured_scene;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::time::Duration;

const SIDE: usize = 1024;

/// A mild oblique-rectification homography: nearly every output pixel has a source.
pub fn bench_homography() -> Homography {
    Homography::new(Mat3::new(
        0.95, 0.08, 20.0, -0.06, 0.9, 40.0, 5e-5, 8e-5, 1.0,
    ))
    .unwrap()
}

fn group<T: Sample>(c: &mut Criterion, name: &str, bands: usize, peak: f32) {
    let size = ImageSize::new(SIDE, SIDE);
    let src: Raster<T> = textured_scene(size, bands, peak, 1);
    let h = bench_homography();
    let mut g = c.benchmark_group(format!("warp/{name}"));
    g.throughput(Throughput::Elements(size.pixels() as u64));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for interp in [Interp::Nearest, Interp::Bilinear, Interp::Bicubic] {
        let opts = WarpOptions {
            interp,
            ..Default::default()
        };
        let mut dst = Raster::<T>::new(size, bands).unwrap();
        let exact = WarpOptions {
            coordinates: Coordinates::Exact,
            ..opts
        };
        for (threads, opts, suffix) in [(1, opts, ""), (2, opts, ""), (1, exact, "-exact")] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let id = BenchmarkId::new(format!("{}{suffix}", interp.name()), format!("{threads}t"));
            g.bench_function(id, |b| {
                b.iter(|| pool.install(|| warp_into(&src, &h, &opts, &mut dst).unwrap()))
            });
        }
    }
    g.finish();
}

fn warp_benches(c: &mut Criterion) {
    group::<u8>(c, "gray8", 1, 255.0);
    group::<u8>(c, "rgb8", 3, 255.0);
    group::<u8>(c, "rgba8", 4, 255.0);
    group::<u16>(c, "gray16", 1, 65535.0);
    group::<f32>(c, "f32", 1, 1.0);
}

criterion_group!(benches, warp_benches);
criterion_main!(benches);
