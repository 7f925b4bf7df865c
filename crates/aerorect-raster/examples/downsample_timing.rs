//! Times area-aware downsampling for `bench/downsample_vs_peers.py`.
//!
//! usage: downsample_timing INPUT.u8 WIDTH HEIGHT OUT_DIR OUT_WIDTH OUT_HEIGHT SCALE THREADS REPEATS
//! INPUT is raw gray u8, row-major. The map is OpenCV resize's: output pixel c reads input
//! SCALE (c + 0.5) - 0.5 on both axes. For average, bilinear and bicubic (prefilter off and on)
//! prints one JSON line each with the median and minimum seconds of the warp alone, and writes the
//! last output to OUT_DIR/ours_{case}.u8.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{Interp, Raster, WarpOptions, warp_into};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    assert_eq!(
        a.len(),
        10,
        "usage: downsample_timing INPUT.u8 W H OUT_DIR OW OH SCALE THREADS REPEATS"
    );
    let n = |i: usize| a[i].parse::<usize>().expect("a whole number");
    let size = ImageSize::new(n(2), n(3));
    let input = std::fs::read(&a[1]).expect("input");
    let src = Raster::from_planes(size, vec![input]).expect("W x H bytes");
    let out_size = ImageSize::new(n(5), n(6));
    let s: f64 = a[7].parse().expect("scale");
    let o = 0.5 * (s - 1.0);
    let map = Homography::new(Mat3::new(s, 0.0, o, 0.0, s, o, 0.0, 0.0, 1.0)).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(n(8))
        .build()
        .unwrap();
    let cases = [
        ("average", Interp::Average, true),
        ("bilinear", Interp::Bilinear, false),
        ("bilinear_prefilter", Interp::Bilinear, true),
        ("bicubic", Interp::Bicubic, false),
        ("bicubic_prefilter", Interp::Bicubic, true),
    ];
    for (name, interp, prefilter) in cases {
        let opts = WarpOptions {
            interp,
            prefilter,
            ..Default::default()
        };
        let mut dst = Raster::<u8>::new(out_size, 1).unwrap();
        let mut times: Vec<f64> = (0..n(9))
            .map(|_| {
                let t = Instant::now();
                pool.install(|| warp_into(&src, &map, &opts, &mut dst).unwrap());
                t.elapsed().as_secs_f64()
            })
            .collect();
        std::fs::write(format!("{}/ours_{name}.u8", a[4]), dst.plane(0)).unwrap();
        times.sort_by(f64::total_cmp);
        println!(
            "{{\"case\": \"{name}\", \"median_s\": {}, \"min_s\": {}}}",
            times[times.len() / 2],
            times[0]
        );
    }
}
