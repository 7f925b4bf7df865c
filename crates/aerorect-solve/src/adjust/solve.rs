//! The adjustment's normal equations and damped steps for the crate's Levenberg-Marquardt
//! loop ([`crate::lm`]). Tie points are eliminated block by block (Schur complement); the
//! reduced system over frames and cameras, sparse because frames only meet their neighbours,
//! is solved with faer's sparse Cholesky.

use super::blocks::{LOCAL, State};
use super::jacobian::Posed;
use super::normal::SymBlocks;
use super::residuals::Problem;
use super::{Observation, TiePoint};
use aerorect_core::Vec3;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{Matrix3, SMatrix, SVector};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// The damped reduced system and its right-hand side.
type Reduced = (SymBlocks, Vec<f64>);

/// One tie point's blocks of the (undamped) normal equations.
pub(super) struct PointLin {
    pub hpp: Matrix3<f64>,
    /// -J_p^T W r.
    pub bp: Vec3,
    /// Its rows of H_cp, by reduced index in index order: a range of [`Linear::hpc`] (a
    /// vector per point cost an allocation per point and linearisation).
    hpc: Range<usize>,
    /// Whether an observation is in Huber's linear arm (the point is polished after a step).
    pub robust: bool,
}

/// The undamped normal equations at one state: the frame-and-camera block (data and
/// priors), its right-hand side (-gradient) and each point's blocks.
pub(super) struct Linear {
    pub entries: SymBlocks,
    pub rhs: Vec<f64>,
    pub points: Vec<PointLin>,
    /// Every point's rows of H_cp, (reduced index, row), one point after another.
    hpc: Vec<(usize, Vec3)>,
}

/// One observation's residual, weight and Jacobians (local columns and point).
struct Lin {
    r: SVector<f64, 2>,
    w: f64,
    local: SMatrix<f64, 2, LOCAL>,
    point: nalgebra::Matrix2x3<f64>,
    idx: [Option<usize>; LOCAL],
}

/// One part's sums: its matrix and right-hand side.
struct Partial {
    entries: SymBlocks,
    rhs: Vec<f64>,
}

impl Partial {
    /// Zero, over `like`'s blocks and `n` parameters.
    fn new(like: &SymBlocks, n: usize) -> Self {
        Self {
            entries: like.empty_like(),
            rhs: vec![0.0; n],
        }
    }

    /// Adds the part's sums to the whole's.
    fn add_to(&self, entries: &mut SymBlocks, rhs: &mut [f64]) {
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
        let mut m = [0.0; LOCAL * LOCAL];
        for (ra, &a) in cols[..n].iter().enumerate() {
            let (j0, j1) = (l.w * l.local[(0, a)], l.w * l.local[(1, a)]);
            for (rb, &b) in cols[..=ra].iter().enumerate() {
                let v = j0 * l.local[(0, b)] + j1 * l.local[(1, b)];
                m[ra * n + rb] = v;
                m[rb * n + ra] = v;
            }
            self.rhs[idx[ra]] -= j0 * l.r[0] + j1 * l.r[1];
            let row = l.point.row(0).transpose() * j0 + l.point.row(1).transpose() * j1;
            hpc.push((idx[ra], row));
        }
        self.entries.add_dense(&idx[..n], &m[..n * n]);
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
    fn point_part(
        &self,
        posed: &[Posed<'_>],
        (tie, x): (&TiePoint, &Vec3),
        sum: &mut Partial,
        hpc: &mut Vec<(usize, Vec3)>,
    ) -> Option<PointLin> {
        let mut hpp = Matrix3::<f64>::zeros();
        let mut bp = Vec3::zeros();
        let mut robust = false;
        let first = hpc.len();
        for o in &tie.observations {
            let l = self.observation_lin(posed, o, x)?;
            robust |= l.w < o.weight;
            let wp = l.point.transpose() * l.w;
            hpp += wp * l.point;
            bp -= wp * l.r;
            sum.add_observation(&l, hpc);
        }
        summed_by_index(hpc, first);
        let (hp, b) = self.point_prior_blocks(tie, x);
        Some(PointLin {
            hpp: hpp + hp,
            bp: bp - b,
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
            .map(|(tie, x)| {
                let (mut hpp, mut bp) = (Matrix3::<f64>::zeros(), Vec3::zeros());
                for o in &tie.observations {
                    let l = self.observation_lin(&posed, o, x)?;
                    let wp = l.point.transpose() * l.w;
                    hpp += wp * l.point;
                    bp -= wp * l.r;
                }
                let (hp, b) = self.point_prior_blocks(tie, x);
                Some((hpp + hp, bp - b))
            })
            .collect()
    }

    /// A tie point's prior (its surveyed position, or the terrain under it): what it adds to
    /// H_pp and what it takes from b_p.
    pub(super) fn point_prior_blocks(&self, tie: &TiePoint, x: &Vec3) -> (Matrix3<f64>, Vec3) {
        if let Some(c) = &tie.control {
            // (x - surveyed) / sigma, axis by axis.
            let j = Matrix3::from_diagonal(&Vec3::from(c.sigma_m.map(|s| 1.0 / s)));
            return (j.transpose() * j, j.transpose() * self.point_prior(tie, x));
        }
        if let Some((h, sigma)) = self.opts.terrain {
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
    /// earlier linearisation whose storage is taken over (fresh, its gigabyte of points' blocks
    /// on a large flight went to the kernel's page clearing at every step).
    pub fn linear(&self, s: &State, reuse: Option<Linear>) -> Option<Linear> {
        let posed = self.posed(s);
        let (mut points, mut hpc) = reuse.map_or_else(
            || (Vec::with_capacity(self.ties.len()), Vec::new()),
            |l| (l.points, l.hpc),
        );
        points.clear();
        hpc.clear();
        let mut lin = Linear {
            entries: SymBlocks::new(Arc::new(self.layout.blocks())),
            rhs: vec![0.0; self.layout.len()],
            points,
            hpc,
        };
        for (ties, xs) in self.ties.chunks(CHUNK).zip(s.points.chunks(CHUNK)) {
            type Part = (Partial, Vec<PointLin>, Vec<(usize, Vec3)>);
            let parts: Vec<Option<Part>> = ties
                .par_chunks(PART)
                .zip(xs.par_chunks(PART))
                .map(|(ties, xs)| {
                    let mut sum = Partial::new(&lin.entries, lin.rhs.len());
                    let mut hpc = Vec::new();
                    let points = ties
                        .iter()
                        .zip(xs)
                        .map(|t| self.point_part(&posed, t, &mut sum, &mut hpc))
                        .collect::<Option<Vec<_>>>()?;
                    Some((sum, points, hpc))
                })
                .collect();
            for part in parts {
                let (sum, points, hpc) = part?;
                sum.add_to(&mut lin.entries, &mut lin.rhs);
                let at = lin.hpc.len();
                lin.points.extend(points.into_iter().map(|p| PointLin {
                    hpc: p.hpc.start + at..p.hpc.end + at,
                    ..p
                }));
                lin.hpc.extend(hpc);
            }
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
}

/// The rows of `rows` from `first` on summed per index, in index order, in place: each sum
/// starts at zero and adds its rows in their order (what a map of sums filled in that order
/// holds).
fn summed_by_index(rows: &mut Vec<(usize, Vec3)>, first: usize) {
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
/// side over every parameter.
const CHUNK: usize = 4096;

impl Linear {
    /// Point `p`'s rows of H_cp.
    pub fn hpc(&self, p: &PointLin) -> &[(usize, Vec3)] {
        &self.hpc[p.hpc.clone()]
    }

    /// The gradient's largest entry (frames, cameras and points).
    pub fn gradient_max_norm(&self) -> f64 {
        let c = self.rhs.iter().fold(0.0, |a: f64, v| a.max(v.abs()));
        self.points.iter().fold(c, |a, p| a.max(p.bp.amax()))
    }

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

/// Tie points (or points) per parallel part of [`Problem::linear`] and [`Linear::reduced`]:
/// a part's sums touch the few frames its points' pairs join. Fixed, so that the sums do not
/// depend on the number of threads. Added on one thread, the points' products were half of a
/// large flight's solve (1,000 fixed-wing frames: 26 of its 52 s on the calling thread, while
/// the other thread waited).
const PART: usize = 256;

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

/// The adjustment as the loop's model: the problem, its starting points (the parameter
/// tolerance is relative to the corrections, not to world coordinates) and the last
/// linearisation.
pub(super) struct Solver<'p, 'a> {
    pub problem: &'p Problem<'a>,
    pub start: Vec<Vec3>,
    pub linear: Option<Linear>,
    /// Each point's damped H_pp^-1 at the last step (kept for its storage).
    pub inverses: Vec<Option<Matrix3<f64>>>,
    /// The stop rule of [`super::AdjustOptions::settled`] (degrees), for a solve that starts
    /// near its minimum (a warm start), where the steps are Gauss-Newton's: from far, the
    /// damped steps can be short while the solve still has far to go.
    pub settled: Option<f64>,
}

impl crate::lm::Model for Solver<'_, '_> {
    type State = State;

    fn cost(&self, s: &State) -> Option<f64> {
        self.problem.cost(s)
    }

    /// With [`Solver::settled`]: the step turned no frame by that many
    /// degrees, moved no centre by a millimetre and changed no camera parameter (focal scale,
    /// radial terms, boresight radians, principal point pixels) by a millionth.
    fn settled(&self, before: &State, after: &State) -> bool {
        let Some(deg) = self.settled else {
            return false;
        };
        let largest = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        };
        let frames = before.frames.iter().zip(&after.frames).all(|(a, b)| {
            (a.rotation - b.rotation).amax() < deg.to_radians()
                && (a.position - b.position).amax() < 1e-3
        });
        let cameras = before.cameras.iter().zip(&after.cameras).all(|(a, b)| {
            let v = |c: &super::blocks::CameraBlock| {
                [
                    c.focal_scale,
                    c.principal_point[0],
                    c.principal_point[1],
                    c.radial[0],
                    c.radial[1],
                    c.boresight.x,
                    c.boresight.y,
                    c.boresight.z,
                ]
            };
            largest(&v(a), &v(b)) < 1e-6
        });
        frames && cameras
    }

    /// The report's standard deviations come from their own normal equations.
    fn linearise_at_end(&self) -> bool {
        false
    }

    fn linearise(&mut self, s: &State) -> Option<f64> {
        self.linear = self.problem.linear(s, self.linear.take());
        self.linear.as_ref().map(Linear::gradient_max_norm)
    }

    fn step(&mut self, s: &State, lambda: f64) -> Option<crate::lm::Step<State>> {
        let lin = self.linear.as_ref()?;
        let mut inverses = std::mem::take(&mut self.inverses);
        let (entries, rhs) = lin.reduced(lambda, &mut inverses);
        let llt = factor(rhs.len(), &entries)?;
        let dc = solve_with(&llt, &rhs);
        let mut next = self.problem.layout.moved(s, &dc);
        let mut step2: f64 = dc.iter().map(|d| d * d).sum();
        for ((x, p), inv) in next.points.iter_mut().zip(&lin.points).zip(&inverses) {
            if let Some(inv) = inv {
                let hd = lin
                    .hpc(p)
                    .iter()
                    .fold(Vec3::zeros(), |a, (i, v)| a + v * dc[*i]);
                let dx = inv * (p.bp - hd);
                step2 += dx.norm_squared();
                *x += dx;
            }
        }
        self.inverses = inverses;
        if !step2.is_finite() {
            return None;
        }
        step2 += self.problem.polish(lin, &mut next);
        let params: f64 = self.problem.layout.values(s).iter().map(|v| v * v).sum();
        let points: f64 = s
            .points
            .iter()
            .zip(&self.start)
            .map(|(x, x0)| (x - x0).norm_squared())
            .sum();
        Some(crate::lm::Step {
            state: next,
            step_norm: step2.sqrt(),
            x_norm: (params + points).sqrt(),
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::collections::BTreeMap;

    /// A problem of two frames and 40 tie points over a sloping terrain, one observation in
    /// Huber's linear arm, attitudes and positions free, and a state near its minimum.
    fn with_fixture(run: impl FnOnce(&Problem<'_>, &State)) {
        use super::super::blocks::{CameraBlock, DatumBlock, FrameBlock, Layout};
        use super::super::{AdjustFrame, AdjustOptions};
        use aerorect_core::{Camera, ImageSize, Intrinsics};
        let frames: Vec<AdjustFrame> = [-20.0, 25.0]
            .iter()
            .map(|&x| AdjustFrame {
                camera: 0,
                centre: [x, 3.0, 120.0],
                world_from_camera: nalgebra::Rotation3::new(Vec3::new(0.02, -0.01, 0.01))
                    .into_inner(),
                position_sigma_m: Some([2.0; 3]),
                attitude_sigma_deg: None,
            })
            .collect();
        let cameras = vec![Camera::new(
            Intrinsics::new(900.0, 900.0, 500.0, 380.0).expect("valid"),
            None,
            ImageSize::new(1000, 760),
        )];
        let ties: Vec<TiePoint> = (0..40)
            .map(|k| {
                let g = [
                    (k % 8) as f64 * 6.0 - 20.0,
                    (k / 8) as f64 * 7.0 - 14.0,
                    1.0,
                ];
                let at = |f: usize, dx: f64| Observation {
                    frame: f,
                    pixel: [500.0 + g[0] * 7.0 + dx, 380.0 - g[1] * 7.0],
                    weight: 1.0,
                };
                TiePoint {
                    ground: g,
                    observations: vec![at(0, 140.0), at(1, -175.0 + f64::from(k == 7) * 40.0)],
                    control: None,
                }
            })
            .collect();
        let terrain = |x: f64, y: f64| 0.02 * x - 0.01 * y;
        let opts = AdjustOptions {
            terrain: Some((&terrain, 1.0)),
            ..AdjustOptions::default()
        };
        let p = Problem {
            frames: &frames,
            cameras: &cameras,
            ties: &ties,
            layout: Layout::new(2, 1, |_, _| true, |_, _| true, |_| false),
            opts: &opts,
            huber: opts.huber,
            centroid: Vec3::zeros(),
        };
        let s = State {
            frames: vec![
                FrameBlock {
                    rotation: Vec3::new(0.001, -0.002, 0.003),
                    position: Vec3::new(0.2, -0.1, 0.3),
                };
                2
            ],
            cameras: vec![CameraBlock::default()],
            datum: DatumBlock::default(),
            points: ties.iter().map(|t| Vec3::from(t.ground)).collect(),
        };
        run(&p, &s);
    }

    /// The reduced system and right-hand side at two dampings equal a dense oracle: every
    /// observation's full Jacobian (all 14 local columns and the point's 3) assembled into
    /// one dense normal matrix with the priors, damped, and its points eliminated by a dense
    /// Schur complement.
    #[test]
    fn the_reduced_system_is_the_dense_schur_complement() {
        use super::super::jacobian::pixel_jacobian;
        use nalgebra::{DMatrix, DVector};
        with_fixture(|p, s| {
            let lin = p.linear(s, None).unwrap();
            let (nc, np) = (p.layout.len(), 3 * p.ties.len());
            let mut n = DMatrix::<f64>::zeros(nc + np, nc + np);
            let mut b = DVector::<f64>::zeros(nc + np);
            let sig = p.opts.pixel_sigma;
            for (t, (tie, x)) in p.ties.iter().zip(&s.points).enumerate() {
                for o in &tie.observations {
                    let fr = &p.frames[o.frame];
                    let (fb, cb) = (&s.frames[o.frame], &s.cameras[fr.camera]);
                    let pj = pixel_jacobian(fr, &p.cameras[fr.camera], fb, cb, x).unwrap();
                    let r =
                        nalgebra::Vector2::new(pj.pixel[0] - o.pixel[0], pj.pixel[1] - o.pixel[1])
                            / sig;
                    let w = p.weight(&r, o);
                    let mut j = DMatrix::<f64>::zeros(2, nc + np);
                    for (a, i) in p.layout.local(o.frame, fr.camera).iter().enumerate() {
                        if let Some(i) = i {
                            j.set_column(*i, &(pj.local.column(a) / sig));
                        }
                    }
                    for k in 0..3 {
                        j.set_column(nc + 3 * t + k, &(pj.point.column(k) / sig));
                    }
                    n += j.transpose() * &j * w;
                    b -= j.transpose() * DVector::from_column_slice(r.as_slice()) * w;
                }
                let (hp, bp) = p.point_prior_blocks(tie, x);
                let at = nc + 3 * t;
                let mut block = n.view_mut((at, at), (3, 3));
                block += hp;
                let mut rows = b.rows_mut(at, 3);
                rows -= bp;
            }
            for row in p.prior_rows(s) {
                let w = row.weight / (row.sigma * row.sigma);
                for &(i, a) in &row.terms {
                    b[i] -= w * a * row.value;
                    for &(j, c) in &row.terms {
                        n[(i, j)] += w * a * c;
                    }
                }
            }
            for lambda in [0.0, 1e-3] {
                let mut d = n.clone();
                for i in 0..nc + np {
                    d[(i, i)] += lambda * n[(i, i)].max(1e-9);
                }
                let ipp = d
                    .view((nc, nc), (np, np))
                    .clone_owned()
                    .try_inverse()
                    .unwrap();
                let ncp = d.view((0, nc), (nc, np)).clone_owned();
                let want = d.view((0, 0), (nc, nc)) - &ncp * &ipp * ncp.transpose();
                let want_rhs = b.rows(0, nc) - &ncp * &ipp * b.rows(nc, np);
                let mut inverses = Vec::new();
                let (entries, rhs) = lin.reduced(lambda, &mut inverses);
                assert!(inverses.iter().all(Option::is_some));
                let scale = want.amax();
                let mut got = DMatrix::<f64>::zeros(nc, nc);
                for (i, j, v) in entries.lower_triplets() {
                    got[(i, j)] = v;
                    got[(j, i)] = v;
                }
                assert!((&got - &want).amax() <= 1e-9 * scale, "{got}\n{want}");
                let rhs = DVector::from_vec(rhs);
                assert!((&rhs - &want_rhs).amax() <= 1e-9 * want_rhs.amax().max(1.0));
            }
        });
    }

    /// The points' blocks alone (a warm start's point passes) are those of the full
    /// linearisation, bit for bit, over a terrain prior and with one observation in Huber's
    /// linear arm.
    #[test]
    fn point_blocks_are_the_full_linearisations_points() {
        with_fixture(|p, s| {
            let lin = p.linear(s, None).unwrap();
            let blocks = p.point_blocks(s).unwrap();
            assert_eq!(blocks.len(), lin.points.len());
            assert!(
                lin.points.iter().any(|q| q.robust),
                "no point in Huber's arm"
            );
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for ((hpp, bp), q) in blocks.iter().zip(&lin.points) {
                assert_eq!(bits(hpp.as_slice()), bits(q.hpp.as_slice()));
                assert_eq!(bits(bp.as_slice()), bits(q.bp.as_slice()));
            }
        });
    }

    /// The same sums, bit for bit and in index order, as a map of sums filled in order
    /// (negative zeros and repeated indices included).
    #[test]
    fn summed_by_index_equals_a_map_of_sums() {
        let rows: Vec<(usize, Vec3)> = (0..40)
            .map(|k| {
                let i = (k * 7) % 9;
                let v = Vec3::new(0.1 * k as f64, -0.0, 1.0 / (k as f64 + 0.3));
                (i, if k % 5 == 0 { -v } else { v })
            })
            .collect();
        let mut map: BTreeMap<usize, Vec3> = BTreeMap::new();
        for (i, v) in &rows {
            *map.entry(*i).or_insert_with(Vec3::zeros) += v;
        }
        // Behind two rows of an earlier point, which stay as they are.
        let earlier = [
            (5, Vec3::new(1.0, 2.0, 3.0)),
            (1, Vec3::new(-4.0, 0.5, 0.0)),
        ];
        let mut got = earlier.to_vec();
        got.extend(rows);
        summed_by_index(&mut got, earlier.len());
        assert_eq!(got[..2], earlier);
        let got = &got[2..];
        assert_eq!(got.len(), map.len());
        for ((gi, gv), (mi, mv)) in got.iter().zip(&map) {
            assert_eq!(gi, mi);
            for k in 0..3 {
                assert_eq!(gv[k].to_bits(), mv[k].to_bits());
            }
        }
    }
}
