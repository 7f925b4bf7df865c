//! Ortho throughput over a DEM beside the flat-ground homography path: the same frame, camera,
//! pose and output grid, warped through `GroundMap` (terrain heights, lens) and through the
//! closed-form ground homography (then the lens). Criterion reports elements/s: output pixels
//! per second.
#![allow(clippy::unwrap_used)]

use aerorect_core::distortion::{Distortion, OpenCv};
use aerorect_core::{Camera, CameraRotation, Homography, ImageSize, Intrinsics};
use aerorect_geo::{Crs, Dem, GroundMap, HeightGrid, OrthoGrid, Pose, Terrain};
use aerorect_raster::{Interp, LensDirection, LensMap, Raster, Then, WarpOptions, warp_into};
use aerorect_testkit::textured_scene;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::time::Duration;

fn setup() -> (Camera, Pose, OrthoGrid, HeightGrid) {
    let lens = Distortion::OpenCv(OpenCv {
        k1: -0.1,
        k2: 0.02,
        ..OpenCv::default()
    });
    let cam = Camera::new(
        Intrinsics::new(3000.0, 3000.0, 1999.5, 1124.5).unwrap(),
        Some(lens),
        ImageSize::new(4000, 2250),
    );
    let r = CameraRotation::dji_gimbal(30.0, -80.0, 0.0).unwrap();
    let pose = Pose::new([0.0, 0.0, 100.0], r.ground_from_camera());
    let grid = OrthoGrid {
        top_left: [-60.0, 70.0],
        gsd: 0.05,
        size: ImageSize::new(2400, 2400),
    };
    let (n, s) = (200usize, 1.0);
    let values = (0..n * n)
        .map(|i| (5.0 * ((i % n) as f64 / 17.0).sin() * ((i / n) as f64 / 23.0).cos()) as f32)
        .collect();
    let heights = HeightGrid {
        origin: [-100.0, 100.0],
        spacing: s,
        width: n,
        height: n,
        values,
    };
    (cam, pose, grid, heights)
}

/// The flat path's map: K R^T T on the grid, then the lens.
fn flat_map(cam: &Camera, pose: &Pose, grid: &OrthoGrid) -> Then<Homography, LensMap> {
    let (g, c) = (grid.gsd, pose.centre);
    let t = aerorect_core::Mat3::new(
        g,
        0.0,
        grid.top_left[0] + 0.5 * g - c[0],
        0.0,
        -g,
        grid.top_left[1] - 0.5 * g - c[1],
        0.0,
        0.0,
        -c[2],
    );
    let k = cam.intrinsics.pixel_from_camera();
    let h = Homography::new(k * pose.world_from_camera().transpose() * t).unwrap();
    let d = cam.distortion.clone().unwrap();
    Then(
        h,
        LensMap::within(cam.intrinsics, d, LensDirection::ObservedFromIdeal),
    )
}

fn ortho(c: &mut Criterion) {
    let (cam, pose, grid, heights) = setup();
    let src: Raster<u8> = textured_scene(cam.size, 3, 250.0, 1);
    let opts = WarpOptions {
        interp: Interp::Bilinear,
        ..Default::default()
    };
    let mut dst = Raster::<u8>::new(grid.size, 3).unwrap();
    let mut g = c.benchmark_group("ortho/rgb8-bilinear");
    g.throughput(Throughput::Elements(grid.size.pixels() as u64));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    let flat = flat_map(&cam, &pose, &grid);
    g.bench_function("flat-homography", |b| {
        b.iter(|| warp_into(&src, &flat, &opts, &mut dst).unwrap())
    });
    let dem = GroundMap {
        camera: cam.clone(),
        pose,
        grid,
        terrain: Terrain::Grid(heights),
    };
    g.bench_function("dem", |b| {
        b.iter(|| warp_into(&src, &dem, &opts, &mut dst).unwrap())
    });
    g.finish();
    heights_along(c);
    dem_range(c);
}

/// The heights of the ortho grid's rows over the height grid (1 m nodes, 20 output pixels
/// each): the bilinear lookup of `dem` alone.
fn heights_along(c: &mut Criterion) {
    let (_, _, grid, heights) = setup();
    let mut g = c.benchmark_group("terrain/heights-along");
    g.throughput(Throughput::Elements(grid.size.pixels() as u64));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    let mut xs = vec![0.0; grid.size.width];
    g.bench_function("rows", |b| {
        b.iter(|| {
            for r in 0..grid.size.height {
                let [x0, y] = grid.centre_of(0.0, r as f64);
                for (i, x) in xs.iter_mut().enumerate() {
                    *x = x0 + i as f64 * grid.gsd;
                }
                heights.heights_along(y, &mut xs);
            }
            xs[0]
        })
    });
    g.finish();
}

/// The lowest and highest heights of a DEM the size of the 1,000-frame flight's tie surface
/// (642 x 757 nodes, a few without a height), which each frame's plan over it reads.
fn dem_range(c: &mut Criterion) {
    let (w, h) = (642, 757);
    let mut values: Vec<f32> = (0..w * h)
        .map(|i| ((i * 7919) % 6000) as f32 * 0.01)
        .collect();
    values.iter_mut().step_by(997).for_each(|v| *v = f32::NAN);
    let dem = Dem {
        name: "bench".into(),
        values,
        width: w,
        height: h,
        top_left: [0.0, 0.0],
        cell_size: [2.0, -2.0],
        crs: Crs::from_epsg(32635).unwrap(),
    };
    let mut g = c.benchmark_group("terrain/range");
    g.throughput(Throughput::Elements((w * h) as u64));
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("642x757", |b| b.iter(|| dem.range()));
    g.finish();
}

criterion_group!(benches, ortho);
criterion_main!(benches);
