//! The calibration's normal equations in blocks. The global parameters (intrinsics and lens
//! coefficients, g of them) couple every view; each view's pose (rotation vector and
//! translation) touches only its own points, so J^T J is
//!
//! ```text
//! [ U    W_1  W_2 ... ]      U   = sum_v Jg_v^T Jg_v    (g x g)
//! [ W_1' V_1          ]      W_v = Jg_v^T Jp_v          (g x 6)
//! [ W_2'      V_2     ]      V_v = Jp_v^T Jp_v          (6 x 6)
//! ```
//!
//! and the damped system is solved by the Schur complement on the global block:
//! (U - sum W_v V_v^-1 W_v^T) dg = -g_g + sum W_v V_v^-1 g_v, then dp_v = V_v^-1 (-g_v - W_v^T dg).
//! The blocks are products of nalgebra matrices and the solves nalgebra's Cholesky; the
//! buffers (each view's Jacobian rows among them) are made once per adjustment.

use nalgebra::{DMatrix, DVector, Dyn, Matrix6, OMatrix, U6, Vector6};

/// A matrix of six columns (a view's pose derivatives).
pub(crate) type Cols6 = OMatrix<f64, Dyn, U6>;

/// One view's blocks and its Jacobian rows.
pub(crate) struct ViewBlock {
    /// d r / d globals for the view's residuals (2 n x g).
    pub jg: DMatrix<f64>,
    /// d r / d pose (2 n x 6).
    pub jp: Cols6,
    /// The view's residuals (2 n), in the rows' order.
    pub r: DVector<f64>,
    v: Matrix6<f64>,
    w: Cols6,
    gp: Vector6<f64>,
    /// V^-1 W^T and V^-1 g_v of the last reduction.
    vinv_wt: OMatrix<f64, U6, Dyn>,
    vinv_g: Vector6<f64>,
}

pub(crate) struct BlockNormal {
    pub views: Vec<ViewBlock>,
    u: DMatrix<f64>,
    gg: DVector<f64>,
    s: DMatrix<f64>,
    rhs: DVector<f64>,
}

impl BlockNormal {
    /// Buffers for `globals` free global parameters and views of `points` points each.
    pub fn new(globals: usize, points: impl Iterator<Item = usize>) -> Self {
        let views = points
            .map(|n| ViewBlock {
                jg: DMatrix::zeros(2 * n, globals),
                jp: Cols6::zeros(2 * n),
                r: DVector::zeros(2 * n),
                v: Matrix6::zeros(),
                w: Cols6::zeros(globals),
                gp: Vector6::zeros(),
                vinv_wt: OMatrix::<f64, U6, Dyn>::zeros(globals),
                vinv_g: Vector6::zeros(),
            })
            .collect();
        BlockNormal {
            views,
            u: DMatrix::zeros(globals, globals),
            gg: DVector::zeros(globals),
            s: DMatrix::zeros(globals, globals),
            rhs: DVector::zeros(globals),
        }
    }

    /// Forms the blocks from each view's `jg`, `jp` and `r`.
    pub fn assemble(&mut self) {
        self.u.fill(0.0);
        self.gg.fill(0.0);
        for b in &mut self.views {
            self.u.gemm_tr(1.0, &b.jg, &b.jg, 1.0);
            self.gg.gemv_tr(1.0, &b.jg, &b.r, 1.0);
            b.w.gemm_tr(1.0, &b.jg, &b.jp, 0.0);
            b.v.gemm_tr(1.0, &b.jp, &b.jp, 0.0);
            b.gp.gemv_tr(1.0, &b.jp, &b.r, 0.0);
        }
    }

    /// The damped Schur complement in `s` and its right-hand side in `rhs`; false when a damped
    /// pose block is not positive definite.
    fn reduce(&mut self, lambda: f64) -> bool {
        self.s.copy_from(&self.u);
        for k in 0..self.s.nrows() {
            self.s[(k, k)] += lambda * self.u[(k, k)].max(1e-12);
        }
        self.rhs.copy_from(&self.gg);
        self.rhs.neg_mut();
        for b in &mut self.views {
            let mut vd = b.v;
            for k in 0..6 {
                vd[(k, k)] += lambda * b.v[(k, k)].max(1e-12);
            }
            let Some(chol) = vd.cholesky() else {
                return false;
            };
            b.vinv_wt.tr_copy_from(&b.w);
            chol.solve_mut(&mut b.vinv_wt);
            b.vinv_g = chol.solve(&b.gp);
            self.s.gemm(-1.0, &b.w, &b.vinv_wt, 1.0);
            self.rhs.gemv(1.0, &b.w, &b.vinv_g, 1.0);
        }
        true
    }

    /// The covariance of the global parameters up to the residual variance: the global block
    /// of (J^T J)^-1, which is the inverse of the undamped Schur complement. None when J^T J is
    /// singular.
    pub fn global_inverse(&mut self) -> Option<DMatrix<f64>> {
        if !self.reduce(0.0) {
            return None;
        }
        self.s.clone().try_inverse()
    }
}

impl super::lm::NormalEquations for BlockNormal {
    fn solve_damped(&mut self, lambda: f64, dx: &mut DVector<f64>) -> bool {
        if !self.reduce(lambda) {
            return false;
        }
        let ng = self.s.nrows();
        let Some(chol) = self.s.clone().cholesky() else {
            return false;
        };
        let dg = chol.solve(&self.rhs);
        dx.rows_mut(0, ng).copy_from(&dg);
        for (k, b) in self.views.iter().enumerate() {
            let dp = -(b.vinv_g + &b.vinv_wt * &dg);
            dx.fixed_rows_mut::<6>(ng + 6 * k).copy_from(&dp);
        }
        true
    }
}
