//! Warping from kept reduced levels (`ReducedLevels`, `warp_levels`) against the warp of the
//! image itself (`warp`, which builds the same levels afresh): the same pixels bit for bit, and
//! `None` wherever that warp would read level 0.

#![allow(clippy::unwrap_used)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{
    Interp, PixelMap, Raster, ReducedLevels, Sample, WarpOptions, warp, warp_levels,
};

/// A textured test image with noise, values 0..255, `bands` planes.
fn noise<T: Sample>(size: ImageSize, bands: usize, seed: u64) -> Raster<T> {
    aerorect_testkit::textured_scene(size, bands, 255.0, seed)
}

fn homography(m: [f64; 9]) -> Homography {
    Homography::new(Mat3::from_row_slice(&m)).unwrap()
}

/// Maps that read levels 1 and deeper only: plain scales (one a power of two), a rotation, a
/// perspective from about 2.5 to 5, and one with a horizon (tiles past it have no source).
fn coarse_maps() -> Vec<(&'static str, Homography)> {
    vec![
        (
            "scale 2",
            homography([2.0, 0.0, 0.5, 0.0, 2.0, 0.5, 0.0, 0.0, 1.0]),
        ),
        (
            "scale 3.7",
            homography([3.7, 0.0, 1.0, 0.0, 3.7, -2.0, 0.0, 0.0, 1.0]),
        ),
        (
            "rotated 9",
            homography([6.4, -6.4, 150.0, 6.4, 6.4, -20.0, 0.0, 0.0, 1.0]),
        ),
        (
            "perspective",
            homography([2.5, 0.3, 3.0, 0.1, 2.5, 2.0, 1e-4, -2e-3, 1.0]),
        ),
        (
            "horizon",
            homography([2.5, 0.0, 0.0, 0.0, 2.5, 0.0, 0.0, -0.006, 1.0]),
        ),
    ]
}

/// Samples whose bits differ between `a` and `b` (which must have the same size and bands).
fn differing<T: Sample>(a: &Raster<T>, b: &Raster<T>) -> usize {
    assert_eq!((a.size(), a.bands()), (b.size(), b.bands()));
    let samples = |r: &Raster<T>| -> Vec<u32> {
        let planes = r.planes().iter();
        planes
            .flat_map(|p| p.iter().map(|v| v.to_f32().to_bits()))
            .collect()
    };
    let (sa, sb) = (samples(a), samples(b));
    sa.iter().zip(&sb).filter(|(x, y)| x != y).count()
}

#[test]
fn warping_from_kept_levels_is_the_warp_bit_for_bit() {
    // Odd sizes: the last odd row and column of every level.
    let size0 = ImageSize::new(301, 203);
    // Tiles past the horizon (rows 192 on) are planned at level 0, with no source.
    let dst = ImageSize::new(150, 260);
    let rgb: Raster<u8> = noise(size0, 3, 7);
    let gray: Raster<f32> = noise(size0, 1, 11);
    // The gray image's levels from its rows, as a caller without it whole makes them.
    let from_rows = ReducedLevels::from_rows(size0, |r, out: &mut [f32]| {
        out.copy_from_slice(&gray.plane(0)[r * size0.width..(r + 1) * size0.width]);
    })
    .unwrap();
    let (rgb_levels, gray_levels) = (
        ReducedLevels::of(&rgb).unwrap(),
        ReducedLevels::of(&gray).unwrap(),
    );
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        let with_alpha = WarpOptions {
            interp,
            nodata: 7.0,
            alpha: true,
            prefilter: true,
            ..WarpOptions::default()
        };
        let nan = WarpOptions {
            nodata: f64::NAN,
            alpha: false,
            ..with_alpha
        };
        for (name, map) in coarse_maps() {
            let want = warp(&rgb, &map, dst, &with_alpha).unwrap();
            let got = warp_levels(&rgb_levels, &map, dst, &with_alpha).unwrap();
            assert!(got.is_some(), "{name} {interp:?}: reads level 0");
            assert_eq!(differing(&got.unwrap(), &want), 0, "{name} {interp:?} rgb");
            let want = warp(&gray, &map, dst, &nan).unwrap();
            for levels in [&gray_levels, &from_rows] {
                let got = warp_levels(levels, &map, dst, &nan).unwrap().unwrap();
                assert_eq!(differing(&got, &want), 0, "{name} {interp:?} gray");
            }
            if name == "horizon" {
                // Past the horizon (row > 166) there is no source: nodata there.
                let got = warp_levels(&gray_levels, &map, dst, &nan).unwrap().unwrap();
                assert!(got.plane(0)[180 * dst.width..].iter().all(|v| v.is_nan()));
            }
        }
    }
}

/// Scales 2 and 3 from column 64 on (tiles at level 1); left of it, sources only in a small disc
/// away from the centre and corners of the first tile (planned at level 0).
struct Disc;

impl PixelMap for Disc {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        (col >= 64.0 || (col - 16.0).hypot(row - 40.0) < 6.0).then_some([2.0 * col, 3.0 * row])
    }
}

#[test]
fn a_warp_that_reads_level_zero_is_none() {
    let size0 = ImageSize::new(200, 160);
    let gray: Raster<f32> = noise(size0, 1, 3);
    let levels = ReducedLevels::of(&gray).unwrap();
    let opts = WarpOptions {
        interp: Interp::Bilinear,
        nodata: f64::NAN,
        prefilter: true,
        ..WarpOptions::default()
    };
    let dst = ImageSize::new(100, 80);
    let scale = |s: f64| homography([s, 0.0, 0.0, 0.0, s, 0.0, 0.0, 0.0, 1.0]);
    // A scale under 2 everywhere, or in part of the output (a perspective from 1.2 to 5).
    assert!(
        warp_levels(&levels, &scale(1.5), dst, &opts)
            .unwrap()
            .is_none()
    );
    let part = homography([1.2, 0.0, 0.0, 0.0, 1.2, 0.0, 0.0, 0.01, 1.0]);
    assert!(warp_levels(&levels, &part, dst, &opts).unwrap().is_none());
    // No prefilter, or a kernel without one.
    for o in [
        WarpOptions {
            prefilter: false,
            ..opts
        },
        WarpOptions {
            interp: Interp::Nearest,
            ..opts
        },
    ] {
        assert!(
            warp_levels(&levels, &scale(4.0), dst, &o)
                .unwrap()
                .is_none()
        );
    }
    // A tile planned at level 0 (no source at its centre or corners) whose pixels have sources:
    // the warp reads level 0 there.
    let plain = warp(&gray, &Disc, dst, &opts).unwrap();
    assert!(!plain.get(0, 16, 40).unwrap().is_nan());
    assert!(warp_levels(&levels, &Disc, dst, &opts).unwrap().is_none());
    // The same scale 4 with the prefilter reads level 2 only.
    assert!(
        warp_levels(&levels, &scale(4.0), dst, &opts)
            .unwrap()
            .is_some()
    );
}

/// The bytes levels would hold, told without making them, are the bytes made levels hold:
/// odd and even sides, one side of a single pixel, and several bands.
#[test]
fn levels_byte_count_is_that_of_the_levels_made() {
    for (w, h, bands) in [
        (8, 4, 1),
        (13, 7, 1),
        (1, 1, 1),
        (2, 300, 3),
        (461, 346, 1),
        (64, 33, 4),
    ] {
        let size = ImageSize::new(w, h);
        let made = ReducedLevels::of(&noise::<f32>(size, bands, 3)).unwrap();
        assert_eq!(
            ReducedLevels::<f32>::byte_len_for(size, bands),
            made.byte_len(),
            "{w} x {h} x {bands}"
        );
        let made = ReducedLevels::of(&noise::<u8>(size, bands, 3)).unwrap();
        assert_eq!(
            ReducedLevels::<u8>::byte_len_for(size, bands),
            made.byte_len()
        );
    }
}
