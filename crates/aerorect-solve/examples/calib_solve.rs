//! The calibration solve alone, timed, on saved control points (CSV `image,X,Y,Z,u,v`), for
//! bench/calib_vs_opencv.py: `cargo run --release -p aerorect-solve --example calib_solve --
//! data/calib/left_corners.csv 640x480 opencv 1e-6`. Reads a line from stdin per solve (so a
//! bench can interleave it with a peer's solves in one process each) and prints one line per
//! solve: `ms <solve ms> rms <px> iterations <n> fx .. fy .. cx .. cy .. <coefficient> <value> ..`.
//! With a fifth argument N it runs N solves without reading stdin.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;
use aerorect_solve::calib::{CalibrationOptions, Observation, calibrate};
use std::io::BufRead;

fn solve_line(obs: &[Observation], opts: &CalibrationOptions) -> String {
    let t = std::time::Instant::now();
    let r = calibrate(obs, opts).expect("a calibration");
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let mut line = format!(
        "ms {ms:.4} rms {:.6} iterations {} fx {:.6} fy {:.6} cx {:.6} cy {:.6}",
        r.rms_px, r.iterations, r.fx, r.fy, r.cx, r.cy
    );
    let m = r.distortion.model();
    for (n, v) in m.names().iter().zip(m.params()) {
        line += &format!(" {n} {v:.8}");
    }
    line
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_string());
    let obs = aerorect_testkit::read_observations(arg(0, "data/calib/left_corners.csv").as_ref());
    let (w, h) = arg(1, "640x480")
        .split_once('x')
        .map(|(w, h)| (w.parse().unwrap(), h.parse().unwrap()))
        .expect("WxH");
    let model = Distortion::zero(&arg(2, "opencv")).expect("a model name");
    let mut opts = CalibrationOptions::new(model, ImageSize::new(w, h));
    opts.stop_px = arg(3, "1e-6").parse().unwrap();
    match args.get(4).map(|n| n.parse::<usize>().unwrap()) {
        Some(n) => (0..n).for_each(|_| println!("{}", solve_line(&obs, &opts))),
        None => {
            for line in std::io::stdin().lock().lines() {
                if line.is_err() {
                    break;
                }
                println!("{}", solve_line(&obs, &opts));
            }
        }
    }
}
