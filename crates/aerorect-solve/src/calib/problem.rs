//! The calibration problem: parameter layout with named blocks, residuals and the analytic
//! normal equations (planned and run by `plan`).

use super::blocks::{BlockNormal, ViewBlock};
use super::inputs::Observation;
use super::jacobian::{
    PointScratch, PoseFrame, intrinsics_from_slice, residual, residual_jacobian,
};
use super::lm::Problem;
use aerorect_core::distortion::Distortion;
use nalgebra::{DVector, Vector3};

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
