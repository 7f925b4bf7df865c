//! A simulated survey flight with known truth, for `bench/sim_flight.py`: NX x NY nadir frames
//! (480 x 360 px, f = 420 px, about 0.24 m pixels) in alternating strips 100 m over rolling
//! hills, rendered by tracing every pixel's ray onto the terrain and sampling a procedural
//! ground texture (value noise from 0.8 m to 100 m wavelengths, 2 x 2 samples per pixel).
//!
//! Writes into OUT_DIR: `frames/*.png`, `truth.csv` and `pert.csv` (the true poses and the
//! poses as recorded, every angle off by N(0, SIGMA_DEG); `filename,x,y,z,omega,phi,kappa`
//! with a `.prj` each), `cam.toml` and `dem.tif` (the hills on a 5 m grid).
//!
//! Ground control as well: `pert_gps.csv` (`.prj`), the recorded poses with every position off
//! by a common (2, -2, 1) m (3 m) plus N(0, 1 m) per axis, and `gcp_list.txt` (ODM's format,
//! EPSG:32633): 15 points on the hills, each marked in every frame that sees it with N(0,
//! 0.5 px) of noise per axis, five spread over the block (`G0`..`G4`) and ten at random
//! (`C0`..`C9`, listed in `checkpoints.txt` to keep out of the solve).
//!
//! `cargo run --release -p aerorect --example simulate_flight -- NX NY OUT_DIR [SIGMA_DEG]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::core::{Camera, CameraRotation, ImageSize, Intrinsics};
use aerorect::geo::Pose;
use aerorect::io::{Crs, GeoReference};
use aerorect::raster::{AnyRaster, Raster};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use std::path::Path;

const ORIGIN: [f64; 2] = [500_000.0, 5_000_000.0];
const FORWARD_M: f64 = 40.0;
const STRIP_M: f64 = 55.0;
const HEIGHT_M: f64 = 130.0;

fn hills(x: f64, y: f64) -> f64 {
    let (u, v) = (x - ORIGIN[0], y - ORIGIN[1]);
    25.0 + 20.0 * (u / 140.0).sin() * (v / 120.0).cos() + 6.0 * (u / 47.0 + v / 61.0).sin()
}

/// Lattice value noise in [0, 1] at (x, y) in cells, smoothly interpolated.
fn value_noise(x: f64, y: f64, seed: u64) -> f64 {
    let hash = |i: i64, j: i64| -> f64 {
        let mut h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ seed.wrapping_mul(0x1656_67B1_9E37_79F9);
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        (h >> 11) as f64 / (1u64 << 53) as f64
    };
    let (i, j) = (x.floor() as i64, y.floor() as i64);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (s(fx), s(fy));
    let top = hash(i, j) * (1.0 - sx) + hash(i + 1, j) * sx;
    let bottom = hash(i, j + 1) * (1.0 - sx) + hash(i + 1, j + 1) * sx;
    top * (1.0 - sy) + bottom * sy
}

/// The ground's brightness (0-255) at world (x, y).
fn texture(x: f64, y: f64) -> f64 {
    let (mut sum, mut norm, mut wavelength, mut amp) = (0.0, 0.0, 100.0, 1.0);
    for octave in 0..8 {
        sum += amp * value_noise(x / wavelength, y / wavelength, octave);
        norm += amp;
        wavelength /= 1.9;
        amp *= 0.75;
    }
    255.0 * (sum / norm)
}

/// Where a ray from `c` along `d` meets the hills (fixed-point iteration on the height).
fn on_hills(c: [f64; 3], d: [f64; 3]) -> Option<[f64; 2]> {
    if d[2] >= 0.0 {
        return None;
    }
    let mut z = hills(c[0], c[1]);
    let mut p = [c[0], c[1]];
    for _ in 0..8 {
        let t = (z - c[2]) / d[2];
        p = [c[0] + t * d[0], c[1] + t * d[1]];
        z = hills(p[0], p[1]);
    }
    Some(p)
}

fn render(camera: &Camera, pose: &Pose) -> Raster<u8> {
    let (w, h) = (camera.size.width, camera.size.height);
    let pixels: Vec<u8> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (c, r) = ((i % w) as f64, (i / w) as f64);
            let mut sum = 0.0;
            for (dx, dy) in [(-0.25, -0.25), (0.25, -0.25), (-0.25, 0.25), (0.25, 0.25)] {
                let ray = camera.ray_from_pixel(c + dx, r + dy).unwrap();
                let d = pose.world_direction(ray);
                let p = on_hills(pose.centre, [d[0], d[1], d[2]]).unwrap();
                sum += texture(p[0], p[1]);
            }
            (sum / 4.0).round().clamp(0.0, 255.0) as u8
        })
        .collect();
    Raster::from_planes(ImageSize::new(w, h), vec![pixels]).unwrap()
}

fn write_dem(path: &Path, nx: usize, ny: usize) {
    let cell = 5.0;
    let (x0, y1) = (ORIGIN[0] - 150.0, ORIGIN[1] + ny as f64 * STRIP_M + 150.0);
    let (w, h) = (
        ((nx as f64 * FORWARD_M + 300.0) / cell) as usize,
        ((ny as f64 * STRIP_M + 300.0) / cell) as usize,
    );
    let z: Vec<f32> = (0..w * h)
        .map(|i| {
            let (c, r) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            hills(x0 + c * cell, y1 - r * cell) as f32
        })
        .collect();
    let geo = GeoReference {
        crs: Crs::Epsg(32633),
        pixel_size: [cell, cell],
        top_left: [x0, y1],
        rotation: [0.0, 0.0],
        nodata: None,
    };
    let raster = Raster::from_planes(ImageSize::new(w, h), vec![z]).unwrap();
    aerorect::io::write_image_geo(path, &AnyRaster::F32(raster), Some(&geo)).unwrap();
}

/// The common GPS offset of `pert_gps.csv` (3 m).
const GPS_OFFSET_M: [f64; 3] = [2.0, -2.0, 1.0];

/// `gcp_list.txt` and `checkpoints.txt` (see the file's doc).
fn write_gcps(
    out: &Path,
    camera: &Camera,
    poses: &[(String, Pose)],
    (nx, ny): (usize, usize),
    rng: &mut ChaCha8Rng,
) {
    use rand::Rng;
    let noise = Normal::new(0.0, 0.5).unwrap();
    let (w, h) = ((nx - 1) as f64 * FORWARD_M, (ny - 1) as f64 * STRIP_M);
    let spread = [
        (0.15, 0.15),
        (0.85, 0.15),
        (0.15, 0.85),
        (0.85, 0.85),
        (0.5, 0.5),
    ];
    let mut points: Vec<(String, f64, f64)> = spread
        .iter()
        .enumerate()
        .map(|(k, (a, b))| (format!("G{k}"), a * w, b * h))
        .collect();
    points.extend((0..10).map(|k| {
        let (a, b): (f64, f64) = (rng.random_range(0.1..0.9), rng.random_range(0.1..0.9));
        (format!("C{k}"), a * w, b * h)
    }));
    let mut list = String::from("EPSG:32633\n");
    for (name, dx, dy) in &points {
        let (x, y) = (ORIGIN[0] + dx, ORIGIN[1] + dy);
        let g = aerorect::core::Vec3::new(x, y, hills(x, y));
        for (image, pose) in poses {
            let d = pose.world_from_camera().transpose()
                * (g - aerorect::core::Vec3::from(pose.centre));
            let Some(p) = camera.pixel_from_camera_point(d) else {
                continue;
            };
            let inside = p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= 479.0 && p[1] <= 359.0;
            if inside {
                list += &format!(
                    "{x:.3} {y:.3} {:.3} {:.2} {:.2} {image} {name}\n",
                    g.z,
                    p[0] + noise.sample(rng),
                    p[1] + noise.sample(rng)
                );
            }
        }
    }
    std::fs::write(out.join("gcp_list.txt"), list).unwrap();
    let checks: Vec<&str> = points[5..].iter().map(|p| p.0.as_str()).collect();
    std::fs::write(out.join("checkpoints.txt"), checks.join(",")).unwrap();
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let nx: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(10);
    let ny: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(10);
    let out = Path::new(args.get(2).map_or("out/sim-flight", String::as_str)).to_path_buf();
    let sigma: f64 = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(1.0);
    std::fs::create_dir_all(out.join("frames")).unwrap();
    let camera = Camera::new(
        Intrinsics::new(420.0, 420.0, 239.5, 179.5).unwrap(),
        None,
        ImageSize::new(480, 360),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let err = Normal::new(0.0, sigma).unwrap();
    let tilt = Normal::new(0.0, 0.5).unwrap();
    let (mut truth, mut pert, mut pert_gps) = (String::new(), String::new(), String::new());
    let mut poses = Vec::new();
    let gps = Normal::new(0.0, 1.0).unwrap();
    let header = "filename,x,y,z,omega,phi,kappa\n";
    let t0 = std::time::Instant::now();
    for j in 0..ny {
        for i in 0..nx {
            // Alternate strips fly back (kappa 180).
            let kappa = if j % 2 == 0 { 0.0 } else { 180.0 };
            let c = [
                ORIGIN[0] + i as f64 * FORWARD_M,
                ORIGIN[1] + j as f64 * STRIP_M,
                HEIGHT_M,
            ];
            let opk = [
                tilt.sample(&mut rng),
                tilt.sample(&mut rng),
                kappa + tilt.sample(&mut rng),
            ];
            let rec = [
                opk[0] + err.sample(&mut rng),
                opk[1] + err.sample(&mut rng),
                opk[2] + err.sample(&mut rng),
            ];
            let rot = CameraRotation::omega_phi_kappa(opk[0], opk[1], opk[2]).unwrap();
            let pose = Pose::new(c, rot.ground_from_camera());
            let name = format!("f_{j:03}_{i:03}.png");
            let frame = render(&camera, &pose);
            aerorect::io::write_image(&out.join("frames").join(&name), &AnyRaster::U8(frame))
                .unwrap();
            let row = |a: [f64; 3]| {
                format!(
                    "{name},{:.3},{:.3},{:.3},{:.6},{:.6},{:.6}\n",
                    c[0], c[1], c[2], a[0], a[1], a[2]
                )
            };
            truth += &row(opk);
            pert += &row(rec);
            let d = [0, 1, 2].map(|k| GPS_OFFSET_M[k] + gps.sample(&mut rng));
            pert_gps += &format!(
                "{name},{:.3},{:.3},{:.3},{:.6},{:.6},{:.6}\n",
                c[0] + d[0],
                c[1] + d[1],
                c[2] + d[2],
                rec[0],
                rec[1],
                rec[2]
            );
            poses.push((name.clone(), pose));
        }
    }
    let wkt = Crs::Epsg(32633).to_wkt().unwrap();
    for (name, rows) in [("truth", truth), ("pert", pert), ("pert_gps", pert_gps)] {
        std::fs::write(out.join(format!("{name}.csv")), format!("{header}{rows}")).unwrap();
        std::fs::write(out.join(format!("{name}.prj")), &wkt).unwrap();
    }
    std::fs::write(
        out.join("cam.toml"),
        "fx_px = 420.0\nfy_px = 420.0\ncx_px = 239.5\ncy_px = 179.5\nimage_size_px = [480, 360]\n",
    )
    .unwrap();
    write_dem(&out.join("dem.tif"), nx, ny);
    write_gcps(&out, &camera, &poses, (nx, ny), &mut rng);
    eprintln!(
        "{} frames rendered into {} in {:.1} s",
        nx * ny,
        out.display(),
        t0.elapsed().as_secs_f64()
    );
}
