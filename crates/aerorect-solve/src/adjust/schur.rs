//! The damped reduced system: the tie points eliminated block by block (Schur complement),
//! and the frame-and-camera system, sparse because frames only meet their neighbours,
//! factorised with faer's sparse Cholesky.

use super::linear::{CHUNK, Linear, PART, Partial, PointLin};
use super::normal::SymBlocks;
use aerorect_core::Vec3;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymbolicCholeskyRaw, factorize_symbolic_cholesky, supernodal,
};
use faer::sparse::{SparseColMat, SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};
use nalgebra::Matrix3;
use rayon::prelude::*;
use std::sync::Arc;

/// The damped reduced system and its right-hand side.
pub(super) type Reduced = (SymBlocks, Vec<f64>);

/// Each point's damped H_pp^-1 (none where it is singular), part by part as
/// [`Linear::parts`].
pub(super) type Inverses = Vec<Vec<Option<Matrix3<f64>>>>;

impl Linear {
    /// The damped reduced system (points eliminated) and its right-hand side; each point's
    /// damped H_pp^-1 in `inverses`, whose earlier contents are dropped (their memory kept).
    /// The parts' Schur blocks are taken in parallel, each part summed into its own matrix,
    /// and the parts are added in point order: the same sums whatever the number of threads.
    pub fn reduced(&self, lambda: f64, inverses: &mut Inverses) -> Reduced {
        let mut entries = self.entries.clone();
        for i in 0..self.rhs.len() {
            let d = entries.entry(i, i);
            *d += lambda * d.max(1e-9);
        }
        let mut rhs = self.rhs.clone();
        inverses.resize_with(self.parts.len(), Vec::new);
        let per_chunk = CHUNK / PART;
        for (parts, invs) in self
            .parts
            .chunks(per_chunk)
            .zip(inverses.chunks_mut(per_chunk))
        {
            let sums: Vec<Partial> = parts
                .par_iter()
                .zip(invs.par_iter_mut())
                .map(|(part, inverses)| {
                    let mut sum = Partial::new(&entries, rhs.len());
                    let mut work = SchurWork::default();
                    inverses.clear();
                    inverses.extend(
                        (part.points.iter())
                            .map(|p| work.eliminate(p, part.hpc(p), lambda, &mut sum)),
                    );
                    sum.flushed()
                })
                .collect();
            for sum in sums {
                sum.add_to(&mut entries, &mut rhs);
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
        self.idx.clear();
        self.idx.extend(hpc.iter().map(|(i, _)| *i));
        let outer = sum.gathered.sum_at(&mut sum.entries, &self.idx);
        for (a, (_, va)) in hpc.iter().enumerate() {
            for (b, tb) in self.t[..=a].iter().enumerate() {
                outer[a * n + b] -= va.dot(tb);
            }
        }
        for (i, va) in hpc {
            sum.rhs[*i] -= va.dot(&ib);
        }
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
/// next system of the same pattern: the steps of one solve share theirs, and so do the
/// standard deviations after them. On the 1,000-frame fixed wing the symbolic part (its
/// ordering, then its elimination tree) was about a third of each step's factorisation in a
/// profile, all of it on one thread.
#[derive(Default)]
pub(super) struct Factoriser {
    /// The lower triangle's pattern and its symbolic factor.
    last: Option<(Pattern, Arc<SymbolicCholesky<usize>>)>,
}

/// A lower triangle's pattern: its column starts and row indices.
type Pattern = (Vec<usize>, Vec<usize>);

/// A system's Cholesky factor P A P^T = L L^T: its structure (with the fill-reducing
/// permutation P) and L's values.
pub(super) struct Factor {
    symbolic: Arc<SymbolicCholesky<usize>>,
    values: Vec<f64>,
}

impl Factoriser {
    /// The Cholesky factor of the system, its numeric part computed with `par`; none where
    /// the system is not positive definite.
    pub fn factor(&mut self, n: usize, entries: &SymBlocks, par: Par) -> Option<Factor> {
        let m = lower(n, entries)?;
        let symbolic = self.symbolic(m.symbolic())?;
        let mut values = vec![0.0; symbolic.len_val()];
        let scratch = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
        let mut mem = MemBuffer::try_new(scratch).ok()?;
        symbolic
            .factorize_numeric_llt(
                &mut values,
                m.as_ref(),
                Side::Lower,
                Default::default(),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .ok()?;
        Some(Factor { symbolic, values })
    }

    /// The symbolic factor of a lower triangle of this `pattern`: the last one's when the
    /// pattern is the last one's.
    fn symbolic(
        &mut self,
        pattern: SymbolicSparseColMatRef<'_, usize>,
    ) -> Option<Arc<SymbolicCholesky<usize>>> {
        if let Some(((cols, rows), s)) = &self.last
            && cols == pattern.col_ptr()
            && rows == pattern.row_idx()
        {
            return Some(Arc::clone(s));
        }
        let s = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            Default::default(),
            Default::default(),
        );
        let s = Arc::new(s.ok()?);
        let kept = (pattern.col_ptr().to_vec(), pattern.row_idx().to_vec());
        self.last = Some((kept, Arc::clone(&s)));
        Some(s)
    }
}

impl Factor {
    /// The solution x of A x = `rhs`.
    pub fn solve(&self, rhs: &[f64]) -> Option<Vec<f64>> {
        let par = faer::get_global_parallelism();
        let mut x = faer::Mat::<f64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
        let scratch = self.symbolic.solve_in_place_scratch::<f64>(1, par);
        let mut mem = MemBuffer::try_new(scratch).ok()?;
        LltRef::new(&self.symbolic, &self.values).solve_in_place_with_conj(
            Conj::No,
            x.as_mut(),
            par,
            MemStack::new(&mut mem),
        );
        Some((0..rhs.len()).map(|i| x[(i, 0)]).collect())
    }

    /// The diagonal of A's inverse. Entry k is the squared norm of L^-1 e_m for m = P k: one
    /// triangular solve per column instead of the two of a solve with A. On the 1,000-frame
    /// fixed wing (6,000 parameters, 1.6 M tie points) its standard deviations agree with those
    /// of a solve with A to 3e-15 (relative), and its final solve, with
    /// [`super::solve::Storage`] kept for them too, took 13.7 / 15.0 / 13.9 s against 18.1 /
    /// 18.0 / 15.9 / 16.1 s, runs alternating.
    pub fn inverse_diagonal(&self) -> Option<Vec<f64>> {
        let n = self.symbolic.nrows();
        let starts: Vec<usize> = (0..n).step_by(INVERSE_BLOCK).collect();
        let permuted: Vec<f64> = starts
            .par_iter()
            .map(|&start| {
                let cols = INVERSE_BLOCK.min(n - start);
                let x = self.l_inverse_columns(start, cols)?;
                Some(
                    (0..cols)
                        .map(|j| x.col(j).squared_norm_l2())
                        .collect::<Vec<f64>>(),
                )
            })
            .collect::<Option<Vec<Vec<f64>>>>()?
            .concat();
        Some(match self.symbolic.perm() {
            Some(p) => p.arrays().1.iter().map(|&m| permuted[m]).collect(),
            None => permuted,
        })
    }

    /// L^-1 applied to columns `start..start + cols` of the identity (in the permuted order).
    fn l_inverse_columns(&self, start: usize, cols: usize) -> Option<faer::Mat<f64>> {
        let n = self.symbolic.nrows();
        let mut x = faer::Mat::<f64>::from_fn(n, cols, |i, j| f64::from(u8::from(i == start + j)));
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                let l = faer::sparse::SparseColMatRef::new(s.factor(), &self.values);
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
                supernodal::SupernodalLltRef::new(s, &self.values).l_solve_with_conj(
                    Conj::No,
                    x.as_mut(),
                    Par::Seq,
                    MemStack::new(&mut mem),
                );
            }
        }
        Some(x)
    }
}

/// Columns of the identity solved at a time by [`Factor::inverse_diagonal`] (the factor's
/// blocked solve), the blocks in parallel.
const INVERSE_BLOCK: usize = 256;

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
            let factor = Factoriser::default().factor(n, &sym, Par::Seq).unwrap();
            assert_eq!(
                matches!(factor.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)),
                supernodal,
                "{blocks} blocks of {len}"
            );
            let got = factor.inverse_diagonal().unwrap();
            let inv = dense.try_inverse().unwrap();
            assert!(n > INVERSE_BLOCK);
            for (k, g) in got.iter().enumerate() {
                let want = inv[(k, k)];
                assert!((g - want).abs() <= 1e-12 * want.abs(), "{k}: {g} vs {want}");
            }
        }
    }

    /// The factoriser solves each system of a sequence, and gives its inverse's diagonal, as
    /// the dense inverse does: new values on the pattern it holds (the symbolic factor
    /// reused), then a wider pattern and a narrower one (each needs its own), then the first
    /// again; the numeric factor in parallel or not.
    #[test]
    fn a_kept_symbolic_factor_serves_only_its_own_pattern() {
        let mut f = Factoriser::default();
        for (k, reach) in [1, 1, 3, 0, 1].into_iter().enumerate() {
            let (sym, dense) = banded(30, 6, reach, 7 + k as u64);
            let n = 180;
            let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
            let par = [Par::Seq, faer::get_global_parallelism()][k % 2];
            let factor = f.factor(n, &sym, par).unwrap();
            let got = factor.solve(&rhs).unwrap();
            let inverse = dense.try_inverse().unwrap();
            let want = &inverse * nalgebra::DVector::from_vec(rhs);
            for (i, g) in got.iter().enumerate() {
                assert!(
                    (g - want[i]).abs() <= 1e-10,
                    "system {k}, {i}: {g} vs {}",
                    want[i]
                );
            }
            for (i, g) in factor.inverse_diagonal().unwrap().iter().enumerate() {
                let want = inverse[(i, i)];
                assert!((g - want).abs() <= 1e-12 * want.abs(), "system {k}, {i}");
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

    /// A system that is not positive definite has no factor, so no such diagonal.
    #[test]
    fn an_indefinite_system_has_no_inverse_diagonal() {
        let (mut sym, _) = banded(10, 3, 1, 1);
        *sym.entry(4, 4) = -100.0;
        assert!(Factoriser::default().factor(30, &sym, Par::Seq).is_none());
    }
}
