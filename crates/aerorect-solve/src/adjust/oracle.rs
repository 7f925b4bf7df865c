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

/// A GPS position prior's row against a free datum (shift, rotation, scale and drift): its
/// terms are the central differences of its value by every free parameter.
#[test]
fn position_prior_rows_agree_with_central_differences() {
    use super::blocks::{DatumBlock, FrameParam, Layout, Param, State};
    use super::residuals::Problem;
    use super::{AdjustOptions, Datum};
    let frames: Vec<AdjustFrame> = (0..3)
        .map(|k| AdjustFrame {
            camera: 0,
            centre: [k as f64 * 40.0 - 30.0, 10.0 * k as f64, 100.0 + k as f64],
            world_from_camera: nalgebra::Matrix3::identity(),
            position_sigma_m: None,
            attitude_sigma_deg: None,
        })
        .collect();
    let cameras = [Camera::new(
        Intrinsics::new(900.0, 880.0, 510.0, 380.0).expect("valid"),
        None,
        ImageSize::new(1000, 750),
    )];
    let times = [-0.5, 0.1, 0.5];
    let opts = AdjustOptions {
        position_sigma_m: Some(3.0),
        datum: Datum::Similarity,
        gps_drift_times: Some(&times),
        ..AdjustOptions::default()
    };
    let p = Problem {
        frames: &frames,
        cameras: &cameras,
        ties: &[],
        layout: Layout::new(
            3,
            1,
            |_, q| matches!(q, FrameParam::Position(_)),
            |_, _| false,
            |_| true,
        ),
        opts: &opts,
        huber: opts.huber,
        centroid: Vec3::new(1.0, 2.0, 3.0),
    };
    let s = State {
        frames: (0..3)
            .map(|k| FrameBlock {
                rotation: Vec3::zeros(),
                position: Vec3::new(0.5, -0.3, 1.2) * k as f64,
            })
            .collect(),
        cameras: vec![CameraBlock::default()],
        datum: DatumBlock {
            shift: Vec3::new(1.0, -2.0, 0.5),
            rotation: Vec3::new(0.01, -0.02, 0.005),
            scale: 1e-3,
            drift: Vec3::new(2.0, -1.0, 5.0),
        },
        points: Vec::new(),
    };
    let free: Vec<(usize, Param)> = p.layout.free().collect();
    let rows = p.prior_rows(&s);
    let mut checked = 0;
    for (r, (row, &(_, q))) in rows.iter().zip(&free).enumerate() {
        if !matches!(q, Param::Frame(_, FrameParam::Position(_))) {
            continue;
        }
        for &(j, by) in &free {
            let value_at = |h: f64| {
                let mut t = s.clone();
                *by.value_mut(&mut t) += h;
                p.prior_rows(&t)[r].value
            };
            let h = 1e-6;
            let numeric = (value_at(h) - value_at(-h)) / (2.0 * h);
            let analytic: f64 = row.terms.iter().filter(|t| t.0 == j).map(|t| t.1).sum();
            assert!(
                (numeric - analytic).abs() < 1e-6,
                "{q:?} by {by:?}: {analytic} vs {numeric}"
            );
            checked += 1;
        }
    }
    // Nine position rows, each by the 9 positions and the 10 datum parameters.
    assert_eq!(checked, 9 * 19);
}
