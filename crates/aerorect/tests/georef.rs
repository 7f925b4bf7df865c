//! Georeferenced orthos against independent truth: a frame simulated over synthetic hills by
//! marching every pixel's ray onto the terrain, and (extended) a real DJI photo downsampled 4x
//! against its full-size ortho.
#![allow(clippy::unwrap_used)]

use aerorect::core::{Camera, CameraRotation, ImageSize, Intrinsics, Mat3, RectifyLimits};
use aerorect::geo::{Crs, Dem, HeightGrid, Pose, Terrain, march_to_ground};
use aerorect::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use aerorect::raster::{AnyRaster, Interp, Raster, WarpOptions};
use std::sync::Arc;

const ORIGIN: [f64; 2] = [500_000.0, 5_970_000.0];

/// Hills of 50 m: 25 + 25 sin(x / 90) cos(y / 120), x and y from ORIGIN.
fn hill(x: f64, y: f64) -> f64 {
    25.0 + 25.0 * ((x - ORIGIN[0]) / 90.0).sin() * ((y - ORIGIN[1]) / 120.0).cos()
}

/// The ground's brightness: smooth texture of a few metres.
fn texture(x: f64, y: f64) -> f64 {
    let (x, y) = (x - ORIGIN[0], y - ORIGIN[1]);
    128.0 + 50.0 * (x / 2.1).sin() * (y / 2.9).cos() + 30.0 * ((x + y) / 3.7).sin()
}

fn utm35() -> Crs {
    Crs::from_proj_string("+proj=utm +zone=35 +datum=WGS84 +units=m +no_defs").unwrap()
}

/// A 2 m DEM of the hills over 1.2 x 1.2 km around ORIGIN.
fn dem() -> Dem {
    let (n, cell) = (600usize, 2.0);
    let top_left = [ORIGIN[0] - 600.0, ORIGIN[1] + 600.0];
    let values = (0..n * n)
        .map(|i| {
            let (c, r) = ((i % n) as f64, (i / n) as f64);
            hill(
                top_left[0] + (c + 0.5) * cell,
                top_left[1] - (r + 0.5) * cell,
            ) as f32
        })
        .collect();
    Dem {
        name: "hills".into(),
        values,
        width: n,
        height: n,
        top_left,
        cell_size: [cell, cell],
        crs: utm35(),
    }
}

/// The DEM's own heights as a terrain (node = cell centre): the truth frames are rendered over.
fn truth_of(dem: &Dem) -> Terrain {
    Terrain::Grid(HeightGrid {
        origin: [dem.top_left[0] + 1.0, dem.top_left[1] - 1.0],
        spacing: 2.0,
        width: 600,
        height: 600,
        values: dem.values.clone(),
    })
}

fn setup() -> (Camera, Pose) {
    let cam = Camera::new(
        Intrinsics::new(500.0, 500.0, 319.5, 239.5).unwrap(),
        None,
        ImageSize::new(640, 480),
    );
    let r = CameraRotation::dji_gimbal(20.0, -70.0, 0.0).unwrap();
    let pose = Pose::new([ORIGIN[0], ORIGIN[1], 100.0], r.ground_from_camera());
    (cam, pose)
}

/// The frame the camera records: each pixel's ray marched onto the DEM's terrain.
fn simulate(cam: &Camera, pose: &Pose, terrain: &Terrain) -> AnyRaster {
    let s = cam.size;
    let mut px = vec![0f32; s.pixels()];
    for v in 0..s.height {
        for u in 0..s.width {
            let ray = pose.world_direction(cam.ray_from_pixel(u as f64, v as f64).unwrap());
            let g = march_to_ground(pose, ray, terrain, (0.0, 50.0), 0.25).unwrap();
            px[v * s.width + u] = texture(g[0], g[1]) as f32;
        }
    }
    AnyRaster::F32(Raster::from_planes(s, vec![px]).unwrap())
}

fn plan(cam: &Camera, pose: Pose, ground: &Ground) -> OrthoPlan {
    plan_at(cam, pose, ground, 0.25)
}

fn plan_at(cam: &Camera, pose: Pose, ground: &Ground, gsd_m: f64) -> OrthoPlan {
    let world = utm35();
    let req = OrthoRequest {
        camera: cam,
        pose,
        world: &world,
        ground,
        gsd_m,
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

/// Median and 95th percentile of the distance (output pixels) between each output pixel's
/// centre and the ground its frame pixel really sees.
fn position_errors(p: &OrthoPlan, pose: &Pose, terrain: &Terrain) -> (f64, f64) {
    position_errors_in(p, pose, terrain, (0.0, 50.0))
}

/// [`position_errors`] over terrain whose heights lie in `range` (m).
fn position_errors_in(
    p: &OrthoPlan,
    pose: &Pose,
    terrain: &Terrain,
    range: (f64, f64),
) -> (f64, f64) {
    let g = p.grid;
    let mut e = Vec::new();
    for r in (0..g.size.height).step_by(7) {
        for c in (0..g.size.width).step_by(7) {
            let Some(f) = p.frame_pixel_of(c as f64, r as f64) else {
                continue;
            };
            if !(0.0..639.0).contains(&f[0]) || !(0.0..479.0).contains(&f[1]) {
                continue;
            }
            let ray = pose.world_direction(p.camera.ray_from_pixel(f[0], f[1]).unwrap());
            let hit = march_to_ground(pose, ray, terrain, range, 0.25).unwrap();
            let want = g.centre_of(c as f64, r as f64);
            e.push((hit[0] - want[0]).hypot(hit[1] - want[1]) / g.gsd);
        }
    }
    assert!(e.len() > 1000, "{} samples", e.len());
    e.sort_by(f64::total_cmp);
    (e[e.len() / 2], e[e.len() * 95 / 100])
}

/// Mean |ortho - true texture| over the valid output pixels.
fn intensity_error(p: &OrthoPlan, ortho: &AnyRaster) -> f64 {
    let AnyRaster::F32(o) = ortho else {
        panic!("f32 in, f32 out")
    };
    let g = p.grid;
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, &v) in o.plane(0).iter().enumerate() {
        if v.is_finite() {
            let w = g.centre_of((i % g.size.width) as f64, (i / g.size.width) as f64);
            sum += (v as f64 - texture(w[0], w[1])).abs();
            n += 1;
        }
    }
    assert!(n > 10_000);
    sum / n as f64
}

#[test]
fn dem_ortho_of_a_frame_over_hills_matches_the_truth_and_flat_does_not() {
    let dem = Arc::new(dem());
    let (cam, pose) = setup();
    let truth = truth_of(&dem);
    let frame = simulate(&cam, &pose, &truth);
    let on_dem = Ground::Dem {
        dem: Arc::clone(&dem),
        fallback: None,
        strict: true,
    };
    let p = plan(&cam, pose, &on_dem);
    let (median, p95) = position_errors(&p, &pose, &truth);
    eprintln!("DEM ortho: position error median {median:.4} px, 95% {p95:.4} px");
    // Occluded ground (behind a nearer hill) is the only place the frame sees something else.
    assert!(median < 0.01 && p95 < 0.5, "{median} {p95}");
    let flat = plan(&cam, pose, &Ground::Flat(25.0));
    let (fm, f95) = position_errors(&flat, &pose, &truth);
    eprintln!("flat ortho: position error median {fm:.2} px, 95% {f95:.2} px");
    assert!(fm > 5.0, "{fm}");
    let (ed, ef) = (
        intensity_error(&p, &p.run(&frame).unwrap()),
        intensity_error(&flat, &flat.run(&frame).unwrap()),
    );
    eprintln!("mean |ortho - truth|: DEM {ed:.2}, flat {ef:.2} grey levels");
    assert!(ed < 4.0 && ef > 4.0 * ed, "{ed} {ef}");
}

/// A frame's ortho from the kept reduced levels of its gray frame (as a flight's rounds render
/// it) is the ortho of its gray frame, bit for bit: over the DEM, on level ground and on level
/// ground through a lens, for a gray f32 frame and an RGB u8 one. Where the grid is less than
/// twice coarser than the frame, the levels do not serve (`None`).
#[test]
fn an_ortho_from_kept_levels_is_the_gray_orthos_bit_for_bit() {
    use aerorect::core::distortion::Distortion;
    use aerorect::motion::{gray, gray_levels};
    let dem = Arc::new(dem());
    let (cam, pose) = setup();
    let frame = simulate(&cam, &pose, &truth_of(&dem));
    let AnyRaster::F32(f) = &frame else {
        panic!("f32")
    };
    let bands = [1.0, 0.5, 0.25].map(|k| f.plane(0).iter().map(|v| (v * k) as u8).collect());
    let rgb = AnyRaster::U8(Raster::from_planes(cam.size, bands.to_vec()).unwrap());
    let mut lens = Distortion::zero("opencv").unwrap();
    let mut p = vec![0.0; lens.model().names().len()];
    (p[0], p[1]) = (-0.2, 0.04);
    lens.model_mut().set_params(&p);
    let lensed = Camera::new(cam.intrinsics, Some(lens), cam.size);
    let on_dem = Ground::Dem {
        dem: Arc::clone(&dem),
        fallback: None,
        strict: true,
    };
    let flat = Ground::Flat(25.0);
    let differing = |a: &Raster<f32>, b: &Raster<f32>| {
        let pairs = a.plane(0).iter().zip(b.plane(0));
        pairs.filter(|(x, y)| x.to_bits() != y.to_bits()).count()
    };
    for (name, camera, ground) in [
        ("dem", &cam, &on_dem),
        ("flat", &cam, &flat),
        ("flat, lens", &lensed, &flat),
    ] {
        for img in [&frame, &rgb] {
            let levels = gray_levels(img).unwrap();
            let coarse = plan_at(camera, pose, ground, 1.0);
            let AnyRaster::F32(want) = coarse.run(&AnyRaster::F32(gray(img).unwrap())).unwrap()
            else {
                panic!("f32")
            };
            let got = coarse
                .run_levels(&levels)
                .unwrap()
                .expect("levels serve at 1 m");
            assert_eq!(got.size(), want.size(), "{name}");
            assert_eq!(differing(&got, &want), 0, "{name}");
            assert!(want.plane(0).iter().any(|v| v.is_finite()), "{name}");
            let fine = plan_at(camera, pose, ground, 0.25);
            assert!(fine.run_levels(&levels).unwrap().is_none(), "{name}");
        }
    }
}

/// Ground falling away under an oblique frame's far field: the horizon cut planned on level
/// ground at the DEM's middle height lets the rays run on past the output size limit, so the
/// plan cuts again at the lowest ground under the frame. It keeps to the limit, and its pixels
/// still land where the frame sees them (marched onto the true terrain).
#[test]
fn far_field_over_falling_ground_keeps_to_the_output_limit() {
    // Level (0 m) to 200 m north of the camera, then falling 1 m in 8 to -100 m; 10 m cells.
    let fall = |y: f64| -((y - ORIGIN[1] - 200.0).max(0.0) / 8.0).min(100.0);
    let (n, cell) = (400usize, 10.0);
    let top_left = [ORIGIN[0] - 2000.0, ORIGIN[1] + 2000.0];
    let values: Vec<f32> = (0..n * n)
        .map(|i| fall(top_left[1] - ((i / n) as f64 + 0.5) * cell) as f32)
        .collect();
    let truth = Terrain::Grid(HeightGrid {
        origin: [top_left[0] + 0.5 * cell, top_left[1] - 0.5 * cell],
        spacing: cell,
        width: n,
        height: n,
        values: values.clone(),
    });
    let dem = Dem {
        name: "falling".into(),
        values,
        width: n,
        height: n,
        top_left,
        cell_size: [cell, cell],
        crs: utm35(),
    };
    let (cam, _) = setup();
    let r = CameraRotation::dji_gimbal(0.0, -20.0, 0.0).unwrap();
    let pose = Pose::new([ORIGIN[0], ORIGIN[1], 100.0], r.ground_from_camera());
    let (world, limit) = (utm35(), 1_000_000);
    let ground = Ground::Dem {
        dem: Arc::new(dem),
        fallback: None,
        strict: true,
    };
    let req = OrthoRequest {
        camera: &cam,
        pose,
        world: &world,
        ground: &ground,
        gsd_m: 1.0,
        limits: RectifyLimits {
            max_output_px: limit,
        },
        occlusion: false,
    };
    let p = plan_ortho(&req, WarpOptions::default()).unwrap();
    let size = p.grid.size;
    eprintln!("falling ground: {} x {} px", size.width, size.height);
    assert!(p.clipped && size.pixels() as u64 <= limit, "{size:?}");
    // The ground reached lies past where the terrain starts to fall.
    let north = p.footprint.iter().map(|q| q[1]).fold(f64::MIN, f64::max);
    assert!(north > ORIGIN[1] + 400.0, "{north}");
    let (median, p95) = position_errors_in(&p, &pose, &truth, (-100.0, 0.0));
    eprintln!("falling ground: position error median {median:.4} px, 95% {p95:.4} px");
    assert!(median < 0.05 && p95 < 0.5, "{median} {p95}");
}

/// The DEM's holes are refused with --strict and filled (with a warning) without it.
#[test]
fn dem_holes_warn_or_refuse() {
    let mut d = dem();
    for r in 280..320 {
        for c in 280..320 {
            d.values[r * 600 + c] = f32::NAN;
        }
    }
    let d = Arc::new(d);
    let (cam, pose) = setup();
    let world = utm35();
    let req = |g| OrthoRequest {
        camera: &cam,
        pose,
        world: &world,
        ground: g,
        gsd_m: 0.25,
        limits: RectifyLimits::default(),
        occlusion: false,
    };
    let strict = Ground::Dem {
        dem: Arc::clone(&d),
        fallback: Some(25.0),
        strict: true,
    };
    let e = plan_ortho(&req(&strict), WarpOptions::default())
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("hills") && e.contains("nodata") && e.contains("refused by strict"),
        "{e}"
    );
    let lenient = Ground::Dem {
        dem: d,
        fallback: Some(25.0),
        strict: false,
    };
    let p = plan_ortho(&req(&lenient), WarpOptions::default()).unwrap();
    assert!(
        p.warnings.iter().any(|w| w.contains("nodata")),
        "{:?}",
        p.warnings
    );
}

/// A DEM in another CRS (here geographic) is sampled through the projection: the same hills
/// described in longitude and latitude give the same ortho map to a few millimetres.
#[test]
fn dem_in_another_crs_is_reprojected() {
    let utm = dem();
    let wgs = Crs::wgs84();
    // Resample the hills onto a lon/lat grid covering the same ground.
    let ll0 = utm35()
        .transform(&wgs, ORIGIN[0] - 500.0, ORIGIN[1] + 500.0)
        .unwrap();
    let ll1 = utm35()
        .transform(&wgs, ORIGIN[0] + 500.0, ORIGIN[1] - 500.0)
        .unwrap();
    let (n, m) = (900usize, 900usize);
    let cell = [(ll1[0] - ll0[0]) / n as f64, (ll0[1] - ll1[1]) / m as f64];
    let values = (0..n * m)
        .map(|i| {
            let (c, r) = ((i % n) as f64, (i / n) as f64);
            let (lon, lat) = (ll0[0] + (c + 0.5) * cell[0], ll0[1] - (r + 0.5) * cell[1]);
            let p = wgs.transform(&utm35(), lon, lat).unwrap();
            hill(p[0], p[1]) as f32
        })
        .collect();
    let geo = Dem {
        name: "hills-lonlat".into(),
        values,
        width: n,
        height: m,
        top_left: ll0,
        cell_size: cell,
        crs: wgs,
    };
    let (cam, pose) = setup();
    let a = plan(
        &cam,
        pose,
        &Ground::Dem {
            dem: Arc::new(utm),
            fallback: None,
            strict: true,
        },
    );
    let b = plan(
        &cam,
        pose,
        &Ground::Dem {
            dem: Arc::new(geo),
            fallback: None,
            strict: true,
        },
    );
    let mut worst: f64 = 0.0;
    for (c, r) in [(100.0, 100.0), (300.0, 500.0), (600.0, 200.0)] {
        let (Some(x), Some(y)) = (a.frame_pixel_of(c, r), b.frame_pixel_of(c, r)) else {
            continue;
        };
        worst = worst.max((x[0] - y[0]).hypot(x[1] - y[1]));
    }
    assert!(worst < 0.1, "{worst} px");
    let _ = Mat3::identity();
}

/// Extended: a real DJI photo (with the tags of a calibrated camera added), downsampled 4x,
/// rectifies onto its full-size ortho: the same ground grid at the same GSD and every output
/// pixel from the same place of the scene.
#[test]
fn downsampled_photo_lands_on_the_full_size_ortho() {
    use aerorect::drone::{DroneOptions, plan_from_metadata};
    let Some(p) = aerorect_testkit::shared_data("drone-xmp/DJI_0028.JPG") else {
        return;
    };
    let mut meta = aerorect::io::read_photo_metadata(&p).unwrap();
    meta.width = Some(4000);
    meta.height = Some(2250);
    meta.dji.dewarp_data =
        Some("2018-01-01;3066.0,3066.0,12.5,-9.0,-0.27,0.11,0.0005,-0.0003,-0.02".into());
    let full = ImageSize::new(4000, 2250);
    let small = ImageSize::new(1000, 562);
    let opts = DroneOptions {
        gsd_m: Some(0.4),
        ..Default::default()
    };
    let (pf, _) = plan_from_metadata(&meta, full, &opts, "full").unwrap();
    let (ps, info) = plan_from_metadata(&meta, small, &opts, "small").unwrap();
    assert!(info.warnings.iter().any(|w| w.contains("4000 x 2250")));
    // One global grid: the two grids differ by whole pixels (the corner pixels' centres of the
    // small image lie 1.5 full-size pixels inside the big one's).
    for k in 0..2 {
        let d = (pf.grid.top_left[k] - ps.grid.top_left[k]) / 0.4;
        assert!((d - d.round()).abs() < 1e-6, "{d}");
    }
    let mut worst: f64 = 0.0;
    for r in (0..pf.grid.size.height.min(ps.grid.size.height)).step_by(97) {
        for c in (0..pf.grid.size.width.min(ps.grid.size.width)).step_by(97) {
            let dc = (pf.grid.top_left[0] - ps.grid.top_left[0]) / 0.4;
            let dr = (ps.grid.top_left[1] - pf.grid.top_left[1]) / 0.4;
            let (Some(a), Some(b)) = (
                pf.frame_pixel_of(c as f64, r as f64),
                ps.frame_pixel_of(c as f64 + dc, r as f64 + dr),
            ) else {
                continue;
            };
            if !(0.0..4000.0).contains(&a[0]) || !(0.0..2250.0).contains(&a[1]) {
                continue;
            }
            // Small pixel of a full-size pixel: (p + 0.5) / 4 - 0.5, in small-image pixels.
            let want = [
                (a[0] + 0.5) / 4.0 - 0.5,
                (a[1] + 0.5) * 562.0 / 2250.0 - 0.5,
            ];
            worst = worst.max((b[0] - want[0]).hypot(b[1] - want[1]));
        }
    }
    eprintln!("downsampled vs full: worst {worst:.4} small-image px");
    assert!(worst < 0.25, "{worst}");
}

/// A frame low and oblique over the hills, planned at 1 m with the occlusion test on (the hills
/// hide each other): the plan, its pose and camera.
fn occluded_plan() -> (OrthoPlan, Pose, Camera) {
    let (cam, _) = setup();
    let r = CameraRotation::dji_gimbal(20.0, -30.0, 0.0).unwrap();
    let pose = Pose::new([ORIGIN[0], ORIGIN[1], 60.0], r.ground_from_camera());
    let world = utm35();
    let ground = Ground::Dem {
        dem: Arc::new(dem()),
        fallback: None,
        strict: false,
    };
    let req = OrthoRequest {
        camera: &cam,
        pose,
        world: &world,
        ground: &ground,
        gsd_m: 1.0,
        limits: RectifyLimits {
            max_output_px: 4_000_000,
        },
        occlusion: true,
    };
    let p = plan_ortho(&req, WarpOptions::default()).unwrap();
    (p, pose, cam)
}

/// With --occlusion, the output pixels hidden behind a nearer hill are exactly those whose frame
/// pixel sees other ground.
#[test]
fn occlusion_hides_the_ground_behind_the_hills() {
    let (p, pose, cam) = occluded_plan();
    let truth = truth_of(&dem());
    let (mut agree, mut total, mut hidden) = (0usize, 0usize, 0usize);
    let g = p.grid;
    for r in (0..g.size.height).step_by(5) {
        for c in (0..g.size.width).step_by(5) {
            let Some(plain) = p.frame_pixel_of_unmasked(c as f64, r as f64) else {
                continue;
            };
            if !(0.0..639.0).contains(&plain[0]) || !(0.0..479.0).contains(&plain[1]) {
                continue;
            }
            let ray = pose.world_direction(cam.ray_from_pixel(plain[0], plain[1]).unwrap());
            let hit = march_to_ground(&pose, ray, &truth, (0.0, 50.0), 0.25).unwrap();
            let want = g.centre_of(c as f64, r as f64);
            let seen_elsewhere = (hit[0] - want[0]).hypot(hit[1] - want[1]) > 3.0 * g.gsd;
            let masked = p.frame_pixel_of(c as f64, r as f64).is_none();
            hidden += masked as usize;
            agree += (seen_elsewhere == masked) as usize;
            total += 1;
        }
    }
    eprintln!("occlusion: {hidden} of {total} hidden, {agree} agree with ray marching");
    assert!(hidden > total / 50, "{hidden} of {total}");
    assert!(agree as f64 > 0.97 * total as f64, "{agree} of {total}");
}

/// A mosaic's lattice scores over a frame that hides ground (hills, `occlusion`): the frame
/// covers exactly the cells its exact scores say, hidden ones left out, while most cells are
/// blended. Here every block that meets hidden ground has a node that reads it (a mutant
/// without the block-level `hides_any` test passes); that test is for patches inside a block.
#[test]
fn lattice_scores_leave_out_the_hidden_ground_cell_by_cell() {
    use aerorect::mosaic::{MosaicFrame, MosaicOptions, MosaicPlan};
    let (p, _, _) = occluded_plan();
    let g = p.grid.size;
    assert!(p.hides_any([0, g.width - 1], [0, g.height - 1]));
    let frame = MosaicFrame {
        path: "hills.tif".into(),
        plan: p,
        nadir_xy: [ORIGIN[0], ORIGIN[1]],
        height_m: 60.0,
    };
    let plan = MosaicPlan::new(vec![frame], 1.0, MosaicOptions::default()).unwrap();
    let size = plan.grid.size;
    let (mut hidden, mut covered, mut blended) = (0, 0, 0);
    for r in 0..size.height {
        for c in 0..size.width {
            let (lattice, exact) = (plan.lattice_score_at(0, c, r), plan.score_at(0, c, r));
            assert_eq!(lattice.is_some(), exact.is_some(), "cell ({c}, {r})");
            let unmasked = plan.frames[0]
                .plan
                .frame_pixel_of_unmasked(c as f64, r as f64);
            let masked = plan.frames[0].plan.frame_pixel_of(c as f64, r as f64);
            hidden += (unmasked
                .is_some_and(|q| (0.0..639.0).contains(&q[0]) && (0.0..479.0).contains(&q[1]))
                && masked.is_none()) as usize;
            covered += exact.is_some() as usize;
            blended += (lattice != exact) as usize;
        }
    }
    eprintln!("{covered} cells covered, {hidden} hidden inside the frame, {blended} blended");
    assert!(
        hidden > 1000 && covered > 5 * hidden,
        "{hidden} hidden, {covered} covered"
    );
    assert!(blended > covered / 2, "{blended} of {covered} blended");
}
