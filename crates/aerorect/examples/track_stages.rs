//! Where `track`'s time goes, for `bench/track_vs_kernel.sh`: the binarised JTC on the same
//! frames in four settings, interleaved round by round so that a loaded machine slows all
//! alike.
//!
//! usage: track_stages ROUNDS FRAME.tif... (threads from RAYON_NUM_THREADS, default all cores)
//!
//! - `kernel-in-pool`: the first pair over and over inside the pool (criterion's `jtc-2t`);
//! - `kernel`: the same pair called from outside the pool, as `track` calls it;
//! - `stream`: each decoded frame against the previous one (the frames held in memory);
//! - `decode`: reading and converting one frame to gray (what `track` does between pairs).
//!
//! Prints one line per setting: the minimum and median milliseconds per call.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::core::ImageSize;
use aerorect::motion::{Method, gray};
use aerorect::raster::shift::ShiftEstimator;
use std::path::PathBuf;
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn summary(name: &str, mut v: Vec<f64>) {
    v.sort_by(f64::total_cmp);
    println!(
        "{name:<16} min {:>8.3} ms  median {:>8.3} ms  ({} calls)",
        v[0],
        v[v.len() / 2],
        v.len()
    );
}

fn main() {
    let mut args = std::env::args().skip(1);
    let rounds: usize = args.next().expect("ROUNDS").parse().expect("ROUNDS");
    let paths: Vec<PathBuf> = args.map(PathBuf::from).collect();
    assert!(paths.len() >= 2, "two frames at least");
    let read = |p: &PathBuf| gray(&aerorect::io::read_image(p).unwrap()).unwrap();
    let frames: Vec<Vec<f32>> = paths.iter().map(|p| read(p).plane(0).to_vec()).collect();
    let size: ImageSize = read(&paths[0]).size();
    let method = Method::parse("jtc").unwrap();
    let mut est: Box<dyn ShiftEstimator + Send> = method.plan(size).unwrap();
    let pool = rayon::ThreadPoolBuilder::new().build().unwrap();
    let (mut in_pool, mut outside, mut stream, mut decode) = (vec![], vec![], vec![], vec![]);
    let (r, c) = (&frames[0], &frames[1]);
    for _ in 0..rounds {
        for _ in 1..frames.len() {
            let t = Instant::now();
            pool.install(|| est.estimate(r, c).unwrap());
            in_pool.push(ms(t));
        }
        for _ in 1..frames.len() {
            let t = Instant::now();
            est.estimate(r, c).unwrap();
            outside.push(ms(t));
        }
        for pair in frames.windows(2) {
            let t = Instant::now();
            est.estimate(&pair[0], &pair[1]).unwrap();
            stream.push(ms(t));
        }
        for p in &paths {
            let t = Instant::now();
            std::hint::black_box(read(p));
            decode.push(ms(t));
        }
    }
    println!(
        "{} frames of {} x {}, {} threads, {rounds} rounds",
        frames.len(),
        size.width,
        size.height,
        rayon::current_num_threads()
    );
    summary("kernel-in-pool", in_pool);
    summary("kernel", outside);
    summary("stream", stream);
    summary("decode", decode);
}
