//! Median compute times of calibration (13 x 54 corners) and undistortion (4000 x 3000 gray8,
//! bilinear), for `bench/lens_vs_opencv.py`. usage: lens_timing CORNERS.csv REPEATS
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::core::distortion::Distortion;
use aerorect::core::{Camera, ImageSize, Intrinsics};
use aerorect::raster::{AnyRaster, Raster, WarpOptions};
use aerorect::undistort::UndistortPlan;
use aerorect_solve::calib::{CalibrationOptions, calibrate};
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let repeats: usize = a[2].parse().expect("REPEATS");
    let obs = aerorect::calibration::read_observations(a[1].as_ref()).expect("corners");
    let mut opts = CalibrationOptions::new(
        Distortion::zero("opencv").unwrap(),
        ImageSize::new(640, 480),
    );
    opts.fix = vec!["k4".into(), "k5".into(), "k6".into()];
    let cal: Vec<f64> = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            calibrate(&obs, &opts).unwrap();
            t.elapsed().as_secs_f64()
        })
        .collect();
    let size = ImageSize::new(4000, 3000);
    let data: Vec<u8> = (0..size.pixels())
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    let img = AnyRaster::U8(Raster::from_planes(size, vec![data]).unwrap());
    let k = Intrinsics::new(3000.0, 3000.0, 1999.5, 1499.5).unwrap();
    let mut d = Distortion::zero("opencv").unwrap();
    d.model_mut()
        .set_params(&[-0.265, -0.0467, 0.0018, -0.0003, 0.252]);
    let camera = Camera::new(k, Some(d), size);
    let und: Vec<f64> = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            UndistortPlan::new(&camera, false)
                .unwrap()
                .run(&img, &WarpOptions::default())
                .unwrap();
            t.elapsed().as_secs_f64()
        })
        .collect();
    println!(
        "{{\"calibrate_s\": {}, \"undistort_s\": {}}}",
        median(cal),
        median(und)
    );
}
