//! Photos rectified from metadata: camera sources, UTM against PROJ, the georeferenced grid
//! against an independent ray-ground intersection, and (extended) the real DJI frames.
#![allow(clippy::unwrap_used)]

use aerorect::core::{CameraRotation, ImageSize, Intrinsics};
use aerorect::drone::{
    CameraSource, DroneOptions, camera_from_metadata, plan_from_metadata, rectify_photo,
};
use aerorect::io::PhotoMetadata;

fn dji(yaw: f64, pitch: f64, roll: f64) -> PhotoMetadata {
    let mut m = PhotoMetadata {
        make: Some("DJI".into()),
        model: Some("FC220".into()),
        focal_length_mm: Some(4.73),
        focal_length_35mm: Some(26.0),
        latitude_deg: Some(53.9),
        longitude_deg: Some(27.55),
        ..Default::default()
    };
    m.dji.gimbal_yaw_deg = Some(yaw);
    m.dji.gimbal_pitch_deg = Some(pitch);
    m.dji.gimbal_roll_deg = Some(roll);
    m.dji.relative_altitude_m = Some(100.0);
    m.dji.absolute_altitude_m = Some(330.0);
    m
}

const SIZE: ImageSize = ImageSize {
    width: 4000,
    height: 2250,
};

#[test]
fn camera_sources_in_order_of_trust() {
    let m = dji(0.0, -90.0, 0.0);
    let c = camera_from_metadata(&m, SIZE, "x").unwrap();
    assert_eq!(
        c.source,
        CameraSource::SensorDatabase("DJI FC220".into(), 6.17)
    );
    // 4.73 mm over a 6.17 mm wide sensor of 4000 px (the 16:9 mode keeps the width).
    assert!((c.camera.intrinsics.fx - 4.73 / (6.17 / 4000.0)).abs() < 1e-9);
    let mut unknown = m.clone();
    unknown.model = Some("XYZ".into());
    let c = camera_from_metadata(&unknown, SIZE, "x").unwrap();
    assert_eq!(c.source, CameraSource::Equivalent35mm);
    let want = 26.0 * 4000f64.hypot(2250.0) / 36f64.hypot(24.0);
    assert!((c.camera.intrinsics.fx - want).abs() < 1e-9);
    assert_eq!(c.warnings.len(), 1);
    let mut cal = m.clone();
    cal.dji.calibrated_focal_length_px = Some(3050.0);
    cal.dji.calibrated_optical_center_x_px = Some(2010.0);
    cal.dji.calibrated_optical_center_y_px = Some(1120.0);
    let c = camera_from_metadata(&cal, SIZE, "x").unwrap();
    assert_eq!(c.source, CameraSource::DjiCalibrated);
    // DJI's optical centre is measured from the outer corner: 2010 there is 2009.5 here.
    assert_eq!(c.camera.intrinsics.cx, 2009.5);
    // DewarpData carries the lens too, so it is preferred (as Orthority does).
    let mut dewarp = cal.clone();
    dewarp.dji.dewarp_data =
        Some("2018-09-04;3678.9,3671.5,10.5,-17.2,-0.26,0.11,0.001,-0.0003,-0.23".into());
    let c = camera_from_metadata(&dewarp, SIZE, "x").unwrap();
    assert_eq!(c.source, CameraSource::DewarpData);
    let k = c.camera.intrinsics;
    assert_eq!((k.fx, k.fy), (3678.9, 3671.5));
    assert!((k.cx - (1999.5 + 10.5)).abs() < 1e-12);
    assert!(c.camera.distortion.is_some());
    unknown.focal_length_35mm = None;
    let e = camera_from_metadata(&unknown, SIZE, "DJI_9.JPG")
        .unwrap_err()
        .full_message();
    assert!(e.contains("DJI_9.JPG") && e.contains("XYZ"), "{e}");
    // A DewarpData of three numbers is refused, naming the photo and the text.
    let mut short = dewarp.clone();
    short.dji.dewarp_data = Some("2018;1,2,3".into());
    let e = camera_from_metadata(&short, SIZE, "DJI_8.JPG")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("DJI_8.JPG") && e.contains("'2018;1,2,3' has 3 numbers"),
        "{e}"
    );
}

/// Pixel-unit tags written for 4000 x 2250 on a 1000 x 562 image: focal lengths divided by 4,
/// the principal point moved with the pixel-centre convention; another aspect ratio refused.
#[test]
fn calibration_tags_are_scaled_to_the_decoded_size() {
    let mut m = dji(0.0, -90.0, 0.0);
    m.width = Some(4000);
    m.height = Some(2250);
    m.dji.dewarp_data = Some("2018;3000,3000,10,-20,-0.27,0.1,0,0,0".into());
    let small = ImageSize::new(1000, 562);
    let c = camera_from_metadata(&m, small, "x").unwrap();
    let k = c.camera.intrinsics;
    assert!((k.fx - 750.0).abs() < 1e-9 && (k.fy - 3000.0 * 562.0 / 2250.0).abs() < 1e-9);
    assert!((k.cx - ((1999.5 + 10.0 + 0.5) / 4.0 - 0.5)).abs() < 1e-9);
    assert_eq!(c.tagged_size, [4000, 2250]);
    let e = camera_from_metadata(&m, ImageSize::new(1000, 1000), "IMG_1.JPG")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("IMG_1.JPG") && e.contains("4000x2250") && e.contains("1000x1000"),
        "{e}"
    );
    // Without EXIF dimensions, twice the calibrated optical centre gives the tagged size.
    let mut c2 = dji(0.0, -90.0, 0.0);
    c2.dji.calibrated_focal_length_px = Some(3000.0);
    c2.dji.calibrated_optical_center_x_px = Some(2000.0);
    c2.dji.calibrated_optical_center_y_px = Some(1125.0);
    let c = camera_from_metadata(&c2, ImageSize::new(1000, 563), "x").unwrap();
    // A whole factor of 4 (the odd height rounds: 2250 / 4 = 562.5).
    assert_eq!(c.tagged_size, [4000, 2252]);
    assert!((c.camera.intrinsics.fx - 750.0).abs() < 1e-9);
}

/// PROJ's meridian convergence at (27.55 E, 53.9 N) in UTM 35N (pyproj 3.7.2,
/// `Proj(proj='utm', zone=35).get_factors(27.55, 53.9).meridian_convergence`).
const CONVERGENCE_DEG: f64 = 0.4443992080546033;

/// Every output pixel's ground position (from the GeoTIFF's geotransform) equals the ground
/// point its source pixel's ray hits, intersected independently in ENU and turned onto the
/// grid by PROJ's convergence.
#[test]
fn georeferenced_grid_matches_ray_ground_intersection() {
    let g = -CONVERGENCE_DEG.to_radians();
    let grid_from_enu =
        nalgebra::Matrix3::new(g.cos(), g.sin(), 0.0, -g.sin(), g.cos(), 0.0, 0.0, 0.0, 1.0);
    for (yaw, pitch, roll) in [(0.0, -90.0, 0.0), (37.0, -60.0, 0.0), (-117.0, -35.0, 2.0)] {
        let m = dji(yaw, pitch, roll);
        let opts = DroneOptions {
            gsd_m: Some(0.25),
            ..Default::default()
        };
        let (plan, info) = plan_from_metadata(&m, SIZE, &opts, "x").unwrap();
        assert!((info.convergence_deg - CONVERGENCE_DEG).abs() < 1e-5);
        let k: Intrinsics = plan.camera.intrinsics;
        let r = grid_from_enu
            * *CameraRotation::dji_gimbal(yaw, pitch, roll)
                .unwrap()
                .ground_from_camera();
        let size = plan.grid.size;
        for (c, row) in [
            (10usize, 10usize),
            (size.width / 2, size.height / 2),
            (size.width - 5, size.height / 3),
        ] {
            let Some(src) = plan.frame_pixel_of(c as f64, row as f64) else {
                continue;
            };
            let ray =
                r * nalgebra::Vector3::new((src[0] - k.cx) / k.fx, -(src[1] - k.cy) / k.fy, -1.0);
            if ray.z >= 0.0 {
                continue;
            }
            let t = 100.0 / -ray.z;
            let want = [
                info.easting_northing_m[0] + t * ray.x,
                info.easting_northing_m[1] + t * ray.y,
            ];
            let got = info.geo.ground_of_pixel(c as f64, row as f64);
            assert!(
                (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
                "{yaw} {pitch}: {got:?} vs {want:?}"
            );
        }
        // The grid is aligned to multiples of the GSD.
        for v in info.geo.top_left {
            assert!((v / 0.25 - (v / 0.25).round()).abs() < 1e-6);
        }
    }
}

/// DJI gimbal angles are world-frame: the aircraft's angles must not change the result.
#[test]
fn flight_angles_are_not_composed_on_the_gimbal() {
    let a = dji(117.6, -19.0, 0.0);
    let mut b = a.clone();
    b.dji.flight_roll_deg = Some(2.0);
    b.dji.flight_pitch_deg = Some(2.8);
    b.dji.flight_yaw_deg = Some(117.6);
    let (pa, _) = plan_from_metadata(&a, SIZE, &DroneOptions::default(), "a").unwrap();
    let (pb, _) = plan_from_metadata(&b, SIZE, &DroneOptions::default(), "b").unwrap();
    assert_eq!(pa.grid, pb.grid);
    assert_eq!(
        pa.frame_pixel_of(100.0, 200.0),
        pb.frame_pixel_of(100.0, 200.0)
    );
}

/// A lever arm moves the ortho by the arm turned into the world; a boresight turns the view.
#[test]
fn lever_arm_shifts_the_ground_by_the_arm() {
    let a = dji(0.0, -90.0, 0.0);
    let mut b = a.clone();
    (
        b.dji.flight_yaw_deg,
        b.dji.flight_pitch_deg,
        b.dji.flight_roll_deg,
    ) = (Some(90.0), Some(0.0), Some(0.0));
    let opts = DroneOptions {
        gsd_m: Some(0.5),
        ..Default::default()
    };
    let arm = DroneOptions {
        mounting: aerorect::geo::Mounting::from_angles([0.0; 3], [1.0, 0.0, 0.0]),
        ..opts.clone()
    };
    let (_, ia) = plan_from_metadata(&b, SIZE, &opts, "a").unwrap();
    let (_, ib) = plan_from_metadata(&b, SIZE, &arm, "b").unwrap();
    // Body x forward with the aircraft heading east: one metre true east, which in grid axes
    // (turned clockwise by the convergence) points a little north of grid east.
    let d = [
        ib.pose.centre[0] - ia.pose.centre[0],
        ib.pose.centre[1] - ia.pose.centre[1],
    ];
    let g = CONVERGENCE_DEG.to_radians();
    assert!(
        (d[0] - g.cos()).abs() < 1e-6 && (d[1] - g.sin()).abs() < 1e-6,
        "{d:?}"
    );
    let _ = a;
}

/// A reversed gimbal (roll 180 at nadir, GimbalReverse) sees the same ground upside down: the
/// same footprint, every ground point at the frame pixel mirrored through the centre.
#[test]
fn reversed_gimbal_sees_the_same_ground_turned_half_a_turn() {
    let (n, r) = (dji(30.0, -90.0, 0.0), dji(30.0, -90.0, 180.0));
    let opts = DroneOptions {
        gsd_m: Some(0.5),
        ..Default::default()
    };
    let (pn, _) = plan_from_metadata(&n, SIZE, &opts, "n").unwrap();
    let (pr, _) = plan_from_metadata(&r, SIZE, &opts, "r").unwrap();
    assert_eq!(pn.grid, pr.grid);
    let (w, h) = (SIZE.width as f64 - 1.0, SIZE.height as f64 - 1.0);
    for (c, row) in [(50.0, 60.0), (200.0, 100.0)] {
        let (a, b) = (
            pn.frame_pixel_of(c, row).unwrap(),
            pr.frame_pixel_of(c, row).unwrap(),
        );
        assert!((a[0] - (w - b[0])).abs() < 1e-6 && (a[1] - (h - b[1])).abs() < 1e-6);
    }
}

/// Omega-phi-kappa poses (the world CRS's own axes) agree with the DJI adapter: the DJI frame's
/// pose exported as OPK and read back gives the same ortho.
#[test]
fn opk_poses_agree_with_the_dji_adapter() {
    let m = dji(-64.9, -24.5, 0.0);
    let opts = DroneOptions {
        gsd_m: Some(0.25),
        ground_height_m: Some(230.0),
        ..Default::default()
    };
    let (pd, info) = plan_from_metadata(&m, SIZE, &opts, "d").unwrap();
    let rot = CameraRotation::from_matrix(info.pose.world_from_camera()).unwrap();
    let [omega, phi, kappa] = rot.to_omega_phi_kappa();
    let c = info.pose.centre;
    let pose = aerorect::io::PoseRecord {
        filename: "d".into(),
        x: c[0],
        y: c[1],
        z: c[2],
        omega,
        phi,
        kappa,
    };
    let crs = aerorect::geo::Crs::utm_for(27.55, 53.9).unwrap();
    assert_eq!(crs, aerorect::geo::Crs::from_epsg(32635).unwrap());
    let posed = DroneOptions {
        crs: Some(crs),
        ..opts
    };
    let (pp, _) = aerorect::drone::plan_from_pose(&pose, &m, SIZE, &posed, "d").unwrap();
    assert_eq!(pd.grid, pp.grid);
    for (col, row) in [(10.0, 10.0), (400.0, 300.0)] {
        let (a, b) = (pd.frame_pixel_of(col, row), pp.frame_pixel_of(col, row));
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!(
            (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
            "{a:?} {b:?}"
        );
    }
}

#[test]
fn height_from_ground_elevation_and_missing_fields() {
    let m = dji(0.0, -90.0, 0.0);
    let opts = DroneOptions {
        ground_height_m: Some(250.0),
        ..Default::default()
    };
    let (_, info) = plan_from_metadata(&m, SIZE, &opts, "x").unwrap();
    assert_eq!(info.height_m, 80.0);
    let mut none = m.clone();
    none.dji.gimbal_pitch_deg = None;
    let e = plan_from_metadata(&none, SIZE, &DroneOptions::default(), "f.jpg")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("f.jpg") && e.contains("GimbalPitchDegree"),
        "{e}"
    );
    let mut nogps = m.clone();
    nogps.latitude_deg = None;
    assert!(
        plan_from_metadata(&nogps, SIZE, &DroneOptions::default(), "x")
            .unwrap_err()
            .full_message()
            .contains("GPS")
    );
    let opts = DroneOptions {
        ground_height_m: Some(400.0),
        ..Default::default()
    };
    assert!(
        plan_from_metadata(&m, SIZE, &opts, "x")
            .unwrap_err()
            .full_message()
            .contains("not positive")
    );
}

use aerorect_testkit::shared_data as shared;

/// Extended: a real DJI frame's metadata, the GeoTIFF read back, and the camera position
/// inside the nadir frame's footprint.
#[test]
fn real_dji_frame_geotiff_reads_back() {
    let Some(p) = shared("drone-xmp/DJI_0010.JPG") else {
        return;
    };
    let meta = aerorect::io::read_photo_metadata(&p).unwrap();
    assert_eq!(meta.model.as_deref(), Some("FC220"));
    assert_eq!(meta.dji.gimbal_yaw_deg, Some(37.1));
    assert_eq!(meta.dji.relative_altitude_m, Some(98.9));
    assert!(
        (meta.latitude_deg.unwrap() - 53.9).abs() < 0.1
            && (meta.longitude_deg.unwrap() - 27.55).abs() < 0.1
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("n.tif");
    let opts = DroneOptions {
        gsd_m: Some(0.2),
        ..Default::default()
    };
    let r = rectify_photo(&p, &out, &opts, None).unwrap();
    let geo = aerorect::io::read_georeference(&out).unwrap().unwrap();
    assert_eq!(geo, r.info.geo);
    assert_eq!(geo.crs.epsg(), Some(32635));
    let img = aerorect::io::read_image(&out).unwrap();
    assert_eq!([img.size().width, img.size().height], r.output_size);
    let [e, n] = r.info.easting_northing_m;
    let [x0, y0] = geo.top_left;
    assert!(e > x0 && e < x0 + 0.2 * img.size().width as f64);
    assert!(n < y0 && n > y0 - 0.2 * img.size().height as f64);
}

/// Extended: 0030 and 0031 (one hover point): the registration's homography against the one
/// the gimbal angles predict, K R31^T R30 K^-1, at the centre of 0030.
#[test]
fn gimbal_angles_predict_the_registered_homography() {
    let (Some(a), Some(b)) = (
        shared("drone-xmp/DJI_0030.JPG"),
        shared("drone-xmp/DJI_0031.JPG"),
    ) else {
        return;
    };
    let (ma, mb) = (
        aerorect::io::read_photo_metadata(&a).unwrap(),
        aerorect::io::read_photo_metadata(&b).unwrap(),
    );
    let k = camera_from_metadata(&ma, SIZE, "a")
        .unwrap()
        .camera
        .intrinsics;
    let (ra, rb) = (
        aerorect::drone::rotation_from_metadata(&ma, "a").unwrap(),
        aerorect::drone::rotation_from_metadata(&mb, "b").unwrap(),
    );
    let km = k.pixel_from_camera();
    let predicted =
        km * rb.ground_from_camera().transpose() * ra.ground_from_camera() * k.camera_from_pixel();
    let p = predicted * nalgebra::Vector3::new(1999.5, 1124.5, 1.0);
    let p = [p.x / p.z, p.y / p.z];
    let img = aerorect::motion::gray(&aerorect::io::read_image(&b).unwrap()).unwrap();
    let reference = aerorect::motion::gray(&aerorect::io::read_image(&a).unwrap()).unwrap();
    let reg = aerorect::register::register(&img, &reference, &Default::default()).unwrap();
    let q = reg.image_from_ref.map(1999.5, 1124.5).unwrap();
    let d = (p[0] - q[0]).hypot(p[1] - q[1]);
    eprintln!("gimbal-predicted {p:?}, registered {q:?}: {d:.1} px apart");
    // About 1 degree of gimbal-angle error at f = 3066 px is 54 px.
    assert!(d < 110.0, "{d}");
}

/// Two GeoTIFFs on one grid whose content is offset by a known whole number of pixels: the
/// overlap measurement gives that offset, in pixels and in metres.
#[test]
fn overlap_shift_measures_a_known_offset() {
    use aerorect::io::{GeoReference, write_image_geo};
    use aerorect::raster::{AnyRaster, Raster};
    let big: Raster<u8> = aerorect_testkit::textured_scene(ImageSize::new(600, 600), 1, 200.0, 7);
    let crop = |x0: usize, y0: usize| {
        let p: Vec<u8> = (0..512 * 512)
            .map(|i| big.plane(0)[(y0 + i / 512) * 600 + x0 + i % 512])
            .collect();
        AnyRaster::U8(Raster::from_planes(ImageSize::new(512, 512), vec![p]).unwrap())
    };
    let geo = GeoReference {
        crs: aerorect::geo::Crs::from_epsg(32635).unwrap(),
        pixel_size: [0.5, 0.5],
        top_left: [1000.0, 2000.0],
        rotation: [0.0, 0.0],
        nodata: Some(0.0),
    };
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.tif"), dir.path().join("b.tif"));
    write_image_geo(&a, &crop(50, 50), Some(&geo)).unwrap();
    // B(c, r) = A(c - 3, r + 2): a feature at (x, y) in A is at (x + 3, y - 2) in B.
    write_image_geo(&b, &crop(47, 52), Some(&geo)).unwrap();
    let r = aerorect::drone::overlap_shift(&a, &b, 128).unwrap();
    assert_eq!(r.patches, 16);
    assert!(
        (r.median_px[0] - 3.0).abs() < 0.05 && (r.median_px[1] + 2.0).abs() < 0.05,
        "{:?}",
        r.median_px
    );
    assert!(
        (r.median_m[0] - 1.5).abs() < 0.03 && (r.median_m[1] - 1.0).abs() < 0.03,
        "{:?}",
        r.median_m
    );
}
