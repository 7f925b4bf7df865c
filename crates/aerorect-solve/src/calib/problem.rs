//! The calibration problem: parameter layout with named blocks, residuals, the adjustment and
//! its report.

use super::CalibrationError;
use super::blocks::{BlockNormal, ViewBlock};
use super::init::{PlaneView, Pose, dlt, zhang};
use super::jacobian::{
    PointScratch, PoseFrame, intrinsics_from_slice, residual, residual_jacobian,
};
use super::lm::{Problem, StopReason, minimise};
use aerorect_core::distortion::Distortion;
use aerorect_core::{Camera, GeometryError, ImageSize};
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};
use serde::Serialize;

/// One control point seen in one image.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    pub image: String,
    pub world: [f64; 3],
    pub pixel: [f64; 2],
}

#[derive(Debug, Clone)]
pub struct CalibrationOptions {
    /// The model to fit (its coefficients are the starting values, normally zero).
    pub model: Distortion,
    /// Parameter names held at their starting values (fx, fy, cx, cy, skew, or a coefficient).
    pub fix: Vec<String>,
    /// Free the skew (held at zero otherwise).
    pub skew: bool,
    /// Hold fy / fx at this ratio (OpenCV's CALIB_FIX_ASPECT_RATIO without a guess uses 1).
    pub fixed_aspect: Option<f64>,
    pub max_iterations: usize,
    /// Stop when an update moves every predicted point by less than this (pixels).
    pub stop_px: f64,
    pub image_size: ImageSize,
}

impl CalibrationOptions {
    pub fn new(model: Distortion, image_size: ImageSize) -> Self {
        Self {
            model,
            fix: vec![],
            skew: false,
            fixed_aspect: None,
            max_iterations: 200,
            stop_px: 0.01,
            image_size,
        }
    }
}

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

const INTRINSICS: [&str; 5] = ["fx", "fy", "cx", "cy", "skew"];

/// The adjustment: parameter vector = [fx, fy, cx, cy, skew, coefficients.., (w, t) per view].
/// The free parameters are the free globals (in that order) followed by every view's pose.
pub(super) struct Calib<'a> {
    obs: &'a [Observation],
    /// Observation indices per view.
    pub(super) views: Vec<Vec<usize>>,
    /// Each view's world points and pixels, in the view's order (planned once).
    world: Vec<Vec<Vector3<f64>>>,
    pixel: Vec<Vec<[f64; 2]>>,
    model: Distortion,
    nd: usize,
    /// Free parameter -> index in the full vector.
    pub(super) free: Vec<usize>,
    /// The number of free global parameters (the first entries of `free`).
    pub(super) free_globals: usize,
    pub(super) full0: Vec<f64>,
    aspect: Option<f64>,
}

impl<'a> Calib<'a> {
    pub(super) fn new(
        obs: &'a [Observation],
        views: Vec<Vec<usize>>,
        model: Distortion,
        free: Vec<usize>,
        full0: Vec<f64>,
        aspect: Option<f64>,
    ) -> Self {
        let nd = model.model().names().len();
        let world = views
            .iter()
            .map(|v| v.iter().map(|&i| Vector3::from(obs[i].world)).collect())
            .collect();
        let pixel = views
            .iter()
            .map(|v| v.iter().map(|&i| obs[i].pixel).collect())
            .collect();
        let free_globals = free.iter().filter(|&&i| i < 5 + nd).count();
        Calib {
            obs,
            views,
            world,
            pixel,
            model,
            nd,
            free,
            free_globals,
            full0,
            aspect,
        }
    }

    pub(super) fn expand(&self, z: &DVector<f64>) -> Vec<f64> {
        let mut x = self.full0.clone();
        for (k, &i) in self.free.iter().enumerate() {
            x[i] = z[k];
        }
        if let Some(a) = self.aspect {
            x[1] = x[0] * a;
        }
        x
    }

    /// The lens model with the coefficients of the full vector `x`.
    fn model_at(&self, x: &[f64]) -> Distortion {
        let mut model = self.model.clone();
        model.model_mut().set_params(&x[5..5 + self.nd]);
        model
    }

    fn pose(&self, x: &[f64], v: usize) -> PoseFrame {
        let base = 5 + self.nd + 6 * v;
        PoseFrame::from_slice(&x[base..base + 6])
    }

    /// Residuals of the full vector `x`, two per observation in input order.
    fn residuals_full(&self, x: &[f64], r: &mut [f64]) {
        let model = self.model_at(x);
        let k = intrinsics_from_slice(x);
        for v in 0..self.views.len() {
            let pose = self.pose(x, v);
            for (k_in_view, &i) in self.views[v].iter().enumerate() {
                let e = residual(
                    &k,
                    model.model(),
                    &pose,
                    &self.world[v][k_in_view],
                    self.pixel[v][k_in_view],
                );
                r[2 * i] = e[0];
                r[2 * i + 1] = e[1];
            }
        }
    }

    /// One view's Jacobian rows and residuals into its block.
    fn view_jacobian(
        &self,
        x: &[f64],
        model: &Distortion,
        v: usize,
        r: &DVector<f64>,
        s: &mut PointScratch,
        b: &mut ViewBlock,
    ) {
        let k = intrinsics_from_slice(x);
        let pose = self.pose(x, v);
        let globals = &self.free[..self.free_globals];
        for (n, &i) in self.views[v].iter().enumerate() {
            let jp = residual_jacobian(
                &k,
                model.model(),
                &pose,
                &self.world[v][n],
                self.pixel[v][n],
                s,
            );
            let dg = &mut s.dg;
            if let Some(a) = self.aspect {
                // fy = a fx: fx's column carries fy's.
                let fy = dg[1];
                dg[0] += fy * a;
            }
            b.jp.fixed_view_mut::<2, 6>(2 * n, 0).copy_from(&jp);
            for (col, &gi) in globals.iter().enumerate() {
                b.jg[(2 * n, col)] = dg[gi][0];
                b.jg[(2 * n + 1, col)] = dg[gi][1];
            }
            b.r[2 * n] = r[2 * i];
            b.r[2 * n + 1] = r[2 * i + 1];
        }
    }
}

impl Problem for Calib<'_> {
    type Normal = BlockNormal;

    fn residual_count(&self) -> usize {
        2 * self.obs.len()
    }

    fn residuals_into(&self, z: &DVector<f64>, r: &mut DVector<f64>) {
        self.residuals_full(&self.expand(z), r.as_mut_slice());
    }

    fn new_normal(&self) -> BlockNormal {
        BlockNormal::new(self.free_globals, self.views.iter().map(Vec::len))
    }

    /// Analytic Jacobian rows per view, then the blocks of J^T J.
    fn normal_into(&self, z: &DVector<f64>, r: &DVector<f64>, n: &mut BlockNormal) {
        let x = self.expand(z);
        let model = self.model_at(&x);
        let mut s = PointScratch::new(self.nd);
        for (v, b) in n.views.iter_mut().enumerate() {
            self.view_jacobian(&x, &model, v, r, &mut s, b);
        }
        n.assemble();
    }
}

/// Groups observations by image id (in first-seen order) and checks them.
fn group(
    obs: &[Observation],
    need: usize,
) -> Result<(Vec<String>, Vec<Vec<usize>>), CalibrationError> {
    let (mut ids, mut views): (Vec<String>, Vec<Vec<usize>>) = (vec![], vec![]);
    for (i, o) in obs.iter().enumerate() {
        if o.world.iter().chain(&o.pixel).any(|v| !v.is_finite()) {
            return Err(CalibrationError::NotFinite {
                index: i,
                image: o.image.clone(),
            });
        }
        match ids.iter().position(|id| *id == o.image) {
            Some(k) => views[k].push(i),
            None => {
                ids.push(o.image.clone());
                views.push(vec![i]);
            }
        }
    }
    for (id, v) in ids.iter().zip(&views) {
        if v.len() < need {
            return Err(CalibrationError::TooFewInImage {
                image: id.clone(),
                got: v.len(),
                need,
            });
        }
    }
    Ok((ids, views))
}

/// Singular values (descending) of the centred world points of `idx`, and the plane basis.
fn spread(obs: &[Observation], idx: &[usize]) -> ([f64; 3], Vector3<f64>, nalgebra::Matrix3<f64>) {
    let n = idx.len() as f64;
    let c: Vector3<f64> = idx
        .iter()
        .map(|&i| Vector3::from(obs[i].world))
        .sum::<Vector3<f64>>()
        / n;
    let a = DMatrix::from_row_iterator(
        idx.len(),
        3,
        idx.iter().flat_map(|&i| {
            (Vector3::from(obs[i].world) - c)
                .iter()
                .copied()
                .collect::<Vec<_>>()
        }),
    );
    let svd = a.svd(false, true);
    let mut order: Vec<usize> = (0..3).collect();
    order.sort_by(|&x, &y| svd.singular_values[y].total_cmp(&svd.singular_values[x]));
    let v_t = svd.v_t.unwrap_or_else(|| DMatrix::identity(3, 3));
    let basis = nalgebra::Matrix3::from_rows(&[
        v_t.row(order[0])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
        v_t.row(order[1])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
        v_t.row(order[2])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
    ]);
    (
        [
            svd.singular_values[order[0]],
            svd.singular_values[order[1]],
            svd.singular_values[order[2]],
        ],
        c,
        basis,
    )
}

/// Starting intrinsics and poses.
fn start(
    obs: &[Observation],
    views: &[Vec<usize>],
    ids: &[String],
    opts: &CalibrationOptions,
) -> Result<(nalgebra::Matrix3<f64>, Vec<Pose>), CalibrationError> {
    let all: Vec<usize> = (0..obs.len()).collect();
    let (sv, c, basis) = spread(obs, &all);
    let planar = sv[2] <= 1e-9 * sv[0];
    for (id, v) in ids.iter().zip(views) {
        let (s, _, _) = spread(obs, v);
        if s[1] <= 1e-9 * s[0] {
            return Err(CalibrationError::Collinear { image: id.clone() });
        }
    }
    if planar {
        if views.len() == 1 {
            return Err(CalibrationError::PlanarSingleImage);
        }
        // Plane coordinates (a, b) = first two basis rows of (X - c).
        let to_plane = |w: [f64; 3]| {
            let d = basis * (Vector3::from(w) - c);
            [d[0], d[1]]
        };
        let data: Vec<PlaneView> = views
            .iter()
            .map(|v| {
                (
                    v.iter().map(|&i| to_plane(obs[i].world)).collect(),
                    v.iter().map(|&i| obs[i].pixel).collect(),
                )
            })
            .collect();
        let (k, poses) = zhang(&data, opts.image_size.centre())?;
        // X_c = R_p (B (X - c)) + t_p  =>  R = R_p B, t = t_p - R c (B is a rotation or a reflection).
        let mut b = basis;
        if b.determinant() < 0.0 {
            b.row_mut(2).neg_mut();
        }
        let poses = poses
            .into_iter()
            .map(|p| {
                let r = Rotation3::from_scaled_axis(p.w).matrix() * b;
                let rot = Rotation3::from_matrix_unchecked(r);
                Pose {
                    w: rot.scaled_axis(),
                    t: p.t - r * c,
                }
            })
            .collect();
        Ok((k, poses))
    } else {
        let mut k0 = None;
        let mut poses = vec![];
        for v in views {
            let w: Vec<[f64; 3]> = v.iter().map(|&i| obs[i].world).collect();
            let p: Vec<[f64; 2]> = v.iter().map(|&i| obs[i].pixel).collect();
            let (k, pose) = dlt(&w, &p)?;
            k0.get_or_insert(k);
            poses.push(pose);
        }
        Ok((
            k0.ok_or(CalibrationError::TooFewPoints { got: 0, need: 6 })?,
            poses,
        ))
    }
}

/// One adjustment with the options as given (`calibrate` adds the identifiability check).
pub(crate) fn calibrate_once(
    obs: &[Observation],
    opts: &CalibrationOptions,
) -> Result<CalibrationReport, CalibrationError> {
    let plan = plan(obs, opts)?;
    let mut res = minimise(
        &plan.problem,
        plan.z0.clone(),
        opts.max_iterations,
        opts.stop_px,
        point_shift,
    );
    report(&plan.problem, &mut res, &plan.global, &plan.ids, opts)
}

/// The largest change of a predicted point (pixels) for a change `dr` of the residuals.
pub(super) fn point_shift(dr: &DVector<f64>) -> f64 {
    (0..dr.len() / 2)
        .map(|i| dr[2 * i].hypot(dr[2 * i + 1]))
        .fold(0.0, f64::max)
}

/// A checked, started adjustment: the problem, its starting free vector, the global
/// parameters' names and the image ids.
pub(super) struct Plan<'a> {
    pub problem: Calib<'a>,
    pub z0: DVector<f64>,
    pub global: Vec<&'static str>,
    pub ids: Vec<String>,
}

/// Checks the points and options and finds the starting values.
pub(super) fn plan<'a>(
    obs: &'a [Observation],
    opts: &CalibrationOptions,
) -> Result<Plan<'a>, CalibrationError> {
    if obs.len() < 6 {
        return Err(CalibrationError::TooFewPoints {
            got: obs.len(),
            need: 6,
        });
    }
    let (ids, views) = group(obs, 4)?;
    if views.len() == 1 && views[0].len() < 6 {
        // One image of a 3-D field: the DLT needs six points.
        return Err(CalibrationError::TooFewInImage {
            image: ids[0].clone(),
            got: views[0].len(),
            need: 6,
        });
    }
    check_inside(obs, opts.image_size)?;
    let (k, poses) = start(obs, &views, &ids, opts)?;
    let names = opts.model.model().names();
    let mut full0 = vec![
        k[(0, 0)],
        k[(1, 1)],
        k[(0, 2)],
        k[(1, 2)],
        if opts.skew { k[(0, 1)] } else { 0.0 },
    ];
    full0.extend(opts.model.model().params());
    for p in &poses {
        full0.extend(p.w.iter().chain(p.t.iter()));
    }
    for f in &opts.fix {
        // OpenCV's twelve names are accepted for any of its variants (`--fix k4,k5,k6` on the
        // five-term model holds terms it does not have).
        let known = opts.model.all_coefficient_names();
        if !INTRINSICS.contains(&f.as_str()) && !known.contains(&f.as_str()) {
            return Err(CalibrationError::UnknownParameter(f.clone()));
        }
    }
    let held = held_terms(opts);
    let is_fixed = |name: &str| {
        opts.fix.iter().any(|f| f == name)
            || held.iter().any(|(term, _)| *term == name)
            || (name == "skew" && !opts.skew)
            || (name == "fy" && opts.fixed_aspect.is_some())
    };
    let global: Vec<&'static str> = INTRINSICS
        .iter()
        .copied()
        .chain(names.iter().copied())
        .collect();
    let free: Vec<usize> = (0..full0.len())
        .filter(|&i| i >= global.len() || !is_fixed(global[i]))
        .collect();
    let aspect = opts.fixed_aspect;
    if let Some(a) = aspect {
        full0[1] = full0[0] * a;
    }
    let z0 = DVector::from_iterator(free.len(), free.iter().map(|&i| full0[i]));
    let problem = Calib::new(obs, views, opts.model.clone(), free, full0, aspect);
    Ok(Plan {
        problem,
        z0,
        global,
        ids,
    })
}

fn report(
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
fn held_terms(opts: &CalibrationOptions) -> Vec<(&'static str, &'static str)> {
    let fixed = |name: &str| opts.fix.iter().any(|f| f == name);
    opts.model
        .duplicates()
        .iter()
        .copied()
        .filter(|(term, partner)| !fixed(term) && !fixed(partner))
        .collect()
}

/// Every measured point must lie in the image (pixel centres at integers: -0.5 .. W - 0.5).
fn check_inside(obs: &[Observation], size: ImageSize) -> Result<(), CalibrationError> {
    let (w, h) = (size.width as f64, size.height as f64);
    let inside = |p: [f64; 2]| (-0.5..=w - 0.5).contains(&p[0]) && (-0.5..=h - 0.5).contains(&p[1]);
    match obs.iter().position(|o| !inside(o.pixel)) {
        None => Ok(()),
        Some(i) => Err(CalibrationError::OutsideImage {
            index: i + 1,
            image: obs[i].image.clone(),
            pixel: obs[i].pixel,
            size,
        }),
    }
}
