use super::*;
use crate::attitude::SixAngleDegrees;
use approx::assert_relative_eq;

fn camera() -> (Intrinsics, ImageSize) {
    (
        Intrinsics::new(1000.0, 1000.0, 255.5, 255.5).expect("valid"),
        ImageSize::new(512, 512),
    )
}

fn att(f: impl Fn(&mut SixAngleDegrees)) -> SixAngleAttitude {
    let mut d = SixAngleDegrees::default();
    f(&mut d);
    SixAngleAttitude::from_degrees(&d).expect("valid angles")
}

#[test]
fn f_times_g_is_identity() {
    let (intr, _) = camera();
    let a = att(|d| {
        *d = SixAngleDegrees {
            azimuth: 20.0,
            elevation: 35.0,
            image_rotation: 4.0,
            pitch: 3.0,
            roll: -2.0,
            yaw: 60.0,
        }
    });
    let f = standard_from_oblique(&intr, &a);
    let prod = f.matrix() * f.inverse().matrix();
    assert_relative_eq!(prod, Mat3::identity(), epsilon = 1e-12);
    let numeric = f.matrix().try_inverse().expect("invertible");
    assert_relative_eq!(*f.inverse().matrix(), numeric, max_relative = 1e-9);
}

#[test]
fn nadir_attitude_is_identity() {
    let (intr, _) = camera();
    let f = standard_from_oblique(&intr, &SixAngleAttitude::default());
    let p = f.map(17.0, 300.0).expect("ground");
    assert_relative_eq!(p[0], 17.0, epsilon = 1e-9);
    assert_relative_eq!(p[1], 300.0, epsilon = 1e-9);
}

#[test]
fn pure_yaw_rotates_about_the_principal_point() {
    let (intr, _) = camera();
    let yaw = 37.0f64;
    let f = standard_from_oblique(&intr, &att(|d| d.yaw = yaw));
    let (s, c) = (-yaw.to_radians()).sin_cos(); // v points down: the paper's yaw turns clockwise on screen
    for &(u, v) in &[(0.0, 0.0), (511.0, 3.0), (100.0, 400.0), (255.5, 255.5)] {
        let (du, dv) = (u - intr.cx, v - intr.cy);
        let p = f.map(u, v).expect("ground");
        assert_relative_eq!(p[0], intr.cx + c * du - s * dv, epsilon = 1e-9);
        assert_relative_eq!(p[1], intr.cy + s * du + c * dv, epsilon = 1e-9);
    }
}

#[test]
fn pure_elevation_gives_a_symmetric_trapezoid() {
    let (intr, size) = camera();
    let f = standard_from_oblique(&intr, &att(|d| d.elevation = 30.0));
    let c: Vec<[f64; 2]> = size
        .corner_pixels()
        .iter()
        .map(|p| f.map(p[0], p[1]).expect("ground"))
        .collect();
    // top-left, top-right, bottom-right, bottom-left
    assert_relative_eq!(c[0][1], c[1][1], epsilon = 1e-9);
    assert_relative_eq!(c[2][1], c[3][1], epsilon = 1e-9);
    assert_relative_eq!(c[0][0] + c[1][0], 2.0 * intr.cx, epsilon = 1e-9);
    assert_relative_eq!(c[2][0] + c[3][0], 2.0 * intr.cx, epsilon = 1e-9);
    let top = c[1][0] - c[0][0];
    let bottom = c[2][0] - c[3][0];
    assert!(
        (top - bottom).abs() > 10.0,
        "a trapezoid, not a rectangle: {top} vs {bottom}"
    );
}

#[test]
fn altitude_scale_is_about_the_principal_point() {
    let s = AltitudeScale::new(1200.0, 1000.0).expect("valid");
    let h = s.base_from_standard([255.5, 200.0]);
    let p = h.map(255.5, 200.0).expect("finite");
    assert_relative_eq!(p[0], 255.5, epsilon = 1e-12);
    assert_relative_eq!(p[1], 200.0, epsilon = 1e-12);
    let q = h.map(265.5, 190.0).expect("finite");
    assert_relative_eq!(q[0] - 255.5, 12.0, epsilon = 1e-12);
    assert_relative_eq!(q[1] - 200.0, -12.0, epsilon = 1e-12);
    assert_relative_eq!(
        h.matrix() * h.inverse().matrix(),
        Mat3::identity(),
        epsilon = 1e-12
    );
    assert!(AltitudeScale::new(0.0, 10.0).is_err());
    assert!(AltitudeScale::new(10.0, -1.0).is_err());
}

#[test]
fn output_grid_covers_the_mapped_corners_tightly() {
    let (intr, size) = camera();
    let a = att(|d| {
        d.elevation = 25.0;
        d.yaw = 15.0;
        d.roll = 2.0
    });
    let g = RectifyGeometry::new(&intr, size, &a, None, RectifyLimits::default()).expect("fits");
    assert!(!g.clipped);
    let mapped: Vec<[f64; 2]> = size
        .corner_pixels()
        .iter()
        .map(|p| g.base_from_oblique.map(p[0], p[1]).expect("ground"))
        .collect();
    let min_u = mapped.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min);
    let max_u = mapped
        .iter()
        .map(|p| p[0])
        .fold(f64::NEG_INFINITY, f64::max);
    let min_v = mapped.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let max_v = mapped
        .iter()
        .map(|p| p[1])
        .fold(f64::NEG_INFINITY, f64::max);
    assert_eq!(g.standard_origin, [min_u.floor(), min_v.floor()]);
    assert_eq!(
        g.output_size.width as f64,
        max_u.ceil() - min_u.floor() + 1.0
    );
    assert_eq!(
        g.output_size.height as f64,
        max_v.ceil() - min_v.floor() + 1.0
    );
    // Output pixel -> oblique is the inverse of oblique -> base, shifted by the origin.
    let p = g.oblique_from_output.map(10.0, 20.0).expect("ground");
    let back = g.base_from_oblique.map(p[0], p[1]).expect("ground");
    assert_relative_eq!(back[0], 10.0 + g.standard_origin[0], epsilon = 1e-8);
    assert_relative_eq!(back[1], 20.0 + g.standard_origin[1], epsilon = 1e-8);
}

#[test]
fn altitude_normalisation_scales_the_output() {
    let (intr, size) = camera();
    let a = att(|d| d.elevation = 10.0);
    let plain =
        RectifyGeometry::new(&intr, size, &a, None, RectifyLimits::default()).expect("fits");
    let alt = AltitudeScale::new(2000.0, 1000.0).expect("valid");
    let scaled =
        RectifyGeometry::new(&intr, size, &a, Some(alt), RectifyLimits::default()).expect("fits");
    let ratio = scaled.output_size.width as f64 / plain.output_size.width as f64;
    assert!((ratio - 2.0).abs() < 0.01, "width ratio {ratio}");
}

#[test]
fn a_frame_looking_up_sees_no_ground() {
    let (intr, size) = camera();
    let a = att(|d| {
        d.elevation = 90.0;
        d.roll = 30.0
    });
    let e = RectifyGeometry::new(&intr, size, &a, None, RectifyLimits::default()).unwrap_err();
    assert_eq!(e, GeometryError::NoGround);
}

#[test]
fn a_frame_across_the_horizon_is_clipped_to_the_limit() {
    let intr = Intrinsics::new(500.0, 500.0, 255.5, 255.5).expect("valid");
    let size = ImageSize::new(512, 512);
    let a = att(|d| d.elevation = 80.0); // top edge at 80 + 27 degrees: above the horizon
    let limits = RectifyLimits::default();
    let g = RectifyGeometry::new(&intr, size, &a, None, limits).expect("clipped");
    assert!(g.clipped);
    assert!(g.output_size.pixels() as u64 <= limits.max_output_px);
    assert!(
        g.output_size.pixels() as u64 > limits.max_output_px / 2,
        "bisection keeps as much as fits"
    );
    // The near (bottom) corners are kept; every footprint vertex is on the ground.
    for p in &g.footprint {
        assert!(g.base_from_oblique.map_homogeneous(p[0], p[1]).z > 0.0);
    }
    assert!(g.footprint.contains(&[511.0, 511.0]) && g.footprint.contains(&[0.0, 511.0]));
}

#[test]
fn a_limit_that_would_keep_too_little_is_refused() {
    let (intr, size) = camera();
    let a = att(|d| d.elevation = 20.0);
    let e = RectifyGeometry::new(&intr, size, &a, None, RectifyLimits { max_output_px: 100 })
        .unwrap_err();
    assert!(
        matches!(e, GeometryError::OutputTooLarge { limit: 100, .. }),
        "{e:?}"
    );
}
