//! The damped reduced system: the tie points eliminated block by block (Schur complement),
//! and the frame-and-camera system, sparse because frames only meet their neighbours,
//! factorised with faer's sparse Cholesky.

use super::linear::{CHUNK, Linear, PART, Partial, PointLin};
use super::normal::SymBlocks;
use aerorect_core::Vec3;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::cholesky::{
    SymbolicCholesky, SymbolicCholeskyRaw, factorize_symbolic_cholesky, supernodal,
};
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::{Conj, Par};
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

/// The lower triangle of a symmetric system given by its entries (both triangles). Its
/// columns come sorted and without repeats from [`SymBlocks::lower_columns`], as faer checks.
fn lower(n: usize, entries: &SymBlocks) -> Option<SparseColMat<usize, f64>> {
    let (col_ptr, rows, values) = entries.lower_columns();
    if col_ptr.len() != n + 1 {
        return None;
    }
    let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, rows);
    Some(SparseColMat::new(pattern, values))
}

/// Factorises symmetric systems given by their entries (both triangles), keeping the last
/// one's symbolic factorisation (its fill-reducing ordering and elimination tree) for the
/// next system of the same pattern: the steps of one solve share theirs. On the 1,000-frame
/// fixed wing the symbolic part (its ordering, then its elimination tree) was about a third of
/// each step's factorisation in a profile, all of it on one thread.
#[derive(Default)]
pub(super) struct Factoriser {
    /// The lower triangle's pattern (column starts, row indices) and its symbolic factor.
    last: Option<(Vec<usize>, Vec<usize>, SymbolicLlt<usize>)>,
}

impl Factoriser {
    /// The Cholesky factor of the system; none where it is not positive definite.
    pub fn factor(&mut self, n: usize, entries: &SymBlocks) -> Option<Llt<usize, f64>> {
        let m = lower(n, entries)?;
        let pattern = m.symbolic();
        let symbolic = match &self.last {
            Some((cols, rows, s)) if cols == pattern.col_ptr() && rows == pattern.row_idx() => {
                s.clone()
            }
            _ => {
                let s = SymbolicLlt::try_new(pattern, faer::Side::Lower).ok()?;
                let (cols, rows) = (pattern.col_ptr().to_vec(), pattern.row_idx().to_vec());
                self.last = Some((cols, rows, s.clone()));
                s
            }
        };
        Llt::try_new_with_symbolic(symbolic, m.as_ref(), faer::Side::Lower).ok()
    }
}

/// Columns of the identity solved at a time by [`inverse_diagonal`] (the factor's blocked
/// solve), the blocks in parallel.
const INVERSE_BLOCK: usize = 256;

/// The diagonal of the inverse of a symmetric positive definite system given by its entries
/// (both triangles); none where it does not factorise. With the system permuted as
/// P A P^T = L L^T, entry k is the squared norm of L^-1 e_m for m = P k: one triangular
/// solve per column instead of the two of a solve with A. On the 1,000-frame fixed wing
/// (6,000 parameters, 1.6 M tie points) its standard deviations agree with those of a solve
/// with A to 3e-15 (relative), and its final solve, with [`super::solve::Storage`] kept for
/// them too, took 13.7 / 15.0 / 13.9 s against 18.1 / 18.0 / 15.9 / 16.1 s, runs alternating.
pub(super) fn inverse_diagonal(n: usize, entries: &SymBlocks) -> Option<Vec<f64>> {
    let (symbolic, values) = factor_parts(n, entries)?;
    let starts: Vec<usize> = (0..n).step_by(INVERSE_BLOCK).collect();
    let permuted: Vec<f64> = starts
        .par_iter()
        .map(|&start| {
            let cols = INVERSE_BLOCK.min(n - start);
            let x = l_inverse_columns((&symbolic, &values), start, cols)?;
            Some(
                (0..cols)
                    .map(|j| x.col(j).squared_norm_l2())
                    .collect::<Vec<f64>>(),
            )
        })
        .collect::<Option<Vec<Vec<f64>>>>()?
        .concat();
    Some(match symbolic.perm() {
        Some(p) => p.arrays().1.iter().map(|&m| permuted[m]).collect(),
        None => permuted,
    })
}

/// The sparse Cholesky factor of a symmetric system given by its entries: its structure
/// (with the fill-reducing permutation) and values.
fn factor_parts(n: usize, entries: &SymBlocks) -> Option<(SymbolicCholesky<usize>, Vec<f64>)> {
    let m = lower(n, entries)?;
    let side = faer::Side::Lower;
    let symbolic =
        factorize_symbolic_cholesky(m.symbolic(), side, Default::default(), Default::default())
            .ok()?;
    let mut values = vec![0.0; symbolic.len_val()];
    let scratch = symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
    let mut mem = MemBuffer::try_new(scratch).ok()?;
    symbolic
        .factorize_numeric_llt(
            &mut values,
            m.as_ref(),
            side,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .ok()?;
    Some((symbolic, values))
}

/// L^-1 applied to columns `start..start + cols` of the identity (in the permuted order).
fn l_inverse_columns(
    (symbolic, values): (&SymbolicCholesky<usize>, &[f64]),
    start: usize,
    cols: usize,
) -> Option<faer::Mat<f64>> {
    let n = symbolic.nrows();
    let mut x = faer::Mat::<f64>::from_fn(n, cols, |i, j| f64::from(u8::from(i == start + j)));
    match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => {
            let l = faer::sparse::SparseColMatRef::new(s.factor(), values);
            faer::sparse::linalg::triangular_solve::solve_lower_triangular_in_place(
                l,
                Conj::No,
                x.as_mut(),
                Par::Seq,
            );
        }
        SymbolicCholeskyRaw::Supernodal(s) => {
            let scratch = s.solve_in_place_scratch::<f64>(cols, Par::Seq);
            let mut mem = MemBuffer::try_new(scratch).ok()?;
            supernodal::SupernodalLltRef::new(s, values).l_solve_with_conj(
                Conj::No,
                x.as_mut(),
                Par::Seq,
                MemStack::new(&mut mem),
            );
        }
    }
    Some(x)
}

pub(super) fn solve_with(llt: &Llt<usize, f64>, rhs: &[f64]) -> Vec<f64> {
    let b = faer::Mat::<f64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
    let x = llt.solve(&b);
    (0..rhs.len()).map(|i| x[(i, 0)]).collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::super::normal::Blocks;
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::sync::Arc;

    /// A symmetric positive definite system of `blocks` blocks of `len` parameters, each
    /// block coupled with the `reach` blocks after it (a strip of frames), as block storage
    /// and as a dense matrix.
    fn banded(
        blocks: usize,
        len: usize,
        reach: usize,
        seed: u64,
    ) -> (SymBlocks, nalgebra::DMatrix<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = blocks * len;
        let mut dense = nalgebra::DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in 0..i {
                if (i / len).abs_diff(j / len) <= reach {
                    let v = rng.random_range(-1.0..1.0);
                    dense[(i, j)] = v;
                    dense[(j, i)] = v;
                }
            }
        }
        // Diagonally dominant: positive definite.
        for i in 0..n {
            let row: f64 = dense.row(i).iter().map(|v| v.abs()).sum();
            dense[(i, i)] = row + rng.random_range(0.5..2.0);
        }
        let mut sym = SymBlocks::new(Arc::new(Blocks::new(vec![len; blocks])));
        for i in 0..n {
            for j in 0..n {
                if dense[(i, j)] != 0.0 {
                    *sym.entry(i, j) += dense[(i, j)];
                }
            }
        }
        (sym, dense)
    }

    /// The inverse's diagonal from one triangular solve per column equals the dense
    /// inverse's, for a system faer factorises simplicially (scalar blocks, a narrow band)
    /// and one it factorises in supernodes (frame-sized blocks, a wide band), more columns
    /// than one block of solves.
    #[test]
    fn the_inverse_diagonal_is_the_dense_inverses() {
        for (blocks, len, reach, supernodal) in [(300, 1, 1, false), (40, 12, 8, true)] {
            let (sym, dense) = banded(blocks, len, reach, blocks as u64);
            let n = blocks * len;
            let m = lower(n, &sym).unwrap();
            let raw = factorize_symbolic_cholesky(
                m.symbolic(),
                faer::Side::Lower,
                Default::default(),
                Default::default(),
            )
            .unwrap();
            assert_eq!(
                matches!(raw.raw(), SymbolicCholeskyRaw::Supernodal(_)),
                supernodal,
                "{blocks} blocks of {len}"
            );
            let got = inverse_diagonal(n, &sym).unwrap();
            let inv = dense.try_inverse().unwrap();
            assert!(n > INVERSE_BLOCK);
            for (k, g) in got.iter().enumerate() {
                let want = inv[(k, k)];
                assert!((g - want).abs() <= 1e-12 * want.abs(), "{k}: {g} vs {want}");
            }
        }
    }

    /// The factoriser solves each system of a sequence like the dense inverse does: new
    /// values on the pattern it holds (the symbolic factor reused), then a wider pattern
    /// and a narrower one (each needs its own), then the first again.
    #[test]
    fn a_kept_symbolic_factor_serves_only_its_own_pattern() {
        let mut f = Factoriser::default();
        for (k, reach) in [1, 1, 3, 0, 1].into_iter().enumerate() {
            let (sym, dense) = banded(30, 6, reach, 7 + k as u64);
            let n = 180;
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            let got = solve_with(&f.factor(n, &sym).unwrap(), &rhs);
            let want = dense.try_inverse().unwrap() * nalgebra::DVector::from_vec(rhs);
            for (i, g) in got.iter().enumerate() {
                assert!(
                    (g - want[i]).abs() <= 1e-10,
                    "system {k}, {i}: {g} vs {}",
                    want[i]
                );
            }
        }
    }

    /// The compressed columns built block by block are faer's own assembly of the sorted
    /// lower-triangle triplets, bit for bit: scalar blocks, frame-sized ones, and blocks of
    /// mixed lengths met in any order.
    #[test]
    fn the_lower_columns_are_faers_assembly_of_the_triplets() {
        let mixed = {
            let blocks = Arc::new(Blocks::new([6, 1, 9, 3, 6]));
            let mut sym = SymBlocks::new(blocks);
            for (i, j) in [(20, 2), (0, 0), (7, 15), (12, 3), (24, 24), (8, 7), (3, 20)] {
                *sym.entry(i, j) += (i * 31 + j) as f64 + 0.5;
                *sym.entry(j, i) += (i * 31 + j) as f64 + 0.5;
            }
            (sym, 25)
        };
        for (sym, n) in [
            (banded(40, 1, 2, 3).0, 40),
            (banded(12, 6, 3, 4).0, 72),
            mixed,
        ] {
            let got = lower(n, &sym).unwrap();
            let triplets: Vec<_> = sym
                .lower_triplets()
                .into_iter()
                .map(|(i, j, v)| faer::sparse::Triplet::new(i, j, v))
                .collect();
            let want = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).unwrap();
            assert_eq!(got.symbolic().col_ptr(), want.symbolic().col_ptr());
            assert_eq!(got.symbolic().row_idx(), want.symbolic().row_idx());
            let bits = |m: &SparseColMat<usize, f64>| -> Vec<u64> {
                m.val().iter().map(|v| v.to_bits()).collect()
            };
            assert_eq!(bits(&got), bits(&want));
        }
    }

    /// A system that is not positive definite has no such diagonal.
    #[test]
    fn an_indefinite_system_has_no_inverse_diagonal() {
        let (mut sym, _) = banded(10, 3, 1, 1);
        *sym.entry(4, 4) = -100.0;
        assert!(inverse_diagonal(30, &sym).is_none());
    }
}
