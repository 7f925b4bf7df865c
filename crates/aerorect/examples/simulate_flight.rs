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
//! With `fixed-wing` after SIGMA_DEG, a fixed wing's flight instead (the default's random
//! stream and outputs are untouched): the image top towards the nose, strips flown east and
//! west in turn (`f_STRIP_SHOT.png` in flight order, so the GPS track runs along the strip),
//! every frame rolled and pitched by U(-5, 5) degrees, and the nose 30 degrees off the track
//! (plus U(-2, 2)) into a wind from the north: left of the track flying east, right of it
//! flying west, so the crab flips sign with the strip (the strips' noses point 120 degrees
//! apart). The recorded positions are off by N(0, 3 m) east and north and N(0, 2 m) up, in
//! `pert.csv` as in `pert_gps.csv` (the same), with the attitudes off by N(0, SIGMA_DEG). The
//! frames are 22 m apart in 45 m strips so that the crabbed footprints (90 x 120 m at 105 m
//! over the ground, long side across the nose) keep about 70 % forward and 70 % side overlap
//! (60 % over the highest hills); `fixed_wing.txt` marks the directory.
//!
//! `cargo run --release -p aerorect --example simulate_flight -- NX NY OUT_DIR [SIGMA_DEG [fixed-wing]]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::core::{Camera, CameraRotation, ImageSize, Intrinsics};
use aerorect::geo::Crs;
use aerorect::geo::Pose;
use aerorect::io::GeoReference;
use aerorect::photo_source::rotation_from_body_ypr;
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

/// How far apart the frames are: along a strip and between strips (m).
#[derive(Debug, Clone, Copy)]
struct Layout {
    forward_m: f64,
    strip_m: f64,
}

/// The default nadir flight's.
const NADIR: Layout = Layout {
    forward_m: FORWARD_M,
    strip_m: STRIP_M,
};

/// The fixed wing's: closer, so that the crabbed, tilted footprints still overlap.
const FIXED_WING: Layout = Layout {
    forward_m: 22.0,
    strip_m: 45.0,
};

/// The fixed wing's roll and pitch: U(-this, this) degrees.
const FW_TILT_DEG: f64 = 5.0;
/// The fixed wing's crab (degrees, the nose off the track into the wind) and its gusts
/// (U(-this, this) degrees more).
const FW_CRAB_DEG: f64 = 30.0;
const FW_GUST_DEG: f64 = 2.0;
/// The fixed wing's GPS noise (m, one sigma; east, north, up).
const FW_GPS_SIGMA_M: [f64; 3] = [3.0, 3.0, 2.0];

fn hills(x: f64, y: f64) -> f64 {
    let (u, v) = (x - ORIGIN[0], y - ORIGIN[1]);
    25.0 + 20.0 * (u / 140.0).sin() * (v / 120.0).cos()
        + 6.0 * (u / 47.0 + v / 61.0).sin()
        + ramp_m(u)
}

/// The slope (degrees, the ground rising east) of a ramp under the hills, as `f64` bits: none
/// by default (the hills to the bit as without it). For tests of steep ground: set once per
/// process ([`set_ramp_deg`]) before [`simulate`].
static RAMP_DEG_BITS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Where the ramp crosses the hills' mean (m east of the origin): the middle of a 5 x 4 block.
const RAMP_CENTRE_M: f64 = 80.0;

/// Puts the hills on a ramp of `deg` degrees rising east (see [`RAMP_DEG_BITS`]).
pub fn set_ramp_deg(deg: f64) {
    RAMP_DEG_BITS.store(deg.to_bits(), std::sync::atomic::Ordering::Relaxed);
}

fn ramp_m(u: f64) -> f64 {
    let deg = f64::from_bits(RAMP_DEG_BITS.load(std::sync::atomic::Ordering::Relaxed));
    // At 0 degrees a signed zero: the sum it joins keeps its bits.
    deg.to_radians().tan() * (u - RAMP_CENTRE_M)
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

fn write_dem(path: &Path, nx: usize, ny: usize, layout: Layout) {
    let cell = 5.0;
    let (x0, y1) = (
        ORIGIN[0] - 150.0,
        ORIGIN[1] + ny as f64 * layout.strip_m + 150.0,
    );
    let (w, h) = (
        ((nx as f64 * layout.forward_m + 300.0) / cell) as usize,
        ((ny as f64 * layout.strip_m + 300.0) / cell) as usize,
    );
    let z: Vec<f32> = (0..w * h)
        .map(|i| {
            let (c, r) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            hills(x0 + c * cell, y1 - r * cell) as f32
        })
        .collect();
    let geo = GeoReference {
        crs: Crs::from_epsg(32633).unwrap(),
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
    (nx, ny, layout): (usize, usize, Layout),
    rng: &mut ChaCha8Rng,
) {
    use rand::Rng;
    let noise = Normal::new(0.0, 0.5).unwrap();
    let (w, h) = (
        (nx - 1) as f64 * layout.forward_m,
        (ny - 1) as f64 * layout.strip_m,
    );
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

/// One frame: its name, true centre and omega, phi, kappa, and as recorded (`pert.csv`:
/// centre and angles; `pert_gps.csv`: centre).
struct Shot {
    name: String,
    centre: [f64; 3],
    truth: [f64; 3],
    rec_centre: [f64; 3],
    rec: [f64; 3],
    gps_centre: [f64; 3],
}

/// The default flight: nadir within N(0, 0.5) degrees, alternate strips turned 180 degrees.
fn nadir_shots(nx: usize, ny: usize, sigma: f64, rng: &mut ChaCha8Rng) -> Vec<Shot> {
    let err = Normal::new(0.0, sigma).unwrap();
    let tilt = Normal::new(0.0, 0.5).unwrap();
    let gps = Normal::new(0.0, 1.0).unwrap();
    let mut shots = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            // Alternate strips fly back (kappa 180).
            let kappa = if j % 2 == 0 { 0.0 } else { 180.0 };
            let c = [
                ORIGIN[0] + i as f64 * FORWARD_M,
                ORIGIN[1] + j as f64 * STRIP_M,
                HEIGHT_M,
            ];
            let opk = [tilt.sample(rng), tilt.sample(rng), kappa + tilt.sample(rng)];
            let rec = [
                opk[0] + err.sample(rng),
                opk[1] + err.sample(rng),
                opk[2] + err.sample(rng),
            ];
            let d = [0, 1, 2].map(|k| GPS_OFFSET_M[k] + gps.sample(rng));
            shots.push(Shot {
                name: format!("f_{j:03}_{i:03}.png"),
                centre: c,
                truth: opk,
                rec_centre: c,
                rec,
                gps_centre: [c[0] + d[0], c[1] + d[1], c[2] + d[2]],
            });
        }
    }
    shots
}

/// The fixed wing's flight (see the file's doc).
fn fixed_wing_shots(nx: usize, ny: usize, sigma: f64, rng: &mut ChaCha8Rng) -> Vec<Shot> {
    use rand::Rng;
    let err = Normal::new(0.0, sigma).unwrap();
    let mut shots = Vec::new();
    for j in 0..ny {
        let east = j % 2 == 0;
        // Wind from the north: the nose turns north of the track.
        let (track, crab) = if east {
            (90.0, -FW_CRAB_DEG)
        } else {
            (270.0, FW_CRAB_DEG)
        };
        for t in 0..nx {
            let i = if east { t } else { nx - 1 - t };
            let c = [
                ORIGIN[0] + i as f64 * FIXED_WING.forward_m,
                ORIGIN[1] + j as f64 * FIXED_WING.strip_m,
                HEIGHT_M,
            ];
            let yaw = track + crab + rng.random_range(-FW_GUST_DEG..=FW_GUST_DEG);
            let pitch = rng.random_range(-FW_TILT_DEG..=FW_TILT_DEG);
            let roll = rng.random_range(-FW_TILT_DEG..=FW_TILT_DEG);
            let opk = rotation_from_body_ypr(yaw, pitch, roll)
                .unwrap()
                .to_omega_phi_kappa();
            let rec = opk.map(|a| a + err.sample(rng));
            let gps = FW_GPS_SIGMA_M.map(|s| Normal::new(0.0, s).unwrap().sample(rng));
            let at = [c[0] + gps[0], c[1] + gps[1], c[2] + gps[2]];
            shots.push(Shot {
                name: format!("f_{j:03}_{t:03}.png"),
                centre: c,
                truth: opk,
                rec_centre: at,
                rec,
                gps_centre: at,
            });
        }
    }
    shots
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let nx: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(10);
    let ny: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(10);
    let out = Path::new(args.get(2).map_or("out/sim-flight", String::as_str)).to_path_buf();
    let sigma: f64 = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let fixed_wing = match args.get(4).map(String::as_str) {
        None => false,
        Some("fixed-wing") => true,
        Some(other) => panic!("mode '{other}': expected fixed-wing"),
    };
    simulate(nx, ny, &out, sigma, fixed_wing);
}

/// The flight of the module's description into `out` (tests include this file as a module).
pub fn simulate(nx: usize, ny: usize, out: &Path, sigma: f64, fixed_wing: bool) {
    std::fs::create_dir_all(out.join("frames")).unwrap();
    let camera = Camera::new(
        Intrinsics::new(420.0, 420.0, 239.5, 179.5).unwrap(),
        None,
        ImageSize::new(480, 360),
    );
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (shots, layout) = if fixed_wing {
        (fixed_wing_shots(nx, ny, sigma, &mut rng), FIXED_WING)
    } else {
        (nadir_shots(nx, ny, sigma, &mut rng), NADIR)
    };
    let (mut truth, mut pert, mut pert_gps) = (String::new(), String::new(), String::new());
    let mut poses = Vec::new();
    let header = "filename,x,y,z,omega,phi,kappa\n";
    let t0 = std::time::Instant::now();
    for shot in &shots {
        let opk = shot.truth;
        let rot = CameraRotation::omega_phi_kappa(opk[0], opk[1], opk[2]).unwrap();
        let pose = Pose::new(shot.centre, rot.ground_from_camera());
        let frame = render(&camera, &pose);
        aerorect::io::write_image(&out.join("frames").join(&shot.name), &AnyRaster::U8(frame))
            .unwrap();
        let row = |c: [f64; 3], a: [f64; 3]| {
            format!(
                "{},{:.3},{:.3},{:.3},{:.6},{:.6},{:.6}\n",
                shot.name, c[0], c[1], c[2], a[0], a[1], a[2]
            )
        };
        truth += &row(shot.centre, opk);
        pert += &row(shot.rec_centre, shot.rec);
        pert_gps += &row(shot.gps_centre, shot.rec);
        poses.push((shot.name.clone(), pose));
    }
    let wkt = Crs::from_epsg(32633).unwrap().to_wkt().unwrap();
    for (name, rows) in [("truth", truth), ("pert", pert), ("pert_gps", pert_gps)] {
        std::fs::write(out.join(format!("{name}.csv")), format!("{header}{rows}")).unwrap();
        std::fs::write(out.join(format!("{name}.prj")), &wkt).unwrap();
    }
    std::fs::write(
        out.join("cam.toml"),
        "fx_px = 420.0\nfy_px = 420.0\ncx_px = 239.5\ncy_px = 179.5\nimage_size_px = [480, 360]\n",
    )
    .unwrap();
    write_dem(&out.join("dem.tif"), nx, ny, layout);
    write_gcps(out, &camera, &poses, (nx, ny, layout), &mut rng);
    if fixed_wing {
        std::fs::write(
            out.join("fixed_wing.txt"),
            format!(
                "fixed wing: roll and pitch U(-{FW_TILT_DEG}, {FW_TILT_DEG}) deg, crab {FW_CRAB_DEG} deg, GPS N(0, {FW_GPS_SIGMA_M:?} m), recorded attitude N(0, {sigma} deg)\n"
            ),
        )
        .unwrap();
    }
    eprintln!(
        "{} frames rendered into {} in {:.1} s",
        nx * ny,
        out.display(),
        t0.elapsed().as_secs_f64()
    );
}
