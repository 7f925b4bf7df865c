//! How attitude-angle errors become pixel errors: the paper's 3 arc-minute experiment.
//!
//! Check points are made with the true attitude; each draw perturbs all six angles by
//! independent N(0, sigma) errors and evaluates the check points with the perturbed attitude
//! (eq. 19-20). A first-order prediction from numerical derivatives is reported beside the
//! Monte Carlo figures.

use crate::Error;
use crate::simulate::spread_grid;
use aerorect_core::evaluate::{residuals, stats};
use aerorect_core::rectify::standard_from_oblique;
use aerorect_core::{Camera, CheckPoint, SixAngleAttitude};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// The experiment's set-up.
#[derive(Debug, Clone)]
pub struct SensitivityConfig {
    /// The camera (its intrinsics and frame size; angle errors are studied without the lens).
    pub camera: Camera,
    pub attitude: SixAngleAttitude,
    /// One-sigma error of every angle, in arc-minutes.
    pub sigma_arcmin: f64,
    pub draws: usize,
    /// Check points on a k x k grid (those that see the ground are kept).
    pub grid: usize,
    pub seed: u64,
}

/// Means over the draws, in oblique-frame pixels (a row like the paper's Table 1).
#[derive(Debug, Clone, Serialize)]
pub struct SensitivityRow {
    pub du_max: f64,
    pub dv_max: f64,
    pub urms: f64,
    pub vrms: f64,
    pub rmse: f64,
    /// sqrt(mean RMSE^2) over the draws.
    pub rms_of_rmse: f64,
    /// sqrt(E[RMSE^2]) to first order in the angle errors.
    pub predicted_rms_of_rmse: f64,
    pub draws: usize,
    pub checkpoints: usize,
    pub sigma_arcmin: f64,
    pub fov_deg: [f64; 2],
}

/// `a` with the angle errors `d` (radians, in the paper's order) added.
pub(crate) fn perturbed(a: &SixAngleAttitude, d: [f64; 6]) -> SixAngleAttitude {
    SixAngleAttitude {
        azimuth: a.azimuth + d[0],
        elevation: a.elevation + d[1],
        image_rotation: a.image_rotation + d[2],
        pitch: a.pitch + d[3],
        roll: a.roll + d[4],
        yaw: a.yaw + d[5],
    }
}

/// Residuals of `points` under `attitude` (all points are on the ground for small errors).
fn residuals_under(
    cfg: &SensitivityConfig,
    attitude: &SixAngleAttitude,
    points: &[CheckPoint],
) -> Result<Vec<[f64; 2]>, Error> {
    let g = standard_from_oblique(&cfg.camera.intrinsics, attitude).inverse();
    residuals(points, &g)
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or_else(|| {
            Error::Invalid("a perturbed attitude puts a check point beyond the horizon".into())
        })
}

/// Runs the experiment.
pub fn run(cfg: &SensitivityConfig) -> Result<SensitivityRow, Error> {
    if cfg.draws == 0 || !(cfg.sigma_arcmin.is_finite() && cfg.sigma_arcmin >= 0.0) {
        return Err(Error::Invalid(format!(
            "draws = {} and sigma_arcmin = {} must be positive",
            cfg.draws, cfg.sigma_arcmin
        )));
    }
    let f = standard_from_oblique(&cfg.camera.intrinsics, &cfg.attitude);
    let points: Vec<CheckPoint> = spread_grid(cfg.camera.size, cfg.grid)
        .into_iter()
        .filter_map(|p| {
            let s = f.map(p[0], p[1])?;
            Some(CheckPoint {
                u_oblique: p[0],
                v_oblique: p[1],
                u_standard: s[0],
                v_standard: s[1],
            })
        })
        .collect();
    if points.is_empty() {
        return Err(Error::Invalid("no check point sees the ground".into()));
    }
    let sigma = (cfg.sigma_arcmin / 60.0).to_radians();
    let normal = Normal::new(0.0, sigma).map_err(Error::from)?;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let mut sum = [0.0f64; 6];
    let mut sum_sq_rmse = 0.0;
    for _ in 0..cfg.draws {
        let d: [f64; 6] = std::array::from_fn(|_| normal.sample(&mut rng));
        let r = residuals_under(cfg, &perturbed(&cfg.attitude, d), &points)?;
        let s = stats(&r).ok_or_else(|| Error::Invalid("no residuals".into()))?;
        for (acc, v) in sum
            .iter_mut()
            .zip([s.du_max, s.dv_max, s.urms, s.vrms, s.rmse, 0.0])
        {
            *acc += v;
        }
        sum_sq_rmse += s.rmse * s.rmse;
    }
    let n = cfg.draws as f64;
    Ok(SensitivityRow {
        du_max: sum[0] / n,
        dv_max: sum[1] / n,
        urms: sum[2] / n,
        vrms: sum[3] / n,
        rmse: sum[4] / n,
        rms_of_rmse: (sum_sq_rmse / n).sqrt(),
        predicted_rms_of_rmse: first_order_rms(cfg, &points, sigma)?,
        draws: cfg.draws,
        checkpoints: points.len(),
        sigma_arcmin: cfg.sigma_arcmin,
        fov_deg: cfg.camera.intrinsics.field_of_view_deg(cfg.camera.size),
    })
}

/// sqrt(E[RMSE^2]) = sigma sqrt(sum_i sum_j |d r_i / d angle_j|^2 / n), derivatives by central
/// differences.
fn first_order_rms(
    cfg: &SensitivityConfig,
    points: &[CheckPoint],
    sigma: f64,
) -> Result<f64, Error> {
    const H: f64 = 1e-6;
    let mut total = 0.0;
    for j in 0..6 {
        let mut d = [0.0; 6];
        d[j] = H;
        let plus = residuals_under(cfg, &perturbed(&cfg.attitude, d), points)?;
        d[j] = -H;
        let minus = residuals_under(cfg, &perturbed(&cfg.attitude, d), points)?;
        for (p, m) in plus.iter().zip(&minus) {
            total += ((p[0] - m[0]) / (2.0 * H)).powi(2) + ((p[1] - m[1]) / (2.0 * H)).powi(2);
        }
    }
    Ok(sigma * (total / points.len() as f64).sqrt())
}
