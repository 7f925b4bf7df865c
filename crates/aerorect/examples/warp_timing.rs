//! Times the warp engine on one image and homography, for `bench/warp_vs_opencv.py`.
//!
//! usage: warp_timing IMAGE OUT H00,H01,...,H22 WIDTH HEIGHT INTERP THREADS REPEATS
//! H maps output pixel (col, row, 1) to input pixel. Prints one JSON line with the median and
//! minimum seconds of the resampling alone; writes the last output to OUT.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::core::{Homography, ImageSize, Mat3};
use aerorect::io::{read_image, write_image};
use aerorect::raster::{AnyRaster, Interp, PixelMap, Raster, Sample, WarpOptions, warp_into};
use std::time::Instant;

fn time<T: Sample>(
    src: &Raster<T>,
    h: &impl PixelMap,
    size: ImageSize,
    opts: &WarpOptions,
    repeats: usize,
) -> (Vec<f64>, Raster<T>) {
    let mut dst = Raster::new(size, src.bands()).unwrap();
    let times = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            warp_into(src, h, opts, &mut dst).unwrap();
            t.elapsed().as_secs_f64()
        })
        .collect();
    (times, dst)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    assert_eq!(
        a.len(),
        9,
        "usage: warp_timing IMAGE OUT H00,..,H22 WIDTH HEIGHT INTERP THREADS REPEATS"
    );
    let img = read_image(a[1].as_ref()).expect("input image");
    let v: Vec<f64> = a[3]
        .split(',')
        .map(|s| s.parse().expect("number"))
        .collect();
    let h = Homography::new(Mat3::from_row_slice(&v)).expect("invertible homography");
    let size = ImageSize::new(a[4].parse().unwrap(), a[5].parse().unwrap());
    let interp: Interp = a[6].parse().unwrap();
    let threads: usize = a[7].parse().unwrap();
    let repeats: usize = a[8].parse().unwrap();
    let opts = WarpOptions {
        interp,
        ..Default::default()
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (mut times, out) = pool.install(|| match &img {
        AnyRaster::U8(r) => {
            let (t, o) = time(r, &h, size, &opts, repeats);
            (t, AnyRaster::U8(o))
        }
        AnyRaster::U16(r) => {
            let (t, o) = time(r, &h, size, &opts, repeats);
            (t, AnyRaster::U16(o))
        }
        AnyRaster::F32(r) => {
            let (t, o) = time(r, &h, size, &opts, repeats);
            (t, AnyRaster::F32(o))
        }
    });
    write_image(a[2].as_ref(), &out).unwrap();
    times.sort_by(f64::total_cmp);
    println!(
        "{{\"median_s\": {}, \"min_s\": {}}}",
        times[times.len() / 2],
        times[0]
    );
}
