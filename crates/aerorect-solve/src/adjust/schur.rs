//! The damped reduced system: the tie points eliminated block by block (Schur complement),
//! and the frame-and-camera system, sparse because frames only meet their neighbours,
//! factorised with faer's sparse Cholesky.

use super::linear::{CHUNK, Linear, PART, Partial, PointLin};
use super::normal::SymBlocks;
use aerorect_core::Vec3;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::Matrix3;
use rayon::prelude::*;

/// The damped reduced system and its right-hand side.
pub(super) type Reduced = (SymBlocks, Vec<f64>);

impl Linear {
    /// The damped reduced system (points eliminated) and its right-hand side; each point's
    /// damped H_pp^-1 (none where it is singular) in `inverses`, which is cleared first. The
    /// points' Schur blocks are taken [`PART`] at a time in parallel, each part summed into its
    /// own matrix, and the parts are added in point order: the same sums whatever the number
    /// of threads.
    pub fn reduced(&self, lambda: f64, inverses: &mut Vec<Option<Matrix3<f64>>>) -> Reduced {
        let mut entries = self.entries.clone();
        for i in 0..self.rhs.len() {
            let d = entries.entry(i, i);
            *d += lambda * d.max(1e-9);
        }
        let mut rhs = self.rhs.clone();
        inverses.clear();
        for points in self.points.chunks(CHUNK) {
            let parts: Vec<(Partial, Vec<Option<Matrix3<f64>>>)> = points
                .par_chunks(PART)
                .map(|points| {
                    let mut sum = Partial::new(&entries, rhs.len());
                    let mut work = SchurWork::default();
                    let inverses = points
                        .iter()
                        .map(|p| work.eliminate(p, self.hpc(p), lambda, &mut sum))
                        .collect();
                    (sum, inverses)
                })
                .collect();
            for (sum, part) in parts {
                sum.add_to(&mut entries, &mut rhs);
                inverses.extend(part);
            }
        }
        (entries, rhs)
    }
}

/// A part's working space for eliminating its points, kept from point to point.
#[derive(Default)]
struct SchurWork {
    /// H_pp^-1 H_pc, by column.
    t: Vec<Vec3>,
    idx: Vec<usize>,
    outer: Vec<f64>,
}

impl SchurWork {
    /// Eliminates point `p` (its rows of H_cp `hpc`) at damping `lambda` from a part's sums:
    /// S -= H_cp H_pp^-1 H_pc over the point's reduced indices, rhs -= H_cp H_pp^-1 b_p.
    /// Returns its damped H_pp^-1, `None` (and nothing subtracted) where that is singular.
    fn eliminate(
        &mut self,
        p: &PointLin,
        hpc: &[(usize, Vec3)],
        lambda: f64,
        sum: &mut Partial,
    ) -> Option<Matrix3<f64>> {
        let mut hpp = p.hpp;
        for k in 0..3 {
            hpp[(k, k)] += lambda * p.hpp[(k, k)].max(1e-9);
        }
        let inv = hpp.try_inverse()?;
        self.t.clear();
        self.t.extend(hpc.iter().map(|(_, v)| inv * v));
        let ib = inv * p.bp;
        let n = hpc.len();
        self.outer.clear();
        self.outer.resize(n * n, 0.0);
        for (a, (i, va)) in hpc.iter().enumerate() {
            for (b, tb) in self.t[..=a].iter().enumerate() {
                let v = -va.dot(tb);
                self.outer[a * n + b] = v;
                self.outer[b * n + a] = v;
            }
            sum.rhs[*i] -= va.dot(&ib);
        }
        self.idx.clear();
        self.idx.extend(hpc.iter().map(|(i, _)| *i));
        sum.entries.add_dense(&self.idx, &self.outer);
        Some(inv)
    }
}

/// Factorises a symmetric system given by its entries (both triangles).
pub(super) fn factor(
    n: usize,
    entries: &SymBlocks,
) -> Option<faer::sparse::linalg::solvers::Llt<usize, f64>> {
    let triplets: Vec<Triplet<usize, usize, f64>> = entries
        .lower_triplets()
        .into_iter()
        .map(|(i, j, v)| Triplet::new(i, j, v))
        .collect();
    let m = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).ok()?;
    m.sp_cholesky(faer::Side::Lower).ok()
}

pub(super) fn solve_with(
    llt: &faer::sparse::linalg::solvers::Llt<usize, f64>,
    rhs: &[f64],
) -> Vec<f64> {
    let b = faer::Mat::<f64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
    let x = llt.solve(&b);
    (0..rhs.len()).map(|i| x[(i, 0)]).collect()
}
