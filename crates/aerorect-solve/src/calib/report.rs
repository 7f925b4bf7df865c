//! The calibration report: the adjusted parameters with their deviations and correlations,
//! per-view residuals and poses, and the warnings; built from a solved adjustment.

use super::CalibrationError;
use super::blocks::BlockNormal;
use super::inputs::CalibrationOptions;
use super::lm::StopReason;
use super::problem::Calib;
use aerorect_core::distortion::Distortion;
use aerorect_core::{Camera, GeometryError, ImageSize};
use nalgebra::{Rotation3, Vector3};
use serde::Serialize;

#[derive(Debug, Clone, Serialize)]
pub struct ParameterValue {
    pub name: String,
    pub value: f64,
    /// One-sigma standard deviation; None for fixed parameters.
    pub std: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ViewReport {
    pub image: String,
    pub points: usize,
    pub rms_px: f64,
    pub rotation_vector: [f64; 3],
    pub translation: [f64; 3],
}

/// The correlation of two estimated parameters.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Correlation {
    pub a: String,
    pub b: String,
    pub rho: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct CalibrationReport {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub skew: f64,
    pub distortion: Distortion,
    /// Intrinsics and coefficients with their standard deviations.
    pub parameters: Vec<ParameterValue>,
    pub correlation_warnings: Vec<String>,
    /// Pairs of free intrinsics or coefficients whose correlation exceeds 0.95 in magnitude.
    pub correlations: Vec<Correlation>,
    /// Terms held at zero because the data could not determine them, and other warnings.
    pub warnings: Vec<String>,
    /// The points' coverage of the image (an 8 x 6 heat map and the empty corner ninths).
    pub coverage: super::Coverage,
    /// Per observation (input order), pixels. For the OpenCV model: predicted minus measured in
    /// the observed image; for the paper's models: projection minus corrected measurement.
    pub residuals: Vec<[f64; 2]>,
    pub views: Vec<ViewReport>,
    /// sqrt(mean |residual|^2) over the points (OpenCV's RMS).
    pub rms_px: f64,
    /// The paper's mean distortion error: mean |residual| (pixels).
    pub mean_error_px: f64,
    /// Mean |residual| over the mean distance of the points from the principal point, percent.
    pub distortion_percent: f64,
    pub iterations: usize,
    pub stop_reason: StopReason,
    /// Coefficients held at their starting values because they duplicate a free parameter
    /// ("a1 held at 0: it duplicates fx").
    pub held_fixed: Vec<String>,
}

impl CalibrationReport {
    /// The calibrated camera for images of `size` (the size the control points were measured
    /// in).
    pub fn camera(&self, size: ImageSize) -> Result<Camera, GeometryError> {
        let mut k = aerorect_core::Intrinsics::new(self.fx, self.fy, self.cx, self.cy)?;
        k.skew = aerorect_core::error::require_finite("skew", self.skew)?;
        Ok(Camera::new(k, Some(self.distortion.clone()), size))
    }

    /// The observed pixel of world point `w` in view `view` under the calibrated camera; `None`
    /// behind the camera or where the lens model's inverse does not converge.
    pub fn project(&self, view: usize, w: [f64; 3]) -> Option<[f64; 2]> {
        let v = self.views.get(view)?;
        let rot = Rotation3::from_scaled_axis(Vector3::from(v.rotation_vector));
        let xc = rot * Vector3::from(w) + Vector3::from(v.translation);
        if xc.z <= 0.0 {
            return None;
        }
        let o = self
            .distortion
            .model()
            .observed_from_ideal([xc.x / xc.z, xc.y / xc.z])?;
        Some([
            self.fx * o[0] + self.skew * o[1] + self.cx,
            self.fy * o[1] + self.cy,
        ])
    }
}

pub(super) fn report(
    p: &Calib,
    res: &mut super::lm::LmResult<BlockNormal>,
    global: &[&str],
    ids: &[String],
    opts: &CalibrationOptions,
) -> Result<CalibrationReport, CalibrationError> {
    let x = p.expand(&res.x);
    let n = p.obs.len();
    let residuals: Vec<[f64; 2]> = (0..n)
        .map(|i| [res.residuals[2 * i], res.residuals[2 * i + 1]])
        .collect();
    let ssr: f64 = res.residuals.norm_squared();
    let dof = (2 * n).saturating_sub(p.free.len()).max(1) as f64;
    let cov = res
        .normal
        .global_inverse()
        .ok_or_else(|| CalibrationError::Singular("J^T J at the solution".into()))?
        * (ssr / dof);
    let mut parameters = vec![];
    for (gi, name) in global.iter().enumerate() {
        let std = p
            .free
            .iter()
            .position(|&f| f == gi)
            .map(|k| cov[(k, k)].max(0.0).sqrt());
        parameters.push(ParameterValue {
            name: name.to_string(),
            value: x[gi],
            std,
        });
    }
    let mut correlations = vec![];
    let gfree: Vec<(usize, usize)> = p
        .free
        .iter()
        .enumerate()
        .filter(|(_, f)| **f < global.len())
        .map(|(k, f)| (k, *f))
        .collect();
    for (a, &(ka, ga)) in gfree.iter().enumerate() {
        for &(kb, gb) in &gfree[a + 1..] {
            let rho = cov[(ka, kb)] / (cov[(ka, ka)] * cov[(kb, kb)]).sqrt();
            if rho.abs() > 0.95 {
                correlations.push(Correlation {
                    a: global[ga].to_string(),
                    b: global[gb].to_string(),
                    rho,
                });
            }
        }
    }
    let global_n = 5 + p.nd;
    let views = ids
        .iter()
        .enumerate()
        .map(|(v, id)| {
            let idx = &p.views[v];
            let se: f64 = idx
                .iter()
                .map(|&i| residuals[i][0].powi(2) + residuals[i][1].powi(2))
                .sum();
            let b = global_n + 6 * v;
            ViewReport {
                image: id.clone(),
                points: idx.len(),
                rms_px: (se / idx.len() as f64).sqrt(),
                rotation_vector: [x[b], x[b + 1], x[b + 2]],
                translation: [x[b + 3], x[b + 4], x[b + 5]],
            }
        })
        .collect();
    let mean_error_px = residuals.iter().map(|r| r[0].hypot(r[1])).sum::<f64>() / n as f64;
    let mean_radius = p
        .obs
        .iter()
        .map(|o| (o.pixel[0] - x[2]).hypot(o.pixel[1] - x[3]))
        .sum::<f64>()
        / n as f64;
    let mut distortion = opts.model.clone();
    distortion.model_mut().set_params(&x[5..global_n]);
    let (cols, rows) = super::COVERAGE_GRID;
    let coverage = super::coverage(p.obs, opts.image_size, cols, rows);
    Ok(CalibrationReport {
        fx: x[0],
        fy: x[1],
        cx: x[2],
        cy: x[3],
        skew: x[4],
        distortion,
        parameters,
        correlation_warnings: correlations
            .iter()
            .map(|c| {
                format!(
                    "{} and {} are strongly correlated ({:+.3})",
                    c.a, c.b, c.rho
                )
            })
            .collect(),
        correlations,
        warnings: coverage.warning().into_iter().collect(),
        coverage,
        residuals,
        views,
        rms_px: (ssr / n as f64).sqrt(),
        mean_error_px,
        distortion_percent: 100.0 * mean_error_px / mean_radius,
        iterations: res.iterations,
        stop_reason: res.stop,
        held_fixed: held_terms(opts)
            .into_iter()
            .map(|(term, partner)| {
                let m = opts.model.model();
                let start = m
                    .names()
                    .iter()
                    .position(|n| *n == term)
                    .map_or(0.0, |i| m.params()[i]);
                format!("{term} held at {start}: it duplicates {partner}")
            })
            .collect(),
    })
}

/// The model's coefficients that duplicate a parameter left free ([`Distortion::duplicates`]),
/// unless the options fix the coefficient or its duplicate themselves.
pub(super) fn held_terms(opts: &CalibrationOptions) -> Vec<(&'static str, &'static str)> {
    let fixed = |name: &str| opts.fix.iter().any(|f| f == name);
    opts.model
        .duplicates()
        .iter()
        .copied()
        .filter(|(term, partner)| !fixed(term) && !fixed(partner))
        .collect()
}
