//! The calibration problem: parameter layout with named blocks, residuals and the analytic
//! normal equations, and the planned, checked adjustment.

use super::CalibrationError;
use super::blocks::{BlockNormal, ViewBlock};
use super::inputs::{CalibrationOptions, Observation};
use super::jacobian::{
    PointScratch, PoseFrame, intrinsics_from_slice, residual, residual_jacobian,
};
use super::lm::{Problem, minimise};
use super::report::{CalibrationReport, held_terms, report};
use super::start::{check_inside, group, start};
use aerorect_core::distortion::Distortion;
use nalgebra::{DVector, Vector3};

const INTRINSICS: [&str; 5] = ["fx", "fy", "cx", "cy", "skew"];

/// The adjustment: parameter vector = [fx, fy, cx, cy, skew, coefficients.., (w, t) per view].
/// The free parameters are the free globals (in that order) followed by every view's pose.
pub(super) struct Calib<'a> {
    pub(super) obs: &'a [Observation],
    /// Observation indices per view.
    pub(super) views: Vec<Vec<usize>>,
    /// Each view's world points and pixels, in the view's order (planned once).
    world: Vec<Vec<Vector3<f64>>>,
    pixel: Vec<Vec<[f64; 2]>>,
    model: Distortion,
    pub(super) nd: usize,
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
