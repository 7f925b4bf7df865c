//! The paper's Table 1 on truth built from a real image: a frame simulated with known six
//! angles from a reference orthoimage, corrected four ways, each judged on the same check points.
//!
//! Rows: registration to the reference, quadratic and bilinear polynomials from GCPs, and the
//! six-angle model with the attitude known to `attitude_noise_arcmin`. GCPs and check points are
//! random ground points seen by the frame; both coordinates of each are measured with
//! N(0, `point_noise_px`) errors. Every method yields `image_from_ref`; a check point's residual
//! is its measured image position minus the method's image of its measured reference position
//! (eq. 19-20). Times cover fitting and the warp onto the same output grid (the six-angle
//! footprint of the frame).

use crate::gcp::GcpPlan;
use crate::motion::gray;
use crate::rectify::RectifyPlan;
use crate::register::{RegisterOptions, register};
use crate::sensitivity::perturbed;
use crate::simulate::SimulatePlan;
use crate::{Error, warp_any};
use aerorect_core::attitude::SixAngleDegrees;
use aerorect_core::evaluate::stats;
use aerorect_core::{
    Camera, CheckPointStats, Homography, PlaneTransform, PolyKind, RectifyGeometry, RectifyLimits,
    SixAngleAttitude,
};
use aerorect_io::Gcp;
use aerorect_raster::{AnyRaster, WarpOptions};
use aerorect_solve::gcp::GcpModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::time::Instant;

/// The experiment's set-up.
#[derive(Debug, Clone)]
pub struct CompareConfig {
    /// The frame's camera; its lens model is not used (the table is of an ideal pinhole).
    pub camera: Camera,
    pub attitude: SixAngleAttitude,
    pub attitude_noise_arcmin: f64,
    pub gcps: usize,
    pub checkpoints: usize,
    /// One-sigma measurement error of each coordinate of GCPs and check points, pixels.
    pub point_noise_px: f64,
    /// One-sigma sensor noise added to the simulated frame, in gray levels of its sample type.
    pub image_noise: f64,
    pub seed: u64,
    pub register: RegisterOptions,
}

/// One row of the table.
#[derive(Debug, Clone, Serialize)]
pub struct CompareRow {
    pub method: &'static str,
    #[serde(flatten)]
    pub stats: CheckPointStats,
    pub seconds: f64,
    /// The paper's row: du_max, dv_max, URMS, VRMS, RMSE, seconds (MATLAB, 3.3 GHz).
    pub paper: [f64; 6],
}

/// The table and what it was computed on.
#[derive(Debug, Clone, Serialize)]
pub struct CompareResult {
    pub rows: Vec<CompareRow>,
    pub gcps: usize,
    pub checkpoints: usize,
    pub tie_points: usize,
    pub tie_inliers: usize,
    pub frame_size: [usize; 2],
    pub reference_size: [usize; 2],
    #[serde(skip)]
    pub frame: AnyRaster,
}

/// The default camera of the table: 512 x 512 like the paper's frame, fx = fy = 500 px (a 54
/// degree field of view; the paper does not state its camera).
pub const CAMERA_TOML: &str = "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [512, 512]\n";

/// The default true attitude of the table: the demo's, tilted to 30 degrees.
pub const ATTITUDE: SixAngleDegrees = SixAngleDegrees {
    azimuth: 20.0,
    elevation: 30.0,
    image_rotation: 2.0,
    pitch: 3.0,
    roll: -2.0,
    yaw: 15.0,
};

/// The paper's Table 1 (spec 01, Evaluation).
pub const PAPER: [(&str, [f64; 6]); 4] = [
    (
        "registration",
        [0.7425, 1.6002, 0.4481, 0.5786, 0.7318, 8.15],
    ),
    ("quadratic", [2.7291, 5.3997, 2.0596, 2.4823, 3.2255, 5.22]),
    ("bilinear", [20.317, 21.725, 9.9904, 11.846, 15.497, 5.20]),
    ("six-angle", [1.6785, 2.2546, 0.7157, 0.9315, 1.1747, 3.63]),
];

/// A measured pair: the frame pixel and the reference pixel of one ground point.
#[derive(Debug, Clone, Copy)]
struct Pair {
    image: [f64; 2],
    reference: [f64; 2],
}

/// `n` random ground points seen by the frame (5 % margin) and inside the reference (2 px),
/// each coordinate measured with N(0, sigma).
fn random_pairs(
    plan: &SimulatePlan,
    n: usize,
    sigma: f64,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<Pair>, Error> {
    let noise = Normal::new(0.0, sigma.max(0.0)).map_err(Error::from)?;
    let frame = plan.frame_size();
    let (w, h) = (frame.width as f64 - 1.0, frame.height as f64 - 1.0);
    let mut out = Vec::with_capacity(n);
    for _ in 0..n * 1000 {
        if out.len() == n {
            break;
        }
        let p = [
            w * rng.random_range(0.05..0.95),
            h * rng.random_range(0.05..0.95),
        ];
        if !plan.sees_ortho(p[0], p[1], 2.0) {
            continue;
        }
        let Some(r) = plan.ortho_from_oblique.map(p[0], p[1]) else {
            continue;
        };
        let mut jitter = || noise.sample(rng);
        out.push(Pair {
            image: [p[0] + jitter(), p[1] + jitter()],
            reference: [r[0] + jitter(), r[1] + jitter()],
        });
    }
    if out.len() < n {
        return Err(Error::Invalid(format!(
            "only {} of {n} random ground points are seen by the frame inside the reference",
            out.len()
        )));
    }
    Ok(out)
}

/// Check-point statistics of an `image_from_ref` map.
fn judge(
    map: impl Fn(f64, f64) -> Option<[f64; 2]>,
    checks: &[Pair],
) -> Result<CheckPointStats, Error> {
    let r: Vec<[f64; 2]> = checks
        .iter()
        .map(|c| {
            map(c.reference[0], c.reference[1])
                .map(|m| [c.image[0] - m[0], c.image[1] - m[1]])
                .ok_or_else(|| Error::Invalid("a check point maps beyond the horizon".into()))
        })
        .collect::<Result<_, _>>()?;
    stats(&r).ok_or_else(|| Error::Invalid("no check points".into()))
}

fn paper(method: &str) -> [f64; 6] {
    PAPER
        .iter()
        .find(|(m, _)| *m == method)
        .map(|(_, r)| *r)
        .unwrap_or([f64::NAN; 6])
}

/// Runs the four methods on a frame simulated from `reference`.
pub fn compare(reference: &AnyRaster, cfg: &CompareConfig) -> Result<CompareResult, Error> {
    let ref_size = reference.size();
    let camera = Camera::new(cfg.camera.intrinsics, None, cfg.camera.size);
    let (k, frame_size) = (camera.intrinsics, camera.size);
    let plan = SimulatePlan::new(camera.clone(), &cfg.attitude, ref_size);
    let warp = WarpOptions::default();
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let frame = noisy(plan.render(reference, &warp)?, cfg.image_noise, &mut rng)?;
    let gcps = random_pairs(&plan, cfg.gcps, cfg.point_noise_px, &mut rng)?;
    let checks = random_pairs(&plan, cfg.checkpoints, cfg.point_noise_px, &mut rng)?;

    // The common output grid: the true six-angle footprint, in reference pixels.
    let geometry = RectifyGeometry::new(
        &k,
        frame_size,
        &cfg.attitude,
        None,
        RectifyLimits::default(),
    )
    .map_err(Error::geometry("compare: output grid"))?;
    let [ocx, ocy] = ref_size.centre();
    let ref_from_standard = [ocx - k.cx, ocy - k.cy];
    let origin = [
        (geometry.standard_origin[0] + ref_from_standard[0]).round() as i64,
        (geometry.standard_origin[1] + ref_from_standard[1]).round() as i64,
    ];
    let grid = (origin, geometry.output_size);

    let mut rows = Vec::new();
    let t = Instant::now();
    let reg = register(&gray(&frame)?, &gray(reference)?, &cfg.register)?;
    let shifted = reg
        .image_from_ref
        .after_translation(origin[0] as f64, origin[1] as f64);
    warp_any(&frame, &shifted, grid.1, &warp)?;
    rows.push(CompareRow {
        method: "registration",
        stats: judge(|u, v| reg.image_from_ref.map(u, v), &checks)?,
        seconds: t.elapsed().as_secs_f64(),
        paper: paper("registration"),
    });

    let table: Vec<Gcp> = gcps
        .iter()
        .map(|g| Gcp {
            u_image: g.image[0],
            v_image: g.image[1],
            u_ref: g.reference[0],
            v_ref: g.reference[1],
        })
        .collect();
    for kind in [PolyKind::Quadratic, PolyKind::Bilinear] {
        let t = Instant::now();
        let fit = GcpPlan::fit(
            &table,
            GcpModel::Polynomial(kind),
            frame_size,
            Some(grid),
            RectifyLimits::default(),
        )?;
        fit.run(&frame, &warp)?;
        rows.push(CompareRow {
            method: kind.name(),
            stats: judge(|u, v| fit.image_from_ref.map(u, v), &checks)?,
            seconds: t.elapsed().as_secs_f64(),
            paper: paper(kind.name()),
        });
    }

    let t = Instant::now();
    let sigma = (cfg.attitude_noise_arcmin / 60.0).to_radians();
    let normal = Normal::new(0.0, sigma.max(0.0)).map_err(Error::from)?;
    let measured = perturbed(
        &cfg.attitude,
        std::array::from_fn(|_| normal.sample(&mut rng)),
    );
    let six = RectifyPlan::new(camera, measured, None, RectifyLimits::default(), warp)?;
    six.run(&frame)?;
    let g = six.geometry.oblique_from_output;
    // reference -> standard -> output grid of the plan -> oblique.
    let standard_from_ref = Homography::translation(-ref_from_standard[0], -ref_from_standard[1]);
    let output_from_standard = Homography::translation(
        -six.geometry.standard_origin[0],
        -six.geometry.standard_origin[1],
    );
    let image_from_ref =
        PlaneTransform::Projective(g.after(&output_from_standard.after(&standard_from_ref)));
    rows.push(CompareRow {
        method: "six-angle",
        stats: judge(|u, v| image_from_ref.map(u, v), &checks)?,
        seconds: t.elapsed().as_secs_f64(),
        paper: paper("six-angle"),
    });

    Ok(CompareResult {
        rows,
        gcps: gcps.len(),
        checkpoints: checks.len(),
        tie_points: reg.ties.len(),
        tie_inliers: reg.inliers(),
        frame_size: [frame_size.width, frame_size.height],
        reference_size: [ref_size.width, ref_size.height],
        frame,
    })
}

/// Adds N(0, sigma) sensor noise, rounded and clamped for integer samples.
fn noisy(frame: AnyRaster, sigma: f64, rng: &mut ChaCha8Rng) -> Result<AnyRaster, Error> {
    if sigma <= 0.0 {
        return Ok(frame);
    }
    let normal = Normal::new(0.0, sigma).map_err(Error::from)?;
    let mut out = frame;
    match &mut out {
        AnyRaster::U8(r) => (0..r.bands()).for_each(|b| {
            r.plane_mut(b)
                .iter_mut()
                .for_each(|v| *v = (*v as f64 + normal.sample(rng)).round().clamp(0.0, 255.0) as u8)
        }),
        AnyRaster::U16(r) => (0..r.bands()).for_each(|b| {
            r.plane_mut(b).iter_mut().for_each(|v| {
                *v = (*v as f64 + normal.sample(rng)).round().clamp(0.0, 65535.0) as u16
            })
        }),
        AnyRaster::F32(r) => (0..r.bands()).for_each(|b| {
            r.plane_mut(b)
                .iter_mut()
                .for_each(|v| *v += normal.sample(rng) as f32)
        }),
    }
    Ok(out)
}
