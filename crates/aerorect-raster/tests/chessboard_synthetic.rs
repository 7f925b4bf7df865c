//! Chessboard corners on boards rendered through a known lens at known poses (the testkit's
//! renderer: 4 x 4 sub-samples a pixel, blur, noise), against the true corners.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_raster::chessboard::{BoardMiss, ChessboardFinder};
use aerorect_testkit::chessboard::{BoardShot, Lens, render_board};

const LENS: Lens = Lens {
    fx: 620.0,
    fy: 620.0,
    cx: 319.5,
    cy: 239.5,
    k1: -0.2,
    k2: 0.05,
};

fn shot(rvec: [f64; 3], t: [f64; 3], noise: f64, seed: u64) -> BoardShot {
    BoardShot {
        cols: 9,
        rows: 6,
        square_m: 0.03,
        rvec,
        t,
        blur_px: 0.8,
        noise,
        seed,
    }
}

/// Four poses (frontal, tilted about each axis, turned in the image), noise 2 gray levels.
fn poses() -> Vec<([f64; 3], [f64; 3])> {
    vec![
        ([0.05, -0.05, 0.02], [-0.12, -0.08, 0.55]),
        ([0.5, 0.1, 0.3], [-0.10, -0.06, 0.55]),
        ([-0.2, 0.55, -0.4], [-0.14, -0.04, 0.6]),
        ([0.3, -0.3, 2.6], [0.12, 0.02, 0.6]),
    ]
}

#[test]
fn corners_are_within_five_hundredths_of_a_pixel_of_the_truth() {
    let size = ImageSize::new(640, 480);
    let finder = ChessboardFinder::new(9, 6).unwrap();
    let mut errors = Vec::new();
    for (k, (rvec, t)) in poses().into_iter().enumerate() {
        let (img, truth) = render_board(size, &LENS, &shot(rvec, t, 2.0, k as u64));
        let found = finder
            .find(&img)
            .unwrap_or_else(|e| panic!("pose {k}: {e}"));
        let d: Vec<f64> = found
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]))
            .collect();
        let max = d.iter().copied().fold(0.0, f64::max);
        // Numbered as the truth is: a wrong order would be off by a square or more.
        assert!(max < 0.2, "pose {k}: largest error {max} px");
        errors.extend(d);
    }
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    eprintln!(
        "mean corner error {mean:.4} px over {} corners",
        errors.len()
    );
    assert!(mean < 0.05, "mean corner error {mean} px");
}

#[test]
fn a_board_cut_by_the_image_edge_is_refused_as_partial() {
    let (img, _) = render_board(
        ImageSize::new(640, 480),
        &LENS,
        &shot([0.05, -0.05, 0.02], [0.12, -0.08, 0.55], 2.0, 9),
    );
    let miss = ChessboardFinder::new(9, 6).unwrap().find(&img).unwrap_err();
    assert!(matches!(miss, BoardMiss::Partial { .. }), "{miss}");
}

#[test]
fn a_larger_board_than_asked_for_is_refused_not_renumbered() {
    let mut s = shot([0.05, -0.05, 0.02], [-0.14, -0.1, 0.6], 2.0, 3);
    (s.cols, s.rows) = (10, 7);
    let (img, _) = render_board(ImageSize::new(640, 480), &LENS, &s);
    assert!(ChessboardFinder::new(10, 7).unwrap().find(&img).is_ok());
    let miss = ChessboardFinder::new(9, 6).unwrap().find(&img).unwrap_err();
    assert!(matches!(miss, BoardMiss::Larger { .. }), "{miss}");
}
