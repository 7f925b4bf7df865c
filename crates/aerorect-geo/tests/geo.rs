//! Georeferencing against independent results: PROJ's meridian convergence (stored), ray
//! intersection as the inverse of projection, and a closed-form flat-ground homography.

#![allow(clippy::unwrap_used)]

use aerorect_core::{Camera, CameraRotation, ImageSize, Intrinsics, Vec3};
use aerorect_geo::{
    Crs, GroundMap, HeightGrid, OrthoGrid, Pose, Terrain, convergence_deg, grid_from_enu,
    march_to_ground,
};
use aerorect_raster::PixelMap;
use approx::assert_abs_diff_eq;

/// pyproj 3.7.2 (PROJ 9): `Proj(proj='utm', zone=Z, south=S, datum='WGS84')
/// .get_factors(lon, lat).meridian_convergence`.
const PROJ_CONVERGENCE: [(f64, f64, &str, f64); 5] = [
    (
        121.0,
        24.7,
        "+proj=utm +zone=51 +datum=WGS84",
        -0.8360191136266517,
    ),
    (
        27.55,
        53.9,
        "+proj=utm +zone=35 +datum=WGS84",
        0.4443992080546033,
    ),
    (
        -70.6,
        -33.4,
        "+proj=utm +zone=19 +south +datum=WGS84",
        0.8809310373794418,
    ),
    (
        152.9,
        -27.5,
        "+proj=utm +zone=56 +south +datum=WGS84",
        0.0461748988090804,
    ),
    (
        -4.5,
        68.0,
        "+proj=utm +zone=30 +datum=WGS84",
        -1.390820493470249,
    ),
];

#[test]
fn convergence_matches_proj_in_both_hemispheres() {
    for (lon, lat, def, expected) in PROJ_CONVERGENCE {
        let crs = Crs::from_proj_string(def).unwrap();
        let got = convergence_deg(&crs, lon, lat).unwrap();
        assert_abs_diff_eq!(got, expected, epsilon = 2e-5);
    }
}

#[test]
fn convergence_holds_for_a_transverse_mercator_with_west_south_axes() {
    // South Africa's Lo25 (the NGI data's CRS): pyproj gives 3.242657481866681 degrees at
    // (19.2 E, 33.9 S) for '+proj=tmerc +lon_0=25 +k=1 +axis=wsu +ellps=WGS84'. proj4rs keeps
    // the axes east-north, so the same angle comes out of the east-north form.
    let crs = Crs::from_proj_string(
        "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m",
    )
    .unwrap();
    assert_abs_diff_eq!(
        convergence_deg(&crs, 19.2, -33.9).unwrap(),
        3.242657481866681,
        epsilon = 2e-5
    );
}

#[test]
fn grid_from_enu_sends_true_north_along_the_projected_meridian() {
    let (lon, lat) = (121.0, 24.7);
    let crs = Crs::utm_for(lon, lat).unwrap();
    let epsg = crs.epsg().unwrap();
    assert_eq!(epsg, 32651);
    let m = grid_from_enu(&crs, lon, lat).unwrap();
    let north = m * Vec3::new(0.0, 1.0, 0.0);
    let a = crs.from_lon_lat(lon, lat).unwrap();
    let b = crs.from_lon_lat(lon, lat + 0.01).unwrap();
    let along = Vec3::new(b[0] - a[0], b[1] - a[1], 0.0).normalize();
    assert_abs_diff_eq!(north.dot(&along), 1.0, epsilon = 1e-9);
    // West of the central meridian in the north, true north leans east of grid north.
    assert!(north.x > 0.01);
}

fn camera() -> Camera {
    Camera::new(
        Intrinsics::new(800.0, 800.0, 319.5, 239.5).unwrap(),
        None,
        ImageSize::new(640, 480),
    )
}

fn oblique_pose(centre_z: f64) -> Pose {
    let r = CameraRotation::dji_gimbal(30.0, -55.0, 0.0).unwrap();
    Pose::from_enu(
        [1000.0, 2000.0, centre_z],
        &r,
        &aerorect_core::Mat3::identity(),
    )
}

fn hills() -> HeightGrid {
    // Hills of 50 m on a 10 m grid over 3 x 3 km around (1000, 2000).
    let (w, h, s) = (301, 301, 10.0);
    let origin = [-500.0, 3500.0];
    let mut values = Vec::with_capacity(w * h);
    for r in 0..h {
        for c in 0..w {
            let (x, y) = (origin[0] + c as f64 * s, origin[1] - r as f64 * s);
            values.push((25.0 + 25.0 * (x / 170.0).sin() * (y / 230.0).cos()) as f32);
        }
    }
    HeightGrid {
        origin,
        spacing: s,
        width: w,
        height: h,
        values,
    }
}

#[test]
fn dem_map_is_the_inverse_of_marching_rays_onto_the_terrain() {
    let terrain = Terrain::Grid(hills());
    let pose = oblique_pose(100.0);
    let cam = camera();
    let grid = OrthoGrid {
        top_left: [900.0, 2200.0],
        gsd: 0.25,
        size: ImageSize::new(800, 800),
    };
    let map = GroundMap {
        camera: cam.clone(),
        pose,
        grid,
        terrain: terrain.clone(),
    };
    // Frame pixel -> first terrain hit along its ray -> output position -> back to the frame.
    for v in (0..480).step_by(60) {
        for u in (0..640).step_by(80) {
            let (u, v) = (u as f64 + 0.3, v as f64 + 0.7);
            let ray = pose.world_direction(cam.ray_from_pixel(u, v).unwrap());
            let g = march_to_ground(&pose, ray, &terrain, (0.0, 50.0), 1.0).unwrap();
            let c = (g[0] - grid.top_left[0]) / grid.gsd - 0.5;
            let r = (grid.top_left[1] - g[1]) / grid.gsd - 0.5;
            let p = map.source_of(c, r).unwrap();
            assert_abs_diff_eq!(p[0], u, epsilon = 1e-6);
            assert_abs_diff_eq!(p[1], v, epsilon = 1e-6);
        }
    }
}

#[test]
fn flat_map_is_the_closed_form_ground_homography() {
    // Flat ground at z = 12: pixel = K R^T (P - C), P = (x0 + (c + 0.5) g, y0 - (r + 0.5) g, 12).
    let pose = oblique_pose(112.0);
    let cam = camera();
    let grid = OrthoGrid {
        top_left: [950.0, 2150.0],
        gsd: 0.5,
        size: ImageSize::new(300, 300),
    };
    let map = GroundMap {
        camera: cam.clone(),
        pose,
        grid,
        terrain: Terrain::Flat(12.0),
    };
    let r_t = pose.world_from_camera().transpose();
    let k = cam.intrinsics.pixel_from_camera();
    let (mut xs, mut ys) = (vec![0.0; 300], vec![0.0; 300]);
    map.source_row(77, 0, &mut xs, &mut ys);
    for c in [0usize, 13, 150, 299] {
        let p = Vec3::new(
            950.0 + (c as f64 + 0.5) * 0.5 - 1000.0,
            2150.0 - 77.5 * 0.5 - 2000.0,
            12.0 - 112.0,
        );
        let h = k * (r_t * p);
        assert_abs_diff_eq!(xs[c], h.x / h.z, epsilon = 1e-9);
        assert_abs_diff_eq!(ys[c], h.y / h.z, epsilon = 1e-9);
    }
}

#[test]
fn aligned_grid_covers_the_bounds_on_multiples_of_the_gsd() {
    let g = OrthoGrid::covering([100.3, 200.7, 110.1, 205.2], 0.5);
    assert_eq!(g.top_left, [100.0, 205.5]);
    assert_eq!(g.size, ImageSize::new(21, 10));
    assert_eq!(g.centre_of(0.0, 0.0), [100.25, 205.25]);
}

#[test]
fn bad_crs_strings_are_refused_naming_the_string() {
    let e = Crs::from_proj_string("+proj=nonsense +zone=99").unwrap_err();
    assert!(e.to_string().contains("+proj=nonsense"), "{e}");
}

/// Stored peer results: PROJ 9 through rasterio 1.4.4 (`rasterio.warp.transform`).
#[test]
fn utm_matches_proj() {
    let crs = Crs::utm_for(27.55, 53.9).unwrap();
    let epsg = crs.epsg().unwrap();
    assert_eq!(epsg, 32635);
    let en = crs.from_lon_lat(27.55, 53.9).unwrap();
    assert!(
        (en[0] - 536138.4290761272).abs() < 1e-3 && (en[1] - 5972535.8563540345).abs() < 1e-3,
        "{en:?}"
    );
    let crs = Crs::utm_for(-70.6, -33.4).unwrap();
    let epsg = crs.epsg().unwrap();
    assert_eq!(epsg, 32719);
    let en = crs.from_lon_lat(-70.6, -33.4).unwrap();
    assert!(
        (en[0] - 351205.0646216514).abs() < 1e-3 && (en[1] - 6303223.750659056).abs() < 1e-3,
        "{en:?}"
    );
    assert!(Crs::utm_for(0.0, 86.0).is_err());
}
