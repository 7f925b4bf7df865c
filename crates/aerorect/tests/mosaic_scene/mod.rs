//! The simulated scene of the mosaic tests: frames of one textured level ground from two
//! near-nadir cameras and an oblique one, and the whole mosaic composited tile by tile.
#![allow(clippy::unwrap_used, dead_code)]

use aerorect::core::{Camera, CameraRotation, ImageSize, Intrinsics, RectifyLimits};
use aerorect::geo::{Crs, Pose};
use aerorect::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use aerorect::mosaic::{MosaicFrame, MosaicOptions, MosaicPlan, MosaicRun};
use aerorect::raster::{AnyRaster, Interp, Raster, WarpOptions};
use std::path::PathBuf;

pub const GSD: f64 = 0.25;
pub const ORIGIN: [f64; 2] = [500_000.0, 5_970_000.0];

pub fn texture(x: f64, y: f64) -> f64 {
    let (x, y) = (x - ORIGIN[0], y - ORIGIN[1]);
    128.0 + 50.0 * (x / 2.1).sin() * (y / 2.9).cos() + 30.0 * ((x + y) / 3.7).sin()
}

pub fn camera() -> Camera {
    Camera::new(
        Intrinsics::new(150.0, 150.0, 79.5, 59.5).unwrap(),
        None,
        ImageSize::new(160, 120),
    )
}

/// Two near-nadir frames and an oblique one, overlapping: (x, y, height, yaw, pitch).
pub const SHOTS: [[f64; 5]; 3] = [
    [0.0, 0.0, 60.0, 0.0, -90.0],
    [35.0, 12.0, 70.0, 30.0, -86.0],
    [-10.0, -45.0, 55.0, 10.0, -60.0],
];

pub fn pose(shot: [f64; 5]) -> Pose {
    let r = CameraRotation::dji_gimbal(shot[3], shot[4], 0.0).unwrap();
    Pose::new(
        [ORIGIN[0] + shot[0], ORIGIN[1] + shot[1], shot[2]],
        r.ground_from_camera(),
    )
}

/// The frame a camera at `pose` records of the textured level ground at z = 0, each pixel's
/// brightness raised by `offset`.
pub fn simulate(cam: &Camera, pose: &Pose, offset: f64) -> AnyRaster {
    let s = cam.size;
    let mut px = vec![0f32; s.pixels()];
    for v in 0..s.height {
        for u in 0..s.width {
            let d = pose.world_direction(cam.ray_from_pixel(u as f64, v as f64).unwrap());
            let t = -pose.centre[2] / d.z;
            let g = [pose.centre[0] + t * d.x, pose.centre[1] + t * d.y];
            px[v * s.width + u] = (texture(g[0], g[1]) + offset) as f32;
        }
    }
    AnyRaster::F32(Raster::from_planes(s, vec![px]).unwrap())
}

pub fn plan(cam: &Camera, pose: Pose) -> OrthoPlan {
    let world = Crs::from_proj_string("+proj=utm +zone=35 +datum=WGS84 +units=m +no_defs").unwrap();
    let req = OrthoRequest {
        camera: cam,
        pose,
        world: &world,
        ground: &Ground::Flat(0.0),
        gsd_m: GSD,
        limits: RectifyLimits::default(),
        occlusion: false,
    };
    let warp = WarpOptions {
        interp: Interp::Bilinear,
        nodata: f64::NAN,
        alpha: false,
        prefilter: true,
        ..WarpOptions::default()
    };
    plan_ortho(&req, warp).unwrap()
}

pub struct Scene {
    pub cam: Camera,
    pub poses: Vec<Pose>,
    pub frames: Vec<MosaicFrame>,
    pub images: Vec<AnyRaster>,
}

pub fn scene(offsets: [f64; 3]) -> Scene {
    let cam = camera();
    let poses: Vec<Pose> = SHOTS.iter().map(|&s| pose(s)).collect();
    let frames = poses
        .iter()
        .enumerate()
        .map(|(k, p)| MosaicFrame {
            path: PathBuf::from(format!("frame{k}.tif")),
            plan: plan(&cam, *p),
            nadir_xy: [p.centre[0], p.centre[1]],
            height_m: p.centre[2],
        })
        .collect();
    let images = poses
        .iter()
        .zip(offsets)
        .map(|(p, o)| simulate(&cam, p, o))
        .collect();
    Scene {
        cam,
        poses,
        frames,
        images,
    }
}

/// The whole mosaic, tile by tile (band 0 and alpha), and the run's decode counts.
pub fn run_all(s: &Scene, opts: MosaicOptions) -> (MosaicPlan, Vec<f32>, Vec<f32>, Vec<usize>) {
    let plan = MosaicPlan::new(s.frames.clone(), GSD, opts).unwrap();
    let size = plan.grid.size;
    let (mut v, mut a) = (vec![0f32; size.pixels()], vec![0f32; size.pixels()]);
    let paths: Vec<PathBuf> = s.frames.iter().map(|f| f.path.clone()).collect();
    let run = MosaicRun::new(&plan, |f: &MosaicFrame| {
        let k = paths.iter().position(|p| *p == f.path).unwrap();
        Ok(s.images[k].clone())
    });
    for t in plan.tile_windows().collect::<Vec<_>>() {
        let r = run.tile(t).unwrap();
        for i in 0..t.size.pixels() {
            let (c, row) = (t.col0 + i % t.size.width, t.row0 + i / t.size.width);
            v[row * size.width + c] = sample(&r, 0, i) as f32;
            a[row * size.width + c] = sample(&r, 1, i) as f32;
        }
    }
    let loads = run.loads();
    (plan, v, a, loads)
}

/// Sample `i` of band `band` of a u8 or f32 raster.
pub fn sample(r: &AnyRaster, band: usize, i: usize) -> f64 {
    match r {
        AnyRaster::U8(r) => f64::from(r.plane(band)[i]),
        AnyRaster::F32(r) => f64::from(r.plane(band)[i]),
        AnyRaster::U16(_) => panic!("the scene's frames are u8 or f32"),
    }
}

/// The scene with its frames rounded to u8 (rendered with an alpha band, as photos are).
pub fn scene_u8(offsets: [f64; 3]) -> Scene {
    let mut s = scene(offsets);
    for f in &mut s.frames {
        f.plan.warp.nodata = 0.0;
        f.plan.warp.alpha = true;
    }
    for im in &mut s.images {
        let AnyRaster::F32(r) = &*im else {
            panic!("the scene's frames are f32")
        };
        let px = r
            .plane(0)
            .iter()
            .map(|v| v.round().clamp(0.0, 255.0) as u8)
            .collect();
        *im = AnyRaster::U8(Raster::from_planes(r.size(), vec![px]).unwrap());
    }
    s
}
