//! The adjustment's normal equations and damped steps for the crate's Levenberg-Marquardt
//! loop ([`crate::lm`]). Tie points are eliminated block by block (Schur complement); the
//! reduced system over frames and cameras, sparse because frames only meet their neighbours,
//! is solved with faer's sparse Cholesky.

use super::blocks::{LOCAL, State};
use super::jacobian::pixel_jacobian;
use super::normal::SymBlocks;
use super::residuals::Problem;
use super::{Observation, TiePoint};
use aerorect_core::Vec3;
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{Matrix3, SMatrix, SVector};
use rayon::prelude::*;
use std::sync::Arc;

/// The damped reduced system, its right-hand side, and each point's damped H_pp^-1 (none
/// where it is singular).
type Reduced = (SymBlocks, Vec<f64>, Vec<Option<Matrix3<f64>>>);

/// One tie point's blocks of the (undamped) normal equations.
pub(super) struct PointLin {
    pub hpp: Matrix3<f64>,
    /// -J_p^T W r.
    pub bp: Vec3,
    /// H_cp by reduced index.
    pub hpc: Vec<(usize, Vec3)>,
    /// Whether an observation is in Huber's linear arm (the point is polished after a step).
    pub robust: bool,
}

/// The undamped normal equations at one state: the frame-and-camera block (data and
/// priors), its right-hand side (-gradient) and each point's blocks.
pub(super) struct Linear {
    pub entries: SymBlocks,
    pub rhs: Vec<f64>,
    pub points: Vec<PointLin>,
}

/// One observation's residual, weight and Jacobians (local columns and point).
struct Lin {
    r: SVector<f64, 2>,
    w: f64,
    local: SMatrix<f64, 2, LOCAL>,
    point: nalgebra::Matrix2x3<f64>,
    idx: [Option<usize>; LOCAL],
}

impl Problem<'_> {
    fn observation_lin(&self, s: &State, o: &Observation, x: &Vec3) -> Option<Lin> {
        let fr = &self.frames[o.frame];
        let c = fr.camera;
        let pj = pixel_jacobian(fr, &self.cameras[c], &s.frames[o.frame], &s.cameras[c], x)?;
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

    /// One tie point's blocks, and each observation's frame-camera products (to be added
    /// to the reduced system in observation order).
    fn point_part(&self, s: &State, tie: &TiePoint, x: &Vec3) -> Option<PointPart> {
        let mut hpp = Matrix3::<f64>::zeros();
        let mut bp = Vec3::zeros();
        // (reduced index, H_cp row) per observation and local column, summed by index below.
        let mut hpc: Vec<(usize, Vec3)> = Vec::with_capacity(LOCAL * tie.observations.len());
        let mut obs = ObservationParts::default();
        let mut robust = false;
        for o in &tie.observations {
            let l = self.observation_lin(s, o, x)?;
            robust |= l.w < o.weight;
            hpp += l.w * l.point.transpose() * l.point;
            bp -= l.w * l.point.transpose() * l.r;
            let cross = l.w * l.local.transpose() * l.point;
            for (a, i) in l.idx.iter().enumerate() {
                let Some(i) = *i else { continue };
                hpc.push((i, cross.row(a).transpose()));
            }
            obs.push(
                &l.idx,
                &(l.w * l.local.transpose() * l.local),
                &(-l.w * l.local.transpose() * l.r),
            );
        }
        let (hp, b) = self.point_prior_blocks(tie, x);
        Some(PointPart {
            point: PointLin {
                hpp: hpp + hp,
                bp: bp - b,
                hpc: summed_by_index(hpc),
                robust,
            },
            obs,
        })
    }

    /// Each tie point's blocks alone (H_pp, -J_p^T W r less its prior's), the frames and
    /// cameras held: what [`Self::linear`] gives each point, without the frames' products.
    pub(super) fn point_blocks(&self, s: &State) -> Option<Vec<(Matrix3<f64>, Vec3)>> {
        self.ties
            .par_iter()
            .zip(s.points.par_iter())
            .map(|(tie, x)| {
                let (mut hpp, mut bp) = (Matrix3::<f64>::zeros(), Vec3::zeros());
                for o in &tie.observations {
                    let l = self.observation_lin(s, o, x)?;
                    hpp += l.w * l.point.transpose() * l.point;
                    bp -= l.w * l.point.transpose() * l.r;
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
    /// are added in tie order: the same sums whatever the number of threads.
    pub fn linear(&self, s: &State) -> Option<Linear> {
        let mut lin = Linear {
            entries: SymBlocks::new(Arc::new(self.layout.blocks())),
            rhs: vec![0.0; self.layout.len()],
            points: Vec::with_capacity(self.ties.len()),
        };
        for (ties, xs) in self.ties.chunks(CHUNK).zip(s.points.chunks(CHUNK)) {
            let parts: Vec<Option<(Partial, Vec<PointLin>)>> = ties
                .par_chunks(PART)
                .zip(xs.par_chunks(PART))
                .map(|(ties, xs)| {
                    let mut sum = Partial::new(&lin.entries, lin.rhs.len());
                    let points = ties
                        .iter()
                        .zip(xs)
                        .map(|(tie, x)| {
                            let part = self.point_part(s, tie, x)?;
                            part.obs.add_to(&mut sum.entries, &mut sum.rhs);
                            Some(part.point)
                        })
                        .collect::<Option<Vec<_>>>()?;
                    Some((sum, points))
                })
                .collect();
            for part in parts {
                let (sum, points) = part?;
                sum.add_to(&mut lin.entries, &mut lin.rhs);
                lin.points.extend(points);
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

/// The rows of `rows` summed per index, in index order: each sum starts at zero and adds its
/// rows in their order in `rows` (what a map of sums filled in that order holds; a map of
/// nodes cost an allocation per index).
fn summed_by_index(mut rows: Vec<(usize, Vec3)>) -> Vec<(usize, Vec3)> {
    rows.sort_by_key(|&(i, _)| i);
    let mut kept = 0;
    for r in 0..rows.len() {
        let (i, v) = rows[r];
        if kept > 0 && rows[kept - 1].0 == i {
            rows[kept - 1].1 += v;
        } else {
            rows[kept] = (i, Vec3::zeros() + v);
            kept += 1;
        }
    }
    rows.truncate(kept);
    // Kept with the point for the whole solve: held at its full length (an entry per
    // observation and local column) it cost 300 MB on the 1,000-frame simulation.
    rows.shrink_to_fit();
    rows
}

/// Points per chunk of [`Problem::linear`] and [`Linear::reduced`]: a chunk's parts
/// ([`PART`]) are summed in parallel and held until they are added, each with a right-hand
/// side over every parameter.
const CHUNK: usize = 4096;

/// A tie point's observations' frame-camera products over the local columns that hold a
/// reduced index (3 of 14 when only attitudes are solved for), one observation after another:
/// its count n (`len`), its n indices (`idx`, in column order), then H_cc over them (n x n,
/// row-major) and -J_c^T W r (n) in `values`. Three small vectors per point: an observation's
/// full 14 x 14 block, 1.9 KB, went through the allocator's slow path for every point and
/// step (a sixth of a large flight's solve).
#[derive(Default)]
struct ObservationParts {
    len: Vec<usize>,
    idx: Vec<Option<usize>>,
    values: Vec<f64>,
}

impl ObservationParts {
    fn push(
        &mut self,
        idx: &[Option<usize>; LOCAL],
        hcc: &SMatrix<f64, LOCAL, LOCAL>,
        bc: &SVector<f64, LOCAL>,
    ) {
        let mut held = [0usize; LOCAL];
        let mut n = 0;
        for (a, i) in idx.iter().enumerate() {
            if i.is_some() {
                held[n] = a;
                n += 1;
            }
        }
        let held = &held[..n];
        self.len.push(n);
        self.idx.extend(held.iter().map(|&a| idx[a]));
        for &a in held {
            self.values.extend(held.iter().map(|&b| hcc[(a, b)]));
        }
        self.values.extend(held.iter().map(|&a| bc[a]));
    }

    /// Adds every observation's products to the reduced system, in observation order, each
    /// the right-hand side's entries first, then H_cc (what adding the full blocks added).
    fn add_to(&self, entries: &mut SymBlocks, rhs: &mut [f64]) {
        let (mut at_idx, mut at_value) = (0, 0);
        for &n in &self.len {
            let idx = &self.idx[at_idx..at_idx + n];
            let (hcc, bc) = self.values[at_value..at_value + n * n + n].split_at(n * n);
            for (i, b) in idx.iter().zip(bc) {
                if let Some(i) = *i {
                    rhs[i] += b;
                }
            }
            entries.add_outer(idx, |a, b| hcc[a * n + b]);
            at_idx += n;
            at_value += n * n + n;
        }
    }
}

/// One tie point's blocks and its observations' products.
struct PointPart {
    point: PointLin,
    obs: ObservationParts,
}

impl Linear {
    /// The gradient's largest entry (frames, cameras and points).
    pub fn gradient_max_norm(&self) -> f64 {
        let c = self.rhs.iter().fold(0.0, |a: f64, v| a.max(v.abs()));
        self.points.iter().fold(c, |a, p| a.max(p.bp.amax()))
    }

    /// The damped reduced system (points eliminated), each point's damped H_pp^-1 (none where
    /// it is singular), and its right-hand side. The points' Schur blocks are taken [`PART`]
    /// at a time in parallel, each part summed into its own matrix, and the parts are added
    /// in point order: the same sums whatever the number of threads.
    pub fn reduced(&self, lambda: f64) -> Reduced {
        let mut entries = self.entries.clone();
        for i in 0..self.rhs.len() {
            let d = entries.entry(i, i);
            *d += lambda * d.max(1e-9);
        }
        let mut rhs = self.rhs.clone();
        let mut inverses = Vec::with_capacity(self.points.len());
        for points in self.points.chunks(CHUNK) {
            let parts: Vec<(Partial, Vec<Option<Matrix3<f64>>>)> = points
                .par_chunks(PART)
                .map(|points| {
                    let mut sum = Partial::new(&entries, rhs.len());
                    let (mut t, mut idx) = (Vec::new(), Vec::new());
                    let inverses = points
                        .iter()
                        .map(|p| {
                            let part = schur_part(p, lambda, &mut t)?;
                            part.add_to(p, &mut sum, &mut idx);
                            Some(part.inv)
                        })
                        .collect();
                    (sum, inverses)
                })
                .collect();
            for (sum, part) in parts {
                sum.add_to(&mut entries, &mut rhs);
                inverses.extend(part);
            }
        }
        (entries, rhs, inverses)
    }
}

/// Tie points (or points) per parallel part of [`Problem::linear`] and [`Linear::reduced`]:
/// a part's sums touch the few frames its points' pairs join. Fixed, so that the sums do not
/// depend on the number of threads. Added on one thread, the points' products were half of a
/// large flight's solve (1,000 fixed-wing frames: 26 of its 52 s on the calling thread, while
/// the other thread waited).
const PART: usize = 256;

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
}

/// One point's elimination, for a point seen through n reduced parameters (its `hpc`):
/// S -= H_cp H_pp^-1 H_pc, n x n values row-major over the point's reduced indices, then
/// rhs -= H_cp H_pp^-1 b_p, n values (what is subtracted), in one vector.
struct SchurPart {
    inv: Matrix3<f64>,
    outer_rhs: Vec<f64>,
}

impl SchurPart {
    /// Subtracts the point's elimination from a part's sums (`idx`: working space).
    fn add_to(&self, p: &PointLin, sum: &mut Partial, idx: &mut Vec<Option<usize>>) {
        let n = p.hpc.len();
        let (outer, subtract) = self.outer_rhs.split_at(n * n);
        for ((i, _), d) in p.hpc.iter().zip(subtract) {
            sum.rhs[*i] -= d;
        }
        idx.clear();
        idx.extend(p.hpc.iter().map(|(i, _)| Some(*i)));
        sum.entries.add_outer(idx, |a, b| outer[a * n + b]);
    }
}

/// Point `p`'s [`SchurPart`] at damping `lambda`; `None` where its damped H_pp is singular.
/// `t` is working space (H_pp^-1 H_pc by column).
fn schur_part(p: &PointLin, lambda: f64, t: &mut Vec<Vec3>) -> Option<SchurPart> {
    let mut hpp = p.hpp;
    for k in 0..3 {
        hpp[(k, k)] += lambda * p.hpp[(k, k)].max(1e-9);
    }
    let inv = hpp.try_inverse()?;
    t.clear();
    t.extend(p.hpc.iter().map(|(_, v)| inv * v));
    let ib = inv * p.bp;
    let n = p.hpc.len();
    let mut outer_rhs = Vec::with_capacity(n * n + n);
    for (_, va) in &p.hpc {
        outer_rhs.extend(t.iter().map(|tb| -va.dot(tb)));
    }
    outer_rhs.extend(p.hpc.iter().map(|(_, vi)| vi.dot(&ib)));
    Some(SchurPart { inv, outer_rhs })
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
        self.linear = self.problem.linear(s);
        self.linear.as_ref().map(Linear::gradient_max_norm)
    }

    fn step(&mut self, s: &State, lambda: f64) -> Option<crate::lm::Step<State>> {
        let lin = self.linear.as_ref()?;
        let (entries, rhs, inverses) = lin.reduced(lambda);
        let llt = factor(rhs.len(), &entries)?;
        let dc = solve_with(&llt, &rhs);
        let mut next = self.problem.layout.moved(s, &dc);
        let mut step2: f64 = dc.iter().map(|d| d * d).sum();
        for ((x, p), inv) in next.points.iter_mut().zip(&lin.points).zip(&inverses) {
            if let Some(inv) = inv {
                let hd = p.hpc.iter().fold(Vec3::zeros(), |a, (i, v)| a + v * dc[*i]);
                let dx = inv * (p.bp - hd);
                step2 += dx.norm_squared();
                *x += dx;
            }
        }
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

    /// An observation's products added from the compact form give the reduced system and
    /// right-hand side that adding its full 14 x 14 block gave, bit for bit.
    #[test]
    fn compact_observations_add_what_full_blocks_added() {
        use super::super::normal::Blocks;
        let blocks = Arc::new(Blocks::new([3, 3, 8]));
        let (mut compact, mut full) = (SymBlocks::new(blocks.clone()), SymBlocks::new(blocks));
        let (mut rhs_c, mut rhs_f) = (vec![0.0; 14], vec![0.0; 14]);
        let mut parts = ObservationParts::default();
        let held: [&[usize]; 3] = [&[0, 1, 2], &[3, 4, 5, 9, 13], &[]];
        for (k, held) in held.iter().enumerate() {
            let mut idx = [None; LOCAL];
            for (n, &a) in held.iter().enumerate() {
                idx[a] = Some((3 * k + 2 * n) % 14);
            }
            let hcc = SMatrix::<f64, LOCAL, LOCAL>::from_fn(|a, b| {
                ((a * 31 + b * 17 + k) as f64).sin() / 3.0
            });
            let bc = SVector::<f64, LOCAL>::from_fn(|a, _| -(((a + k) as f64) * 0.7).cos());
            parts.push(&idx, &hcc, &bc);
            for (a, i) in idx.iter().enumerate() {
                if let Some(i) = *i {
                    rhs_f[i] += bc[a];
                }
            }
            full.add_outer(&idx, |a, b| hcc[(a, b)]);
        }
        parts.add_to(&mut compact, &mut rhs_c);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&rhs_c), bits(&rhs_f));
        let (c, f) = (compact.lower_triplets(), full.lower_triplets());
        assert_eq!(c.len(), f.len());
        for (x, y) in c.iter().zip(&f) {
            assert_eq!((x.0, x.1, x.2.to_bits()), (y.0, y.1, y.2.to_bits()));
        }
    }

    /// The points' blocks alone (a warm start's point passes) are those of the full
    /// linearisation, bit for bit, over a terrain prior and with one observation in Huber's
    /// linear arm.
    #[test]
    fn point_blocks_are_the_full_linearisations_points() {
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
        let lin = p.linear(&s).unwrap();
        let blocks = p.point_blocks(&s).unwrap();
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
        let got = summed_by_index(rows);
        assert_eq!(got.len(), map.len());
        for ((gi, gv), (mi, mv)) in got.iter().zip(&map) {
            assert_eq!(gi, mi);
            for k in 0..3 {
                assert_eq!(gv[k].to_bits(), mv[k].to_bits());
            }
        }
    }
}
