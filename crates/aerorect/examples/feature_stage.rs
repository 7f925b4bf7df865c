//! Where a flight's feature stage spends its CPU: SIFT per frame, descriptor matching and
//! fundamental-matrix RANSAC per candidate pair, each stage's process CPU seconds (user +
//! system, so a busy machine inflates them less than wall time), and what the pairs give.
//!
//! `feature_stage POSES_CSV MAX_FEATURES MIN_INLIERS FRAME...`
//!
//! Candidate pairs come from the frames' positions in POSES_CSV (`filename,x,y,...`; eight
//! nearest neighbours and Delaunay, as the flight's). MIN_INLIERS is RANSAC's
//! `min_inliers` (0: off). Prints one JSON line.

use aerorect::features::{TieOptions, raster_features};
use aerorect_raster::features::DESCRIPTOR_LEN;
use aerorect_solve::fundamental::ransac_fundamental;
use aerorect_solve::matching::match_float;
use aerorect_solve::pairs::candidate_pairs;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// This process's user + system CPU seconds (Linux: /proc/self/stat, 100 ticks a second).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat");
    let after = &stat[stat.rfind(')').expect("comm") + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>().expect("utime") + f[12].parse::<f64>().expect("stime");
    ticks / 100.0
}

fn centres(csv: &Path) -> HashMap<String, [f64; 2]> {
    let text = std::fs::read_to_string(csv).expect("poses");
    text.lines()
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Some((f[0].to_string(), [f[1].parse().ok()?, f[2].parse().ok()?]))
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let all = centres(Path::new(&args[0]));
    let mut opts = TieOptions::default();
    opts.features.max_features = args[1].parse().expect("MAX_FEATURES");
    opts.ransac.min_inliers = args[2].parse().expect("MIN_INLIERS");
    let min_matches = 20;
    let paths: Vec<PathBuf> = args[3..].iter().map(PathBuf::from).collect();
    let xy: Vec<[f64; 2]> = paths
        .iter()
        .map(|p| all[p.file_name().and_then(|n| n.to_str()).expect("name")])
        .collect();
    let images: Vec<_> = paths
        .par_iter()
        .map(|p| aerorect_io::read_image(p).expect("decode"))
        .collect();
    let t = cpu_seconds();
    let frames: Vec<_> = paths
        .par_iter()
        .zip(&images)
        .map(|(p, im)| raster_features(p, im, &opts).expect("features"))
        .collect();
    let sift_s = cpu_seconds() - t;
    let pairs = candidate_pairs(&xy, None, &opts.pairs).expect("pairs");
    let t = cpu_seconds();
    let matches: Vec<_> = pairs
        .par_iter()
        .map(|&(i, j)| {
            let (a, b) = (&frames[i].features, &frames[j].features);
            let m = match_float(
                &a.descriptors,
                &b.descriptors,
                DESCRIPTOR_LEN,
                &opts.matching,
            )
            .expect("match");
            let pa: Vec<[f64; 2]> = m.iter().map(|m| a.positions()[m.query]).collect();
            let pb: Vec<[f64; 2]> = m.iter().map(|m| b.positions()[m.train]).collect();
            (pa, pb)
        })
        .collect();
    let match_s = cpu_seconds() - t;
    let t = cpu_seconds();
    let inliers: Vec<usize> = matches
        .par_iter()
        .map(|(pa, pb)| {
            if pa.len() < min_matches {
                return 0;
            }
            ransac_fundamental(pa, pb, &opts.ransac).map_or(0, |f| f.inlier_count())
        })
        .collect();
    let ransac_s = cpu_seconds() - t;
    let tied: Vec<&usize> = inliers.iter().filter(|&&n| n >= min_matches).collect();
    let keypoints: usize = frames.iter().map(|f| f.features.len()).sum();
    println!(
        "{{\"frames\": {}, \"keypoints_per_frame\": {:.0}, \"pairs\": {}, \"tied_pairs\": {}, \"inliers_of_tied\": {}, \"sift_cpu_s\": {sift_s:.2}, \"match_cpu_s\": {match_s:.2}, \"ransac_cpu_s\": {ransac_s:.2}}}",
        frames.len(),
        keypoints as f64 / frames.len() as f64,
        pairs.len(),
        tied.len(),
        tied.iter().copied().sum::<usize>(),
    );
}
