//! Area-aware downsampling: `Interp::Average` and the automatic prefilter of bilinear/bicubic,
//! against closed forms (block means, constants, ramps), an analytic zone plate box-filtered at the
//! output resolution, and OpenCV's INTER_AREA (stored results, see data/downsample/README.md).

#![allow(clippy::unwrap_used)]

use aerorect_core::{Homography, ImageSize, Mat3};
use aerorect_raster::{Interp, PixelMap, Raster, WarpOptions, warp};
use aerorect_testkit::zone_plate::ZonePlate;

fn opts(interp: Interp, prefilter: bool) -> WarpOptions {
    WarpOptions {
        interp,
        nodata: 7.0,
        alpha: true,
        prefilter,
        ..WarpOptions::default()
    }
}

fn affine(a: f64, b: f64, c: f64, d: f64, e: f64, f: f64) -> Homography {
    Homography::new(Mat3::new(a, b, c, d, e, f, 0.0, 0.0, 1.0)).unwrap()
}

/// A deterministic pseudo-random u8 image (an LCG), `bands` planes.
fn noise_u8(size: ImageSize, bands: usize, seed: u64) -> Raster<u8> {
    let mut s = seed;
    let planes = (0..bands)
        .map(|_| {
            (0..size.pixels())
                .map(|_| {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (s >> 56) as u8
                })
                .collect()
        })
        .collect();
    Raster::from_planes(size, planes).unwrap()
}

/// Scale f on both axes, aligned grids: destination pixel i covers source pixels f i .. f i + f - 1,
/// its centre at f i + (f - 1) / 2. The result is the block mean, rounded half up (exact).
#[test]
fn integer_factors_give_the_exact_block_mean() {
    for f in [2usize, 4] {
        let src = noise_u8(ImageSize::new(64, 48), 3, f as u64);
        let o = 0.5 * (f as f64 - 1.0);
        let map = affine(f as f64, 0.0, o, 0.0, f as f64, o);
        let size = ImageSize::new(64 / f, 48 / f);
        let out = warp(&src, &map, size, &opts(Interp::Average, true)).unwrap();
        for b in 0..3 {
            for r in 0..size.height {
                for c in 0..size.width {
                    let mut sum = 0u32;
                    for j in 0..f {
                        for i in 0..f {
                            sum += src.get(b, f * c + i, f * r + j).unwrap() as u32;
                        }
                    }
                    let n = (f * f) as u32;
                    let want = ((2 * sum + n) / (2 * n)) as u8; // half up
                    assert_eq!(out.get(b, c, r).unwrap(), want, "f {f} band {b} ({c}, {r})");
                }
            }
        }
        assert!(out.plane(3).iter().all(|&a| a == 255), "alpha opaque");
    }
}

/// Under a perspective map a constant stays constant (weights are normalised) and a linear ramp
/// keeps its value at the footprint's centre (a symmetric box's mean of a linear function).
#[test]
fn constants_stay_constant_and_ramps_keep_their_mean() {
    let size = ImageSize::new(300, 200);
    let ramp: Vec<f32> = (0..size.pixels())
        .map(|i| 0.5 * (i % 300) as f32 + 0.25 * (i / 300) as f32 + 10.0)
        .collect();
    let src = Raster::from_planes(size, vec![vec![42.0f32; size.pixels()], ramp]).unwrap();
    let h = Homography::new(Mat3::new(2.6, 0.4, 3.0, -0.3, 3.1, 4.0, 1e-4, 6e-4, 1.0)).unwrap();
    let dst_size = ImageSize::new(90, 60);
    let out = warp(&src, &h, dst_size, &opts(Interp::Average, true)).unwrap();
    let mut checked = 0;
    for r in 0..dst_size.height {
        for c in 0..dst_size.width {
            let Some([x, y]) = h.source_of(c as f64, r as f64) else {
                continue;
            };
            let inside = (-0.5..299.5).contains(&x) && (-0.5..199.5).contains(&y);
            let alpha = out.get(2, c, r).unwrap();
            assert_eq!(alpha, if inside { 1.0 } else { 0.0 }, "({c}, {r})");
            if !inside {
                continue;
            }
            assert!(
                (out.get(0, c, r).unwrap() - 42.0).abs() < 1e-4,
                "constant ({c}, {r})"
            );
            // Away from the edges (the box is clipped there): the weights are the areas of the
            // piecewise-constant pixels under the box, whose mean of slope a differs from the
            // linear one by a ov (1 - ov) / 2 <= a / 8 at each partly covered end, over a box at
            // least 2 px wide (scale >= 2.5 here): <= 2 (0.5 + 0.25) / 8 / 2 ~ 0.094.
            if x > 8.0 && x < 291.0 && y > 8.0 && y < 191.0 {
                let want = 0.5 * x + 0.25 * y + 10.0;
                let got = out.get(1, c, r).unwrap() as f64;
                assert!(
                    (got - want).abs() < 0.094,
                    "ramp ({c}, {r}): {got} vs {want}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 2000, "{checked} interior pixels");
}

/// A map without a source (NaN, beyond the horizon) or outside the image gives nodata, alpha 0,
/// for average and for the prefiltered kernels.
#[test]
fn no_source_or_outside_gives_nodata() {
    struct Holes;
    impl PixelMap for Holes {
        fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
            match col as i64 % 3 {
                0 => None,
                1 => Some([f64::NAN, 4.0 * row]),
                _ => Some([4.0 * col + 500.0, 4.0 * row]),
            }
        }
    }
    let src = noise_u8(ImageSize::new(400, 400), 1, 9);
    for interp in [Interp::Average, Interp::Bilinear, Interp::Bicubic] {
        let out = warp(&src, &Holes, ImageSize::new(90, 90), &opts(interp, true)).unwrap();
        assert!(out.plane(0).iter().all(|&v| v == 7), "{}", interp.name());
        assert!(out.plane(1).iter().all(|&a| a == 0), "{}", interp.name());
    }
}

/// RMS of out - truth over the valid pixels whose local frequency (cycles per destination pixel)
/// is in `band`.
fn rms_in_band<M: PixelMap>(
    zp: &ZonePlate,
    map: &M,
    out: &Raster<f32>,
    truth: &[f64],
    band: (f64, f64),
) -> f64 {
    let w = out.width();
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, &t) in truth.iter().enumerate() {
        let (c, r) = (i % w, i / w);
        let [x, y] = map.source_of(c as f64, r as f64).unwrap();
        let scale = (map.source_of(c as f64 + 1.0, r as f64).unwrap()[0] - x).abs();
        let f = zp.frequency(x, y) * scale;
        if out.plane(1)[i] == 1.0 && f >= band.0 && f < band.1 {
            sum += (out.plane(0)[i] as f64 - t).powi(2);
            n += 1;
        }
    }
    assert!(n > 1000, "{n} pixels in band {band:?}");
    (sum / n as f64).sqrt()
}

/// A 1024^2 zone plate (up to 0.45 cycles/px) seen 3.9x smaller through a mild homography: its
/// outer rings reach 1.75 cycles per destination pixel, far past the output's Nyquist (0.5).
/// Plain bilinear point-samples them (aliasing: rings that are not there); average and the
/// prefiltered kernels stay near the analytic plate box-filtered at the output resolution.
#[test]
fn zone_plate_aliasing_is_gone_with_average_and_prefilter() {
    let zp = ZonePlate::new(1024, 0.45);
    let src: Raster<f32> = zp.raster(1.0);
    let h = Homography::new(Mat3::new(3.9, 0.1, 2.0, 0.05, 3.9, 2.0, 1e-5, 2e-5, 1.0)).unwrap();
    let size = ImageSize::new(256, 256);
    let truth = zp.box_filtered(&h, size, 8);
    let cases = [
        ("bilinear", Interp::Bilinear, false),
        ("bicubic", Interp::Bicubic, false),
        ("average", Interp::Average, true),
        ("bilinear+prefilter", Interp::Bilinear, true),
        ("bicubic+prefilter", Interp::Bicubic, true),
    ];
    let mut rms = Vec::new();
    for (name, interp, prefilter) in cases {
        let o = WarpOptions {
            nodata: 0.0,
            ..opts(interp, prefilter)
        };
        let out = warp(&src, &h, size, &o).unwrap();
        let low = rms_in_band(&zp, &h, &out, &truth, (0.0, 0.25));
        let high = rms_in_band(&zp, &h, &out, &truth, (0.5, 10.0));
        eprintln!(
            "{name:>20}: rms error vs box-filtered truth: below 0.25 c/px {low:.4}, above Nyquist {high:.4}"
        );
        rms.push((low, high));
    }
    let [bilinear, bicubic, average, bilinear_pf, bicubic_pf] = rms[..] else {
        unreachable!()
    };
    // Measured (1024^2 -> 256^2, f32): plain bilinear 0.017 / 0.237 (below 0.25 c/px / above
    // Nyquist), plain bicubic 0.020 / 0.289, average 0.0025 / 0.010, prefiltered bilinear
    // 0.007 / 0.094 (level 1, the remaining scale 1.95 still folds some rings), bicubic 0.015 / 0.132.
    assert!(bilinear.1 > 0.2 && bicubic.1 > 0.2, "plain kernels alias");
    assert!(
        average.0 < 0.005 && average.1 < 0.02,
        "average is the box filter"
    );
    assert!(bilinear_pf.0 < 0.01 && bilinear_pf.1 < 0.5 * bilinear.1);
    assert!(bicubic_pf.0 < 0.02 && bicubic_pf.1 < 0.5 * bicubic.1);
}

/// Below a scale of 2 the prefilter changes nothing, bit for bit (u8, 3 bands, with alpha).
#[test]
fn the_prefilter_is_a_no_op_below_a_scale_of_two() {
    let src = noise_u8(ImageSize::new(500, 400), 3, 5);
    let h = Homography::new(Mat3::new(1.6, 0.2, 3.0, -0.1, 1.5, 2.0, 2e-4, 4e-4, 1.0)).unwrap();
    let size = ImageSize::new(300, 260);
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        let on = warp(&src, &h, size, &opts(interp, true)).unwrap();
        let off = warp(&src, &h, size, &opts(interp, false)).unwrap();
        assert!(on == off, "{}", interp.name());
        assert!(on.plane(3).contains(&0) && on.plane(3).contains(&255));
    }
}

/// Under a strong perspective (scales from about 1 to 10, tiles at several levels) the prefiltered
/// warp keeps the plain warp's validity (nodata and alpha decided on level 0's footprints), and its
/// values stay within the source's range.
#[test]
fn prefiltered_tiles_keep_the_plain_footprint() {
    let src = noise_u8(ImageSize::new(900, 700), 1, 3);
    let h = Homography::new(Mat3::new(
        1.0, 0.3, -50.0, 0.0, 1.0, -20.0, 0.0, -2.5e-3, 1.0,
    ))
    .unwrap();
    let size = ImageSize::new(500, 380);
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        let on = warp(&src, &h, size, &opts(interp, true)).unwrap();
        let off = warp(&src, &h, size, &opts(interp, false)).unwrap();
        assert_eq!(on.plane(1), off.plane(1), "alpha, {}", interp.name());
        for (i, &a) in on.plane(1).iter().enumerate() {
            if a == 0 {
                assert_eq!(on.plane(0)[i], 7);
            }
        }
        assert!(on != off, "some tiles are prefiltered");
        let valid = on.plane(1).iter().filter(|&&a| a == 255).count();
        assert!(valid > size.pixels() / 4, "{valid} valid pixels");
    }
}

/// OpenCV's cv2.resize INTER_AREA on a crop of aero1 (stored, see data/downsample/README.md):
/// resize maps destination pixel c to source f (c + 0.5) - 0.5. Within one grey level; at the
/// integer factors every difference is an exact tie of the block mean (x.5), which OpenCV rounds
/// half to even (cvRound) and aerorect half up.
#[test]
fn average_equals_opencvs_inter_area() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/downsample");
    let input = std::fs::read(dir.join("aero1_gray_240x180.u8")).unwrap();
    let src = Raster::from_planes(ImageSize::new(240, 180), vec![input]).unwrap();
    for (f, name, w, h) in [
        (4.0, "area_x4_60x45.u8", 60, 45),
        (3.0, "area_x3_80x60.u8", 80, 60),
        (2.5, "area_x2.5_96x72.u8", 96, 72),
    ] {
        let peer = std::fs::read(dir.join(name)).unwrap();
        let o = 0.5 * (f - 1.0);
        let map = affine(f, 0.0, o, 0.0, f, o);
        let out = warp(
            &src,
            &map,
            ImageSize::new(w, h),
            &opts(Interp::Average, true),
        )
        .unwrap();
        let mut differing = 0;
        for (i, (&ours, &theirs)) in out.plane(0).iter().zip(&peer).enumerate() {
            assert!((ours as i32 - theirs as i32).abs() <= 1, "x{f} pixel {i}");
            if ours == theirs {
                continue;
            }
            differing += 1;
            if f.fract() == 0.0 {
                let n = f as usize;
                let (c, r) = (i % w, i / w);
                let sum: u32 = (0..n * n)
                    .map(|k| src.get(0, n * c + k % n, n * r + k / n).unwrap() as u32)
                    .sum();
                let mean = sum as f64 / (n * n) as f64;
                assert_eq!(mean.fract(), 0.5, "x{f} pixel {i}: not a tie");
                assert_eq!(theirs % 2, 0, "x{f} pixel {i}: OpenCV rounds ties to even");
            }
        }
        eprintln!(
            "x{f}: {differing} of {} pixels differ from OpenCV (by 1)",
            w * h
        );
    }
}

/// A window of the destination (a mosaic tile: the same map read from column c0, row r0, on the
/// 64-pixel tile grid) equals that part of the whole warp bit for bit: its pyramid is reduced
/// from a crop aligned to the deepest level, so the levels are the whole image's.
#[test]
fn a_prefiltered_window_equals_that_part_of_the_whole_warp() {
    struct Window<'a>(&'a Homography, usize, usize);
    impl PixelMap for Window<'_> {
        fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
            self.0.source_of(col + self.1 as f64, row + self.2 as f64)
        }
        fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
            self.0.source_row(row + self.2, col0 + self.1, xs, ys);
        }
    }
    let src = noise_u8(ImageSize::new(1500, 1200), 2, 4);
    let h = Homography::new(Mat3::new(4.0, 0.5, 3.0, -0.2, 4.5, 1.0, 2e-4, 1e-3, 1.0)).unwrap();
    let size = ImageSize::new(320, 256);
    for interp in [Interp::Bilinear, Interp::Bicubic] {
        let whole = warp(&src, &h, size, &opts(interp, true)).unwrap();
        let plain = warp(&src, &h, size, &opts(interp, false)).unwrap();
        assert!(whole != plain, "prefiltered");
        let (c0, r0, win) = (128, 64, ImageSize::new(100, 90));
        let part = warp(&src, &Window(&h, c0, r0), win, &opts(interp, true)).unwrap();
        for b in 0..3 {
            for r in 0..win.height {
                for c in 0..win.width {
                    assert_eq!(
                        part.get(b, c, r),
                        whole.get(b, c + c0, r + r0),
                        "{} band {b} ({c}, {r})",
                        interp.name()
                    );
                }
            }
        }
    }
}
