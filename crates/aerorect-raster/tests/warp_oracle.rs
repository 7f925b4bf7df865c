//! The fast warp against the slow oracle of aerorect-testkit, and exact closed-form cases.
#![allow(clippy::unwrap_used, clippy::needless_range_loop)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{Coordinates, Interp, Raster, Sample, WarpOptions, warp};
use aerorect_testkit::{oracle_warp, textured_scene};

const INTERPS: [Interp; 3] = [Interp::Nearest, Interp::Bilinear, Interp::Bicubic];
/// Exact f64 positions, and the fast ones (f32 offsets within 5e-4 px of them).
const COORDINATES: [Coordinates; 2] = [Coordinates::Exact, Coordinates::Fast];

/// A homography with rotation, shear and perspective that leaves part of the output uncovered.
fn test_homography() -> Homography {
    Homography::new(Mat3::new(
        0.93, 0.21, -12.3, -0.17, 1.04, 9.7, 4.1e-4, -2.3e-4, 1.0,
    ))
    .unwrap()
}

fn compare<T: Sample>(src: &Raster<T>, interp: Interp, tol: f64) {
    for coordinates in COORDINATES {
        compare_with(src, interp, coordinates, tol);
    }
}

fn compare_with<T: Sample>(src: &Raster<T>, interp: Interp, coordinates: Coordinates, tol: f64) {
    let h = test_homography();
    let size = ImageSize::new(83, 71);
    let opts = WarpOptions {
        interp,
        nodata: 7.0,
        alpha: true,
        prefilter: true,
        coordinates,
    };
    let fast = warp(src, &h, size, &opts).unwrap();
    let slow = oracle_warp(src, &h, size, interp);
    let (mut valid, mut invalid) = (0, 0);
    for b in 0..src.bands() {
        for i in 0..size.pixels() {
            let f = fast.plane(b)[i].to_f32() as f64;
            let alpha = fast.plane(src.bands())[i];
            match slow[b][i] {
                Some(v) => {
                    valid += 1;
                    // integers: the oracle's exact value rounds to within 1 of ours
                    assert!(
                        (f - v).abs() <= tol,
                        "{interp:?} {coordinates:?} {} band {b} px {i}: {f} vs {v}",
                        T::NAME
                    );
                    assert_eq!(alpha, T::OPAQUE);
                }
                None => {
                    invalid += 1;
                    assert_eq!(f, 7.0);
                    assert_eq!(alpha, T::default());
                }
            }
        }
    }
    assert!(
        valid > 1000 && invalid > 100,
        "the case covers both: {valid} valid, {invalid} invalid"
    );
}

#[test]
fn u8_gray_rgb_rgba_match_the_oracle() {
    for bands in [1, 3, 4] {
        let src: Raster<u8> = textured_scene(ImageSize::new(64, 57), bands, 255.0, bands as u64);
        for interp in INTERPS {
            compare(&src, interp, 0.5 + 1e-3);
        }
    }
}

#[test]
fn u16_matches_the_oracle() {
    let src: Raster<u16> = textured_scene(ImageSize::new(64, 57), 1, 65535.0, 9);
    for interp in INTERPS {
        compare(&src, interp, 0.5 + 65535.0 * 2e-6);
    }
}

#[test]
fn f32_matches_the_oracle() {
    let src: Raster<f32> = textured_scene(ImageSize::new(64, 57), 3, 1000.0, 11);
    for interp in INTERPS {
        compare(&src, interp, 1e-3);
    }
}

#[test]
fn identity_and_integer_shifts_are_exact() {
    let src: Raster<u16> = textured_scene(ImageSize::new(40, 30), 2, 65535.0, 3);
    for interp in INTERPS {
        let out = warp(
            &src,
            &Homography::identity(),
            src.size(),
            &WarpOptions {
                interp,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(out, src, "{interp:?}");
        let out = warp(
            &src,
            &Homography::translation(3.0, -2.0),
            src.size(),
            &WarpOptions {
                interp,
                ..Default::default()
            },
        )
        .unwrap();
        for b in 0..2 {
            for y in 2..30 {
                for x in 0..37 {
                    assert_eq!(out.get(b, x, y), src.get(b, x + 3, y - 2), "{interp:?}");
                }
            }
        }
    }
}

#[test]
fn half_pixel_bilinear_is_the_mean() {
    let src =
        Raster::from_planes(ImageSize::new(2, 2), vec![vec![10.0f32, 20.0, 30.0, 41.0]]).unwrap();
    let out = warp(
        &src,
        &Homography::translation(0.5, 0.5),
        ImageSize::new(1, 1),
        &WarpOptions::default(),
    )
    .unwrap();
    assert_eq!(out.plane(0)[0], 25.25);
}

#[test]
fn footprint_edges_follow_the_convention() {
    // Source 4 x 1: x = -0.5 is inside, x = 3.5 is outside.
    let src = Raster::from_planes(ImageSize::new(4, 1), vec![vec![1u8, 2, 3, 4]]).unwrap();
    let opts = WarpOptions {
        interp: Interp::Nearest,
        nodata: 99.0,
        alpha: false,
        prefilter: true,
        ..WarpOptions::default()
    };
    let out = warp(
        &src,
        &Homography::translation(-0.5, 0.0),
        ImageSize::new(5, 1),
        &opts,
    )
    .unwrap();
    assert_eq!(out.plane(0), &[1, 2, 3, 4, 99]);
}

#[test]
fn one_and_two_threads_agree() {
    let src: Raster<u8> = textured_scene(ImageSize::new(300, 200), 3, 255.0, 5);
    let h = test_homography();
    let opts = WarpOptions {
        interp: Interp::Bicubic,
        ..Default::default()
    };
    let run = |n| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap();
        pool.install(|| warp(&src, &h, ImageSize::new(310, 190), &opts).unwrap())
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn nodata_must_fit_the_sample_type() {
    let src: Raster<u8> = textured_scene(ImageSize::new(8, 8), 1, 255.0, 1);
    let opts = WarpOptions {
        nodata: 300.0,
        ..Default::default()
    };
    assert!(warp(&src, &Homography::identity(), src.size(), &opts).is_err());
}

/// The fast build of `src` against the portable one: the same arithmetic, so equal to the bit.
fn builds_agree<T: Sample>(src: &Raster<T>, h: &Homography, size: ImageSize, opts: &WarpOptions) {
    let bands = opts.output_bands(src.bands());
    let mut a = Raster::new(size, bands).unwrap();
    let mut b = Raster::new(size, bands).unwrap();
    let mut c = Raster::new(size, bands).unwrap();
    // The best build (AVX-512 steps where the CPU has them), AVX2 alone, portable.
    aerorect_raster::warp_into(src, h, opts, &mut a).unwrap();
    aerorect_raster::warp_into_avx2(src, h, opts, &mut c).unwrap();
    aerorect_raster::warp_into_portable(src, h, opts, &mut b).unwrap();
    let what = (opts.interp, opts.coordinates, T::NAME, src.bands());
    assert_eq!(a, b, "best and portable: {what:?}");
    assert_eq!(c, b, "AVX2 and portable: {what:?}");
}

#[test]
fn simd_and_portable_builds_agree_exactly() {
    // Strong perspective (rows from nearly horizontal to steep) and a mild one (where u8
    // bilinear reads byte windows of source rows instead of gathers). The 700 x 90 output runs
    // off the 640 x 120 source; under the mild map the 600 x 70 one lies inside it, so whole
    // blocks take the kernels' all-inside paths (and 600 leaves a half step of sixteen).
    let mild = Homography::new(Mat3::new(
        0.95, 0.08, 20.0, -0.06, 0.9, 40.0, 5e-5, 8e-5, 1.0,
    ))
    .unwrap();
    // Moved 30 px right, the inside blocks reach the source's last columns (windows that
    // would run past a row's end start earlier).
    let right = Homography::new(Mat3::new(
        0.95, 0.08, 50.0, -0.06, 0.9, 40.0, 5e-5, 8e-5, 1.0,
    ))
    .unwrap();
    // Rotated by about 30 degrees and inside: sixteen pixels cross five source rows, so the
    // all-inside steps read sample by sample, not from row windows.
    let rotated = Homography::new(Mat3::new(
        0.6, -0.35, 150.0, 0.35, 0.6, 5.0, 1e-5, 1e-5, 1.0,
    ))
    .unwrap();
    // Nearly a shift whose last output row reads the source's last row up to its last column:
    // the windows there start early, and no read may pass the plane's end.
    let corner = Homography::new(Mat3::new(1.0, 0.0, 40.3, 0.0, 1.0, 50.2, 0.0, 0.0, 1.0)).unwrap();
    // Stretched 2.07-fold along rows (no prefilter): sixteen pixels' taps span 32 or 33
    // columns, just past what one window of 32 holds.
    let stretched =
        Homography::new(Mat3::new(2.07, 0.0, 3.3, 0.02, 0.5, 20.7, 0.0, 0.0, 1.0)).unwrap();
    // Rows descending 0.1 px per pixel, inside: sixteen pixels span three source rows, which
    // the sixteen-pixel bicubic windows take (a third of their rows from two rows lower).
    let sheared =
        Homography::new(Mat3::new(0.95, 0.08, 20.0, 0.1, 0.9, 5.0, 1e-5, 1e-5, 1.0)).unwrap();
    // Steeper, 0.17 px per pixel: sixteen pixels' nearest samples span four source rows, which
    // the wide u8 nearest layout (several bands) takes.
    let steep =
        Homography::new(Mat3::new(0.95, 0.08, 20.0, 0.17, 0.9, 5.0, 1e-5, 1e-5, 1.0)).unwrap();
    let cases = [
        (test_homography(), ImageSize::new(700, 90), true),
        (sheared, ImageSize::new(500, 60), true),
        (steep, ImageSize::new(450, 30), true),
        (mild, ImageSize::new(700, 90), true),
        (mild, ImageSize::new(600, 70), true),
        (right, ImageSize::new(640, 70), true),
        (rotated, ImageSize::new(200, 40), true),
        (corner, ImageSize::new(600, 70), true),
        (stretched, ImageSize::new(300, 60), false),
    ];
    for ((h, size, prefilter), coordinates) in cases
        .into_iter()
        .flat_map(|hs| COORDINATES.map(|c| (hs, c)))
    {
        for interp in INTERPS {
            let opts = WarpOptions {
                interp,
                nodata: 3.0,
                alpha: true,
                prefilter,
                coordinates,
            };
            for bands in [1, 3, 4] {
                let src8: Raster<u8> =
                    textured_scene(ImageSize::new(640, 120), bands, 255.0, 21 + bands as u64);
                builds_agree(&src8, &h, size, &opts);
            }
            let src16: Raster<u16> = textured_scene(ImageSize::new(640, 120), 1, 65535.0, 23);
            builds_agree(&src16, &h, size, &opts);
            let srcf: Raster<f32> = textured_scene(ImageSize::new(640, 120), 2, 1.0, 22);
            builds_agree(&srcf, &h, size, &opts);
        }
    }
}

#[test]
fn bicubic_overshoot_is_saturated_alike_in_every_build() {
    // Hard edges between 0 and full scale: bicubic overshoots both ends, so the integer
    // stores' saturation (below 0, above 255 or 65535) decides many samples, in every build.
    let size = ImageSize::new(640, 120);
    let hard = |hi: f64| -> Vec<f64> {
        (0..size.pixels())
            .map(|i| {
                let (x, y) = (i % 640, i / 640);
                if (x / 3 + y / 5) % 2 == 0 { 0.0 } else { hi }
            })
            .collect()
    };
    let src8 =
        Raster::from_planes(size, vec![hard(255.0).iter().map(|&v| v as u8).collect()]).unwrap();
    let src16 = Raster::from_planes(
        size,
        vec![hard(65535.0).iter().map(|&v| v as u16).collect()],
    )
    .unwrap();
    let srcf =
        Raster::from_planes(size, vec![hard(1.0).iter().map(|&v| v as f32).collect()]).unwrap();
    let mild = Homography::new(Mat3::new(
        0.95, 0.08, 20.0, -0.06, 0.9, 40.0, 5e-5, 8e-5, 1.0,
    ))
    .unwrap();
    for coordinates in COORDINATES {
        let opts = WarpOptions {
            interp: Interp::Bicubic,
            nodata: 3.0,
            alpha: false,
            prefilter: true,
            coordinates,
        };
        builds_agree(&src8, &mild, ImageSize::new(600, 70), &opts);
        builds_agree(&src16, &mild, ImageSize::new(600, 70), &opts);
        builds_agree(&srcf, &mild, ImageSize::new(600, 70), &opts);
        // The case does overshoot: f32 values beyond [0, 1].
        let out = warp(&srcf, &mild, ImageSize::new(600, 70), &opts).unwrap();
        let (lo, hi) = out
            .plane(0)
            .iter()
            .fold((0f32, 1f32), |(a, b), &v| (a.min(v), b.max(v)));
        assert!(lo < -0.05 && hi > 1.05, "{lo} {hi}");
    }
}

#[test]
fn runs_ending_on_the_last_column_read_no_further() {
    // Output column 607, the end of a run of whole sixteens, lands exactly on the source's last
    // column, 639 (rows a quarter pixel off, so that no integer-shift shortcut applies).
    // Bilinear's upper-left neighbour there is capped at 638 with fraction 1, so column 0 of
    // the next row, NaN here, is never read; a kernel taking 639 with fraction 0 would read it
    // and give 0 x NaN.
    let size = ImageSize::new(640, 120);
    let mut src: Raster<f32> = textured_scene(size, 1, 1.0, 41);
    for y in 0..120 {
        src.plane_mut(0)[y * 640] = f32::NAN;
    }
    let h = Homography::new(Mat3::new(1.0, 0.0, 32.0, 0.0, 1.0, 3.25, 0.0, 0.0, 1.0)).unwrap();
    for coordinates in COORDINATES {
        let opts = WarpOptions {
            interp: Interp::Bilinear,
            nodata: 3.0,
            alpha: false,
            prefilter: true,
            coordinates,
        };
        builds_agree(&src, &h, ImageSize::new(608, 100), &opts);
        let out = warp(&src, &h, ImageSize::new(608, 100), &opts).unwrap();
        assert!(
            out.plane(0).iter().all(|v| v.is_finite()),
            "{coordinates:?}"
        );
    }
}

#[test]
fn tiny_sources_match_the_oracle() {
    // One-pixel, one-row and one-column sources take the portable path; 2 x 2 the AVX2 one.
    let h = Homography::new(Mat3::new(
        0.37, 0.05, -0.4, -0.03, 0.41, -0.3, 1e-3, 2e-3, 1.0,
    ))
    .unwrap();
    for (w, hgt) in [(1, 1), (5, 1), (1, 5), (2, 2), (3, 2)] {
        let src: Raster<u8> = textured_scene(ImageSize::new(w, hgt), 2, 255.0, 30);
        for interp in INTERPS {
            let out = warp(
                &src,
                &h,
                ImageSize::new(19, 13),
                &WarpOptions {
                    interp,
                    nodata: 1.0,
                    alpha: false,
                    prefilter: true,
                    ..WarpOptions::default()
                },
            )
            .unwrap();
            let slow = oracle_warp(&src, &h, ImageSize::new(19, 13), interp);
            for b in 0..2 {
                for i in 0..19 * 13 {
                    let f = out.plane(b)[i] as f64;
                    match slow[b][i] {
                        Some(v) => {
                            assert!((f - v).abs() <= 0.501, "{w}x{hgt} {interp:?}: {f} vs {v}")
                        }
                        None => assert_eq!(f, 1.0),
                    }
                }
            }
        }
    }
}

#[test]
fn fast_coordinates_change_u8_outputs_by_at_most_one_level() {
    // Positions within 5e-4 px move a bilinear value by at most 255 x 5e-4 < 0.13 before
    // rounding, so a sample can only round the other way, by one level, and rarely.
    let h = Homography::new(Mat3::new(
        0.95, 0.08, 20.0, -0.06, 0.9, 40.0, 5e-5, 8e-5, 1.0,
    ))
    .unwrap();
    let src: Raster<u8> = textured_scene(ImageSize::new(1024, 1024), 1, 255.0, 5);
    let size = ImageSize::new(1024, 1024);
    let run = |coordinates| {
        let opts = WarpOptions {
            coordinates,
            ..WarpOptions::default()
        };
        warp(&src, &h, size, &opts).unwrap()
    };
    let (exact, fast) = (run(Coordinates::Exact), run(Coordinates::Fast));
    let (mut differ, mut inside) = (0usize, 0usize);
    for (a, b) in exact.plane(0).iter().zip(fast.plane(0)) {
        assert!(a.abs_diff(*b) <= 1, "{a} vs {b}");
        differ += usize::from(a != b);
        inside += usize::from(*a != 0);
    }
    assert!(inside > 500_000, "{inside} pixels inside");
    assert!(differ * 1000 < inside, "{differ} of {inside} pixels differ");
}
