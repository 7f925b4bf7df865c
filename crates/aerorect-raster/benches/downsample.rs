//! Area-aware downsampling: a 4096^2 gray8 zone plate shrunk 4x to 1024^2 (OpenCV resize's grid)
//! with average, plain bilinear and prefiltered bilinear/bicubic, 1 and 2 threads. Criterion
//! reports elements/s: read it as output pixels per second. bench/downsample_vs_peers.py times the
//! same case beside OpenCV's INTER_AREA and measures each output's aliasing.
//!
//! `downsample/gray32_photo_x4` is a flight round's render: a 3456^2 f32 gray frame (a photo's
//! short side) warped 4x smaller with the prefilter, by `warp` (which reduces the frame afresh)
//! and by `warp_levels` from kept levels; `levels` is building them once.
#![allow(clippy::unwrap_used)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{Interp, Raster, ReducedLevels, WarpOptions, warp, warp_into, warp_levels};
use aerorect_testkit::zone_plate::ZonePlate;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::time::Duration;

const OUT: usize = 1024;
const SCALE: usize = 4;

fn downsample_benches(c: &mut Criterion) {
    // 0.5 + 0.5 cos(k r^2), up to 0.45 cycles/px at the corners, as u8.
    let src: Raster<u8> = ZonePlate::new(OUT * SCALE, 0.45).raster(255.0);
    let (s, o) = (SCALE as f64, 0.5 * (SCALE as f64 - 1.0));
    let map = Homography::new(Mat3::new(s, 0.0, o, 0.0, s, o, 0.0, 0.0, 1.0)).unwrap();
    let size = ImageSize::new(OUT, OUT);
    let mut g = c.benchmark_group("downsample/gray8_x4");
    g.throughput(Throughput::Elements(size.pixels() as u64));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let cases = [
        ("average", Interp::Average, true),
        ("bilinear", Interp::Bilinear, false),
        ("bilinear_prefilter", Interp::Bilinear, true),
        ("bicubic_prefilter", Interp::Bicubic, true),
    ];
    for (name, interp, prefilter) in cases {
        let opts = WarpOptions {
            interp,
            prefilter,
            ..Default::default()
        };
        let mut dst = Raster::<u8>::new(size, 1).unwrap();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let id = BenchmarkId::new(name, format!("{threads}t"));
            g.bench_function(id, |b| {
                b.iter(|| pool.install(|| warp_into(&src, &map, &opts, &mut dst).unwrap()))
            });
        }
    }
    g.finish();
}

fn kept_levels_benches(c: &mut Criterion) {
    let side = 3456;
    let src: Raster<f32> = ZonePlate::new(side, 0.45).raster(255.0);
    let (s, o) = (SCALE as f64, 0.5 * (SCALE as f64 - 1.0));
    let map = Homography::new(Mat3::new(s, 0.0, o, 0.0, s, o, 0.0, 0.0, 1.0)).unwrap();
    let size = ImageSize::new(side / SCALE, side / SCALE);
    let opts = WarpOptions {
        interp: Interp::Bilinear,
        nodata: f64::NAN,
        prefilter: true,
        ..Default::default()
    };
    let levels = ReducedLevels::of(&src).unwrap();
    let mut g = c.benchmark_group("downsample/gray32_photo_x4");
    g.throughput(Throughput::Elements(size.pixels() as u64));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("warp", |b| {
        b.iter(|| warp(&src, &map, size, &opts).unwrap())
    });
    g.bench_function("warp_levels", |b| {
        b.iter(|| warp_levels(&levels, &map, size, &opts).unwrap().unwrap())
    });
    g.bench_function("levels", |b| {
        b.iter(|| {
            ReducedLevels::from_rows(src.size(), |r, out| {
                out.copy_from_slice(&src.plane(0)[r * side..(r + 1) * side]);
            })
            .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, downsample_benches, kept_levels_benches);
criterion_main!(benches);
