//! SIFT keypoints and descriptors (kornia-imgproc's port of OpenCV's) on a 480 x 360 textured
//! scene, the size of the 1,000-frame simulation's frames, on one thread and on all. Criterion
//! reports time per frame; bench/features_vs_opencv.py times real frames beside OpenCV's SIFT.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_raster::Raster;
use aerorect_raster::features::{FeatureOptions, sift};
use aerorect_testkit::textured_scene;
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn sift_benches(c: &mut Criterion) {
    let scene: Raster<f32> = textured_scene(ImageSize::new(480, 360), 1, 255.0, 7);
    let opts = FeatureOptions::default();
    let mut g = c.benchmark_group("sift/480x360");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        g.bench_function(format!("threads_{threads}"), |b| {
            b.iter(|| pool.install(|| sift(&scene, &opts).unwrap()))
        });
    }
    g.finish();
}

criterion_group!(benches, sift_benches);
criterion_main!(benches);
