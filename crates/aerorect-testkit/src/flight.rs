//! Simulated flights with known truth for the adjustment: frames on a grid over terrain,
//! attitudes recorded with errors, tie points observed in the true frames with pixel noise.

use aerorect_core::{Camera, ImageSize, Intrinsics, Mat3, Vec3};
use aerorect_solve::adjust::{AdjustFrame, Observation, TiePoint};
use nalgebra::Rotation3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

pub fn camera(f: f64) -> Camera {
    Camera::new(
        Intrinsics::new(f, f, 499.5, 374.5).expect("a valid camera"),
        None,
        ImageSize::new(1000, 750),
    )
}

/// Nadir camera, image top towards +y (camera x = east, y = north, z = up).
pub fn nadir() -> Mat3 {
    Mat3::identity()
}

fn project(cam: &Camera, f: &AdjustFrame, x: Vec3) -> Option<[f64; 2]> {
    let d = f.world_from_camera.transpose() * (x - Vec3::from(f.centre));
    cam.pixel_from_camera_point(d)
        .filter(|p| p[0] >= 0.0 && p[1] >= 0.0 && p[0] <= 999.0 && p[1] <= 749.0)
}

pub struct Flight {
    pub truth: Vec<AdjustFrame>,
    pub recorded: Vec<AdjustFrame>,
    pub ties: Vec<TiePoint>,
}

/// `nx` x `ny` frames 50 m / 40 m apart at 100 m over terrain `h`, each recorded with a
/// rotation error of `sigma_deg` per axis, and 40 tie points drawn per frame.
pub fn flight(
    nx: usize,
    ny: usize,
    sigma_deg: f64,
    h: &dyn Fn(f64, f64) -> f64,
    seed: u64,
) -> Flight {
    dense_flight(nx, ny, sigma_deg, h, seed, 40)
}

/// [`flight`] with `per_frame` tie points drawn per frame (those seen in fewer than two
/// frames are dropped).
pub fn dense_flight(
    nx: usize,
    ny: usize,
    sigma_deg: f64,
    h: &dyn Fn(f64, f64) -> f64,
    seed: u64,
    per_frame: usize,
) -> Flight {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma_deg.to_radians()).expect("valid");
    let pix = Normal::new(0.0, 0.3).expect("valid");
    let cam = camera(800.0);
    let mut truth = Vec::new();
    let mut recorded = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let centre = [i as f64 * 50.0, j as f64 * 40.0, 100.0];
            let tilt = Vec3::new(0.02 * rng.random::<f64>(), 0.02 * rng.random::<f64>(), 0.1);
            let r = Rotation3::new(tilt).into_inner() * nadir();
            truth.push(AdjustFrame {
                camera: 0,
                centre,
                world_from_camera: r,
                position_sigma_m: None,
                attitude_sigma_deg: None,
            });
            let e = Vec3::new(
                noise.sample(&mut rng),
                noise.sample(&mut rng),
                noise.sample(&mut rng),
            );
            recorded.push(AdjustFrame {
                camera: 0,
                centre,
                world_from_camera: Rotation3::new(e).into_inner() * r,
                position_sigma_m: None,
                attitude_sigma_deg: None,
            });
        }
    }
    let (w, hgt) = ((nx - 1) as f64 * 50.0, (ny - 1) as f64 * 40.0);
    let mut ties = Vec::new();
    for _ in 0..(per_frame * nx * ny) {
        let (x, y) = (
            rng.random_range(-50.0..w + 50.0),
            rng.random_range(-40.0..hgt + 40.0),
        );
        let g = Vec3::new(x, y, h(x, y));
        let observations: Vec<Observation> = truth
            .iter()
            .enumerate()
            .filter_map(|(k, f)| {
                let p = project(&cam, f, g)?;
                Some(Observation {
                    frame: k,
                    pixel: [p[0] + pix.sample(&mut rng), p[1] + pix.sample(&mut rng)],
                    weight: 1.0,
                })
            })
            .collect();
        if observations.len() >= 2 {
            // First guess: the first recorded ray met with the terrain's mean height.
            let f = &recorded[observations[0].frame];
            let ray = f.world_from_camera
                * cam
                    .ray_from_pixel(observations[0].pixel[0], observations[0].pixel[1])
                    .expect("valid");
            let t = (f.centre[2] - 10.0) / -ray.z;
            let c = Vec3::from(f.centre) + ray * t;
            ties.push(TiePoint {
                ground: [c.x, c.y, c.z],
                observations,
                control: None,
            });
        }
    }
    Flight {
        truth,
        recorded,
        ties,
    }
}

/// The observations of ground point `g` in every `truth` frame that sees it (camera
/// `camera(800.0)`), each pixel with Gaussian noise of `sigma_px`.
pub fn marks(
    truth: &[AdjustFrame],
    g: Vec3,
    sigma_px: f64,
    rng: &mut ChaCha8Rng,
) -> Vec<Observation> {
    let cam = camera(800.0);
    let pix = Normal::new(0.0, sigma_px).expect("valid");
    truth
        .iter()
        .enumerate()
        .filter_map(|(k, f)| {
            let p = project(&cam, f, g)?;
            Some(Observation {
                frame: k,
                pixel: [p[0] + pix.sample(rng), p[1] + pix.sample(rng)],
                weight: 1.0,
            })
        })
        .collect()
}
