//! The numeric oracle of the analytic Jacobians: central differences of `project`.

use super::AdjustFrame;
use super::blocks::{CAMERA_PARAMS, CameraBlock, FRAME_PARAMS, FrameBlock, LOCAL};
use super::jacobian::pixel_jacobian;
use super::residuals::project;
use aerorect_core::distortion::{Distortion, OpenCv, Tsai};
use aerorect_core::{Camera, ImageSize, Intrinsics, Vec3};
use nalgebra::{Matrix2x3, Rotation3, SMatrix};

/// Central differences of the pixel by the local columns and by the point.
fn numeric(
    frame: &AdjustFrame,
    camera: &Camera,
    fb: &FrameBlock,
    cb: &CameraBlock,
    x: &Vec3,
) -> (SMatrix<f64, 2, LOCAL>, Matrix2x3<f64>) {
    let px = |fb: &FrameBlock, cb: &CameraBlock, x: &Vec3| {
        let p = project(frame, camera, fb, cb, x).expect("in view");
        nalgebra::Vector2::new(p[0], p[1])
    };
    let mut local = SMatrix::<f64, 2, LOCAL>::zeros();
    for (k, p) in FRAME_PARAMS.iter().enumerate() {
        let h = 1e-6;
        let (mut a, mut b) = (*fb, *fb);
        *a.get_mut(*p) += h;
        *b.get_mut(*p) -= h;
        local.set_column(k, &((px(&a, cb, x) - px(&b, cb, x)) / (2.0 * h)));
    }
    for (k, p) in CAMERA_PARAMS.iter().enumerate() {
        let h = 1e-6;
        let (mut a, mut b) = (*cb, *cb);
        *a.get_mut(*p) += h;
        *b.get_mut(*p) -= h;
        local.set_column(6 + k, &((px(fb, &a, x) - px(fb, &b, x)) / (2.0 * h)));
    }
    let mut point = Matrix2x3::zeros();
    for k in 0..3 {
        let (mut a, mut b) = (*x, *x);
        a[k] += 1e-4;
        b[k] -= 1e-4;
        point.set_column(k, &((px(fb, cb, &a) - px(fb, cb, &b)) / 2e-4));
    }
    (local, point)
}

fn lenses() -> Vec<Option<Distortion>> {
    let opencv = OpenCv {
        k1: -0.12,
        k2: 0.03,
        p1: 1e-3,
        p2: -5e-4,
        k3: 0.01,
        ..OpenCv::default()
    };
    vec![
        None,
        Some(Distortion::OpenCv(opencv)),
        Some(Distortion::Tsai(Tsai {
            k1: 0.08,
            k2: -0.01,
        })),
    ]
}

#[test]
fn analytic_jacobians_agree_with_central_differences() {
    let tilt = Rotation3::new(Vec3::new(0.5, -0.2, 0.3)).into_inner();
    let frame = AdjustFrame {
        camera: 0,
        centre: [10.0, -5.0, 120.0],
        world_from_camera: tilt,
        position_sigma_m: None,
        attitude_sigma_deg: None,
    };
    let fb = FrameBlock {
        rotation: Vec3::new(0.01, -0.02, 0.015),
        position: Vec3::new(0.3, -0.2, 0.5),
    };
    let cb = CameraBlock {
        focal_scale: 0.01,
        principal_point: [1.5, -2.0],
        radial: [0.01, -0.002],
        boresight: Vec3::new(0.004, -0.003, 0.002),
    };
    let mut checked = 0;
    for lens in lenses() {
        let camera = Camera::new(
            Intrinsics::new(900.0, 880.0, 510.0, 380.0).expect("valid"),
            lens,
            ImageSize::new(1000, 750),
        );
        for (u, v) in [(100.0, 80.0), (500.0, 380.0), (900.0, 650.0)] {
            // A ground point on the recorded ray of pixel (u, v), 100 m along it.
            let ray = tilt * camera.ray_from_pixel(u, v).expect("a ray").normalize();
            let x = Vec3::from(frame.centre) + ray * 100.0;
            let a = pixel_jacobian(&frame, &camera, &fb, &cb, &x).expect("in view");
            let p = project(&frame, &camera, &fb, &cb, &x).expect("in view");
            assert!((a.pixel[0] - p[0]).abs() < 1e-9 && (a.pixel[1] - p[1]).abs() < 1e-9);
            let (local, point) = numeric(&frame, &camera, &fb, &cb, &x);
            for (an, nu) in a.local.iter().zip(local.iter()) {
                assert!(
                    (an - nu).abs() <= 1e-5 * (1.0 + nu.abs()),
                    "{}\n{}",
                    a.local,
                    local
                );
            }
            for (an, nu) in a.point.iter().zip(point.iter()) {
                assert!(
                    (an - nu).abs() <= 1e-5 * (1.0 + nu.abs()),
                    "{}\n{}",
                    a.point,
                    point
                );
            }
            checked += 1;
        }
    }
    assert_eq!(checked, 9);
}
