//! The paper's comparison (section 2): Tsai vs Brown vs the improved model, each calibrated by
//! the paper's procedure on one image of a synthetic 3-D test field whose lens has radial and
//! tangential distortion, then scored on the calibration points and on independent check points.

use crate::Error;
use aerorect_core::ImageSize;
use aerorect_core::distortion::{Distortion, DistortionModel, Improved};
use aerorect_solve::calib::{CalibrationOptions, Observation, calibrate};
use nalgebra::{Rotation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// One row of the table.
#[derive(Debug, Clone, Serialize)]
pub struct CompareRow {
    pub model: String,
    /// Free distortion parameters.
    pub parameters: usize,
    /// The paper's mean distortion error on the calibration points (pixels).
    pub mean_error_px: f64,
    /// Mean error over the mean distance from the principal point, percent.
    pub distortion_percent: f64,
    /// Mean error on check points not used in the fit (pixels).
    pub check_mean_error_px: f64,
    pub rms_px: f64,
    pub iterations: usize,
}

const K: [f64; 4] = [1000.0, 1000.0, 400.0, 400.0];

/// Truth: radial k1 = -0.15, k2 = 0.05 and tangential p1 = 3e-3, p2 = -2e-3 (the improved
/// model's form, 800 x 800 frame like the paper's), observed with white noise of `noise_px`.
fn field(noise_px: f64, seed: u64) -> Result<(Vec<Observation>, Vec<Observation>), Error> {
    let truth = Improved {
        k1: -0.15,
        k2: 0.05,
        p1: 3e-3,
        p2: -2e-3,
        dx0: 0.0,
        dy0: 0.0,
    };
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.04, -0.06, 0.03));
    let t = Vector3::new(0.05, -0.08, 0.2);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, noise_px).map_err(Error::from)?;
    let (mut fit, mut check) = (vec![], vec![]);
    for i in 0..17 {
        for j in 0..17 {
            let z = [4.0, 4.5, 5.1, 5.6][(i * 3 + j) % 4];
            let w = [-1.7 + i as f64 * 0.2125, -1.7 + j as f64 * 0.2125, z];
            let xc = rot * Vector3::from(w) + t;
            let o = truth
                .observed_from_ideal([xc.x / xc.z, xc.y / xc.z])
                .ok_or_else(|| Error::Invalid("the synthetic lens does not invert".into()))?;
            let px = [
                K[0] * o[0] + K[2] + noise.sample(&mut rng),
                K[1] * o[1] + K[3] + noise.sample(&mut rng),
            ];
            // The camera records only what falls on its frame (calibrate refuses the rest).
            if !px.iter().all(|c| (-0.5..=799.5).contains(c)) {
                continue;
            }
            let ob = Observation {
                image: "field".into(),
                world: w,
                pixel: px,
            };
            if (i + j) % 4 == 0 {
                check.push(ob)
            } else {
                fit.push(ob)
            }
        }
    }
    Ok((fit, check))
}

/// Calibrates each model on the same field and scores it.
pub fn compare(noise_px: f64, seed: u64) -> Result<Vec<CompareRow>, Error> {
    let (fit, check) = field(noise_px, seed)?;
    let models: [(&str, &[&str]); 3] = [
        ("tsai", &[]),
        // The film terms a1, a2, b1, b2 and the offsets duplicate fx, fy, skew, cx, cy.
        ("brown", &["a1", "a2", "b1", "b2", "dx0", "dy0"]),
        ("improved", &["dx0", "dy0"]),
    ];
    let mut rows = vec![];
    for (kind, fix) in models {
        let model = Distortion::zero(kind).ok_or_else(|| Error::Invalid(kind.into()))?;
        let n = model.model().names().len() - fix.len();
        let mut opts = CalibrationOptions::new(model, ImageSize::new(800, 800));
        opts.fix = fix.iter().map(|s| s.to_string()).collect();
        let r = calibrate(&fit, &opts).map_err(Error::context(&kind))?;
        let errs: Vec<f64> = check
            .iter()
            .filter_map(|o| {
                r.project(0, o.world)
                    .map(|p| (p[0] - o.pixel[0]).hypot(p[1] - o.pixel[1]))
            })
            .collect();
        rows.push(CompareRow {
            model: kind.into(),
            parameters: n,
            mean_error_px: r.mean_error_px,
            distortion_percent: r.distortion_percent,
            check_mean_error_px: errs.iter().sum::<f64>() / errs.len().max(1) as f64,
            rms_px: r.rms_px,
            iterations: r.iterations,
        });
    }
    Ok(rows)
}
