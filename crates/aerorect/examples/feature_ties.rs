//! For bench/features_vs_opencv.py: SIFT ties of frame pairs, one JSON line per pair.
//!
//! `feature_ties [--double-first-octave] LONG_SIDE_PX A B [A B ...]`; a path prefixed `rot180:`
//! is turned half a turn after decoding (a strip flown the other way). With
//! `--double-first-octave` the reduced frame is upsampled 2x before the first octave, as
//! OpenCV's SIFT always does (the flight pipeline does not). Prints keypoints and seconds per frame
//! (reduction + SIFT, decoding excluded), matches, and inliers under a homography and a
//! fundamental matrix (RANSAC threshold 1 px of the reduced frame).

use aerorect::features::{TieOptions, Verification, match_frames, raster_features};
use aerorect_raster::AnyRaster;
use std::path::Path;

fn turned(r: AnyRaster) -> AnyRaster {
    let flip = |p: &[u8]| p.iter().rev().copied().collect::<Vec<u8>>();
    match r {
        AnyRaster::U8(r) => {
            let planes = r.planes().iter().map(|p| flip(p)).collect();
            AnyRaster::U8(
                aerorect_raster::Raster::from_planes(r.size(), planes).expect("same size"),
            )
        }
        other => other,
    }
}

fn load(arg: &str, opts: &TieOptions) -> aerorect::features::FrameFeatures {
    let (rot, path) = match arg.strip_prefix("rot180:") {
        Some(p) => (true, p),
        None => (false, arg),
    };
    let image = aerorect_io::read_image(Path::new(path)).expect("decode");
    let image = if rot { turned(image) } else { image };
    raster_features(Path::new(path), &image, opts).expect("features")
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let double = args.first().is_some_and(|a| a == "--double-first-octave");
    if double {
        args.remove(0);
    }
    let long: usize = args[0].parse().expect("LONG_SIDE_PX");
    let mut opts = TieOptions {
        long_side_px: long,
        ..TieOptions::default()
    };
    opts.features.double_first_octave = double;
    for pair in args[1..].chunks_exact(2) {
        let (a, b) = (load(&pair[0], &opts), load(&pair[1], &opts));
        opts.verification = Verification::Homography;
        let h = match_frames(&a, &b, (0, 1), &opts).expect("match");
        opts.verification = Verification::Fundamental;
        let f = match_frames(&a, &b, (0, 1), &opts).expect("match");
        println!(
            "{{\"a\": \"{}\", \"b\": \"{}\", \"factor\": {}, \"keypoints\": [{}, {}], \"seconds\": [{:.4}, {:.4}], \"matches\": {}, \"inliers_h\": {}, \"inliers_f\": {}}}",
            pair[0],
            pair[1],
            a.factor,
            a.features.len(),
            b.features.len(),
            a.seconds,
            b.seconds,
            h.inliers.len(),
            h.inlier_count(),
            f.inlier_count()
        );
    }
}
