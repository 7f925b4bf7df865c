//! Dev-only helpers: synthetic scenes with fixed seeds, a slow per-pixel warp oracle written
//! from the textbook formulas (independent of the optimised kernels), and image metrics.
#![allow(clippy::unwrap_used)]

pub mod chessboard;
pub mod flight;
pub mod lens_domain;
pub mod zone_plate;

use aerorect_core::ImageSize;
use aerorect_raster::{Interp, PixelMap, Raster, Sample};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A deterministic textured scene: smooth gradients, sinusoids, sharp squares and noise, scaled
/// to [0, peak] and rounded to `T`.
pub fn textured_scene<T: Sample>(size: ImageSize, bands: usize, peak: f32, seed: u64) -> Raster<T> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let planes = (0..bands)
        .map(|b| {
            let (kx, ky): (f32, f32) = (rng.random_range(0.03..0.2), rng.random_range(0.03..0.2));
            let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
            (0..size.pixels())
                .map(|i| {
                    let (x, y) = ((i % size.width) as f32, (i / size.width) as f32);
                    let smooth = 0.5 + 0.25 * (kx * x + phase).sin() * (ky * y).cos();
                    let ramp = 0.15 * (x + y + b as f32 * 7.0) / (size.width + size.height) as f32;
                    let square = if ((x as usize / 13) + (y as usize / 17)).is_multiple_of(2) {
                        0.08
                    } else {
                        0.0
                    };
                    let noise: f32 = rng.random_range(-0.02..0.02);
                    T::from_f32((smooth + ramp + square + noise).clamp(0.0, 1.0) * peak)
                })
                .collect()
        })
        .collect();
    Raster::from_planes(size, planes).unwrap()
}

/// Peak signal-to-noise ratio in dB over the pixels where `mask` is true.
pub fn psnr_masked(a: &[f32], b: &[f32], mask: &[bool], peak: f64) -> f64 {
    let (mut se, mut n) = (0.0f64, 0usize);
    for ((x, y), &m) in a.iter().zip(b).zip(mask) {
        if m {
            se += (*x as f64 - *y as f64).powi(2);
            n += 1;
        }
    }
    assert!(n > 0, "empty mask");
    10.0 * (peak * peak / (se / n as f64)).log10()
}

/// Keys' cubic convolution kernel, a = -0.5, written from its definition.
pub fn keys_kernel(d: f64) -> f64 {
    let a = -0.5;
    let d = d.abs();
    if d <= 1.0 {
        (a + 2.0) * d.powi(3) - (a + 3.0) * d.powi(2) + 1.0
    } else if d < 2.0 {
        a * d.powi(3) - 5.0 * a * d.powi(2) + 8.0 * a * d - 4.0 * a
    } else {
        0.0
    }
}

/// Slow reference sample of band `b` at (x, y): f64 arithmetic, edge pixels repeated, `None`
/// outside the pixel footprints [-0.5, n - 0.5).
pub fn oracle_sample<T: Sample>(
    src: &Raster<T>,
    b: usize,
    interp: Interp,
    x: f64,
    y: f64,
) -> Option<f64> {
    let (w, h) = (src.width() as i64, src.height() as i64);
    if !(x >= -0.5 && x < w as f64 - 0.5 && y >= -0.5 && y < h as f64 - 0.5) {
        return None;
    }
    let px = |i: i64, j: i64| {
        src.get(b, i.clamp(0, w - 1) as usize, j.clamp(0, h - 1) as usize)
            .unwrap()
            .to_f32() as f64
    };
    let (x0, y0) = (x.floor() as i64, y.floor() as i64);
    Some(match interp {
        Interp::Nearest => px((x + 0.5).floor() as i64, (y + 0.5).floor() as i64),
        Interp::Bilinear => {
            // Clamp the position first (edge repeat), then the four-neighbour formula.
            let xc = x.clamp(0.0, (w - 1) as f64);
            let yc = y.clamp(0.0, (h - 1) as f64);
            let (i, j) = (xc.floor() as i64, yc.floor() as i64);
            let (fx, fy) = (xc - i as f64, yc - j as f64);
            (1.0 - fx) * (1.0 - fy) * px(i, j)
                + fx * (1.0 - fy) * px(i + 1, j)
                + (1.0 - fx) * fy * px(i, j + 1)
                + fx * fy * px(i + 1, j + 1)
        }
        Interp::Bicubic => {
            let mut acc = 0.0;
            for j in -1..=2 {
                for i in -1..=2 {
                    let wgt = keys_kernel(x - (x0 + i) as f64) * keys_kernel(y - (y0 + j) as f64);
                    acc += wgt * px(x0 + i, y0 + j);
                }
            }
            acc
        }
        // An area mean depends on the map's local scale, not on one position: its tests use
        // closed-form block means, an analytic zone plate and OpenCV's INTER_AREA instead.
        Interp::Average => panic!("oracle_sample: average is not a point sample"),
    })
}

/// Slow reference warp: one `source_of` call and one oracle sample per pixel and band.
/// Returns per band the values (None = nodata).
pub fn oracle_warp<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    size: ImageSize,
    interp: Interp,
) -> Vec<Vec<Option<f64>>> {
    (0..src.bands())
        .map(|b| {
            (0..size.pixels())
                .map(|i| {
                    let (c, r) = ((i % size.width) as f64, (i / size.width) as f64);
                    map.source_of(c, r)
                        .and_then(|p| oracle_sample(src, b, interp, p[0], p[1]))
                })
                .collect()
        })
        .collect()
}

/// `../shared/data/REL` beside the repository (extended tests; `AERORECT_SHARED_DATA` names
/// another folder), or `None` after recording the skip with [`skip`].
pub fn shared_data(rel: &str) -> Option<std::path::PathBuf> {
    let root = std::env::var_os("AERORECT_SHARED_DATA").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
        std::path::PathBuf::from,
    );
    let p = root.join(rel);
    if p.exists() {
        Some(p)
    } else {
        skip(&format!("{} is absent", p.display()));
        None
    }
}

/// Records that the calling test did not run (libtest reports it as `ok` all the same): says
/// `SKIP` on stderr and, when `AERORECT_SKIP_LOG` names a file, appends a line
/// `TEST-BINARY::TEST: why` to it (.ci/run prints the count and the names).
pub fn skip(why: &str) {
    let test = std::thread::current()
        .name()
        .unwrap_or("unnamed test")
        .to_string();
    // Test binaries are named `NAME-HASH`.
    let binary = std::env::current_exe()
        .ok()
        .and_then(|e| e.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .map(|s| match s.rsplit_once('-') {
            Some((name, hash)) if hash.chars().all(|c| c.is_ascii_hexdigit()) => name.to_string(),
            _ => s,
        })
        .unwrap_or_default();
    eprintln!("SKIP: {binary}::{test}: {why}; this extended test did not run");
    if let Some(log) = std::env::var_os("AERORECT_SKIP_LOG") {
        use std::io::Write;
        let line = format!("{binary}::{test}: {why}\n");
        // One write of one line in append mode: lines from parallel tests do not interleave.
        let written = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .and_then(|mut f| f.write_all(line.as_bytes()));
        if let Err(e) = written {
            eprintln!("cannot record the skip in {}: {e}", log.to_string_lossy());
        }
    }
}

/// Control points from a CSV `image,X,Y,Z,u,v` (a header line first), as `calibrate --points`
/// reads them.
pub fn read_observations(path: &std::path::Path) -> Vec<aerorect_solve::calib::Observation> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| r[i].trim().parse::<f64>().unwrap();
            aerorect_solve::calib::Observation {
                image: r[0].to_string(),
                world: [f(1), f(2), f(3)],
                pixel: [f(4), f(5)],
            }
        })
        .collect()
}

/// OpenCV's 13 chessboard views of `data/calib/left_corners.csv` (702 corners).
pub fn opencv_corners() -> Vec<aerorect_solve::calib::Observation> {
    read_observations(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_corners.csv"),
    )
}
