//! The adjustment's undamped normal equations at one state: each observation's residual and
//! Jacobians, the frame-and-camera block summed in fixed parts of points, and each tie point's
//! own blocks for the Schur complement ([`super::schur`]).

use super::blocks::{LOCAL, State};
use super::jacobian::Posed;
use super::normal::{Gathered, SymBlocks};
use super::residuals::Problem;
use super::{Observation, TiePoint};
use aerorect_core::Vec3;
use nalgebra::{Matrix3, SMatrix, SVector};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// One tie point's blocks of the (undamped) normal equations.
pub(super) struct PointLin {
    pub hpp: Matrix3<f64>,
    /// -J_p^T W r.
    pub bp: Vec3,
    /// Its rows of H_cp, by reduced index in index order: a range of its part's
    /// [`PointsPart::hpc`] (a vector per point cost an allocation per point and linearisation).
    hpc: Range<usize>,
    /// Whether an observation is in Huber's linear arm (the point is polished after a step).
    pub robust: bool,
}

/// The blocks of [`PART`] consecutive tie points (fewer in the last part).
#[derive(Default)]
pub(super) struct PointsPart {
    pub points: Vec<PointLin>,
    /// Every point's rows of H_cp, (reduced index, row), one point after another.
    hpc: Vec<(usize, Vec3)>,
}

impl PointsPart {
    /// Point `p`'s rows of H_cp (`p` one of this part's points).
    pub fn hpc(&self, p: &PointLin) -> &[(usize, Vec3)] {
        &self.hpc[p.hpc.clone()]
    }
}

/// The undamped normal equations at one state: the frame-and-camera block (data and
/// priors), its right-hand side (-gradient) and each point's blocks.
pub(super) struct Linear {
    pub entries: SymBlocks,
    pub rhs: Vec<f64>,
    /// The points' blocks part by part, in tie order. Each part is filled, and its memory
    /// first touched, by the worker that linearises it: copied into one vector on the calling
    /// thread, the 1,000-frame flight's gigabyte of points' blocks kept the other core idle
    /// for a second or more per solve, most of it in the kernel's page clearing.
    pub parts: Vec<PointsPart>,
}

/// One observation's residual, weight and Jacobians (local columns and point).
struct Lin {
    r: SVector<f64, 2>,
    w: f64,
    local: SMatrix<f64, 2, LOCAL>,
    point: nalgebra::Matrix2x3<f64>,
    idx: [Option<usize>; LOCAL],
}

/// One part's sums: its matrix (with the additions gathered for it) and right-hand side.
pub(super) struct Partial {
    pub entries: SymBlocks,
    pub gathered: Gathered,
    pub rhs: Vec<f64>,
}

impl Partial {
    /// Zero, over `like`'s blocks and `n` parameters.
    pub(super) fn new(like: &SymBlocks, n: usize) -> Self {
        Self {
            entries: like.empty_like(),
            gathered: Gathered::default(),
            rhs: vec![0.0; n],
        }
    }

    /// The part's sums with its gathered additions sent to its matrix: done by the worker
    /// that made them (on the calling thread, they held up the other core).
    pub(super) fn flushed(mut self) -> Self {
        self.gathered.flush(&mut self.entries);
        self
    }

    /// Adds the part's sums ([`Self::flushed`]) to the whole's.
    pub(super) fn add_to(&self, entries: &mut SymBlocks, rhs: &mut [f64]) {
        debug_assert!(self.gathered.is_empty());
        entries.add_matrix(&self.entries);
        for (r, v) in rhs.iter_mut().zip(&self.rhs) {
            *r += v;
        }
    }

    /// Adds an observation's frame-camera products over the local columns that hold a
    /// reduced index (6 of 14 when attitudes and positions are solved for): H_cc = w J_c^T J_c
    /// and -J_c^T W r, formed for those columns alone. Returns each such column's row of H_cp
    /// (w J_c^T J_p) in `hpc`.
    fn add_observation(&mut self, l: &Lin, hpc: &mut Vec<(usize, Vec3)>) {
        let (mut cols, mut idx) = ([0usize; LOCAL], [0usize; LOCAL]);
        let mut n = 0;
        for (a, i) in l.idx.iter().enumerate() {
            if let Some(i) = *i {
                (cols[n], idx[n]) = (a, i);
                n += 1;
            }
        }
        let m = self.gathered.sum_at(&mut self.entries, &idx[..n]);
        for (ra, &a) in cols[..n].iter().enumerate() {
            let (j0, j1) = (l.w * l.local[(0, a)], l.w * l.local[(1, a)]);
            for (rb, &b) in cols[..=ra].iter().enumerate() {
                m[ra * n + rb] += j0 * l.local[(0, b)] + j1 * l.local[(1, b)];
            }
            self.rhs[idx[ra]] -= j0 * l.r[0] + j1 * l.r[1];
            let row = l.point.row(0).transpose() * j0 + l.point.row(1).transpose() * j1;
            hpc.push((idx[ra], row));
        }
    }
}

impl Problem<'_> {
    fn observation_lin(&self, posed: &[Posed<'_>], o: &Observation, x: &Vec3) -> Option<Lin> {
        let c = self.frames[o.frame].camera;
        let pj = posed[o.frame].pixel_jacobian(x)?;
        let sig = self.opts.pixel_sigma;
        let r = SVector::<f64, 2>::new(pj.pixel[0] - o.pixel[0], pj.pixel[1] - o.pixel[1]) / sig;
        Some(Lin {
            w: self.weight(&r, o),
            r,
            local: pj.local / sig,
            point: pj.point / sig,
            idx: self.layout.local(o.frame, c),
        })
    }

    /// One tie point's blocks: its observations' frame-camera products go into `sum`, its
    /// rows of H_cp onto the end of `hpc`.
    fn point_lin(
        &self,
        posed: &[Posed<'_>],
        (tie, x): (&TiePoint, &Vec3),
        sum: &mut Partial,
        hpc: &mut Vec<(usize, Vec3)>,
    ) -> Option<PointLin> {
        let first = hpc.len();
        let (hpp, bp, robust) =
            self.point_sums(posed, (tie, x), |l| sum.add_observation(l, hpc))?;
        summed_by_index(hpc, first);
        Some(PointLin {
            hpp,
            bp,
            hpc: first..hpc.len(),
            robust,
        })
    }

    /// Each tie point's blocks alone (H_pp, -J_p^T W r less its prior's), the frames and
    /// cameras held: what [`Self::linear`] gives each point, without the frames' products.
    pub(super) fn point_blocks(&self, s: &State) -> Option<Vec<(Matrix3<f64>, Vec3)>> {
        let posed = self.posed(s);
        self.ties
            .par_iter()
            .zip(s.points.par_iter())
            .map(|t| {
                let (hpp, bp, _) = self.point_sums(&posed, t, |_| {})?;
                Some((hpp, bp))
            })
            .collect()
    }

    /// A tie point's H_pp and -J_p^T W r, its prior included, and whether an observation is
    /// in Huber's linear arm; `each` is handed every observation's linearisation.
    fn point_sums(
        &self,
        posed: &[Posed<'_>],
        (tie, x): (&TiePoint, &Vec3),
        mut each: impl FnMut(&Lin),
    ) -> Option<(Matrix3<f64>, Vec3, bool)> {
        let (mut hpp, mut bp, mut robust) = (Matrix3::<f64>::zeros(), Vec3::zeros(), false);
        for o in &tie.observations {
            let l = self.observation_lin(posed, o, x)?;
            robust |= l.w < o.weight;
            let wp = l.point.transpose() * l.w;
            hpp += wp * l.point;
            bp -= wp * l.r;
            each(&l);
        }
        let (hp, b) = self.point_prior_blocks(tie, x);
        Some((hpp + hp, bp - b, robust))
    }

    /// A tie point's prior (its surveyed position, or the terrain under it): what it adds to
    /// H_pp and what it takes from b_p.
    pub(super) fn point_prior_blocks(&self, tie: &TiePoint, x: &Vec3) -> (Matrix3<f64>, Vec3) {
        if let Some(c) = &tie.control {
            // (x - surveyed) / sigma, axis by axis.
            let j = Matrix3::from_diagonal(&Vec3::from(c.sigma_m.map(|s| 1.0 / s)));
            return (j.transpose() * j, j.transpose() * self.point_prior(tie, x));
        }
        if let Some((h, _)) = self.opts.terrain {
            let sigma = self.terrain_sigma(tie);
            // d/dx of (z - h(x, y)) / sigma (the terrain by central differences).
            let e = 1e-2;
            let gx = (h(x.x + e, x.y) - h(x.x - e, x.y)) / (2.0 * e);
            let gy = (h(x.x, x.y + e) - h(x.x, x.y - e)) / (2.0 * e);
            let j = Vec3::new(-gx, -gy, 1.0) / sigma;
            let r = (x.z - h(x.x, x.y)) / sigma;
            return (j * j.transpose(), j * r);
        }
        (Matrix3::zeros(), Vec3::zeros())
    }

    /// The undamped normal equations at `s`. The tie points are taken [`PART`] at a time in
    /// parallel, each part summing its points' products into its own matrix, and the parts
    /// are added in tie order: the same sums whatever the number of threads. `reuse`: an
    /// earlier linearisation whose parts' storage is taken over (fresh, its gigabyte of
    /// points' blocks on a large flight went to the kernel's page clearing at every step).
    pub fn linear(&self, s: &State, reuse: Option<Linear>) -> Option<Linear> {
        let posed = self.posed(s);
        let mut spare = reuse.map(|l| l.parts).unwrap_or_default().into_iter();
        let mut lin = Linear {
            entries: SymBlocks::new(Arc::new(self.layout.blocks())),
            rhs: vec![0.0; self.layout.len()],
            parts: Vec::with_capacity(self.ties.len().div_ceil(PART)),
        };
        for (ties, xs) in self.ties.chunks(CHUNK).zip(s.points.chunks(CHUNK)) {
            let mut store: Vec<PointsPart> = spare.by_ref().take(CHUNK / PART).collect();
            store.resize_with(ties.len().div_ceil(PART), PointsPart::default);
            let parts: Vec<Option<Partial>> = ties
                .par_chunks(PART)
                .zip(xs.par_chunks(PART))
                .zip(store.par_iter_mut())
                .map(|((ties, xs), part)| {
                    let mut sum = Partial::new(&lin.entries, lin.rhs.len());
                    self.part_lin(&posed, (ties, xs), &mut sum, part)?;
                    Some(sum.flushed())
                })
                .collect();
            for sum in parts {
                sum?.add_to(&mut lin.entries, &mut lin.rhs);
            }
            lin.parts.append(&mut store);
        }
        for row in self.prior_rows(s) {
            let w = row.weight / (row.sigma * row.sigma);
            for &(i, a) in &row.terms {
                lin.rhs[i] -= w * a * row.value;
                for &(j, b) in &row.terms {
                    *lin.entries.entry(i, j) += w * a * b;
                }
            }
        }
        Some(lin)
    }

    /// One part's points linearised into `part` (its earlier contents dropped, its memory
    /// kept), their frame-camera products summed into `sum`.
    fn part_lin(
        &self,
        posed: &[Posed<'_>],
        (ties, xs): (&[TiePoint], &[Vec3]),
        sum: &mut Partial,
        part: &mut PointsPart,
    ) -> Option<()> {
        part.points.clear();
        part.hpc.clear();
        for t in ties.iter().zip(xs) {
            let p = self.point_lin(posed, t, sum, &mut part.hpc)?;
            part.points.push(p);
        }
        Some(())
    }
}

/// The rows of `rows` from `first` on summed per index, in index order, in place: each sum
/// starts at zero and adds its rows in their order (what a map of sums filled in that order
/// holds).
pub(super) fn summed_by_index(rows: &mut Vec<(usize, Vec3)>, first: usize) {
    rows[first..].sort_by_key(|&(i, _)| i);
    let mut kept = first;
    for r in first..rows.len() {
        let (i, v) = rows[r];
        if kept > first && rows[kept - 1].0 == i {
            rows[kept - 1].1 += v;
        } else {
            rows[kept] = (i, Vec3::zeros() + v);
            kept += 1;
        }
    }
    rows.truncate(kept);
}

/// Points per chunk of [`Problem::linear`] and [`Linear::reduced`]: a chunk's parts
/// ([`PART`]) are summed in parallel and held until they are added, each with a right-hand
/// side over every parameter. A whole number of parts.
pub(super) const CHUNK: usize = 16 * PART;

impl Linear {
    /// Every point's blocks, in tie order.
    pub fn points(&self) -> impl Iterator<Item = &PointLin> {
        self.parts.iter().flat_map(|part| &part.points)
    }

    /// The gradient's largest entry (frames, cameras and points).
    pub fn gradient_max_norm(&self) -> f64 {
        let c = self.rhs.iter().fold(0.0, |a: f64, v| a.max(v.abs()));
        self.points().fold(c, |a, p| a.max(p.bp.amax()))
    }
}

/// Tie points (or points) per parallel part of [`Problem::linear`] and [`Linear::reduced`]:
/// a part's sums touch the few frames its points' pairs join. Fixed, so that the sums do not
/// depend on the number of threads. Added on one thread, the points' products were half of a
/// large flight's solve (1,000 fixed-wing frames: 26 of its 52 s on the calling thread, while
/// the other thread waited).
pub(super) const PART: usize = 256;
