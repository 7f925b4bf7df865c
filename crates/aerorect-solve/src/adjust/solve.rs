//! The adjustment as the crate's Levenberg-Marquardt model ([`crate::lm`]): the cost, the
//! stop rule of a warm start, and each damped step from the linearisation ([`super::linear`])
//! through the reduced system ([`super::schur`]), the points back-substituted.

use super::blocks::State;
use super::linear::{Linear, PART};
use super::residuals::Problem;
use super::schur::{Factoriser, Inverses};
use aerorect_core::Vec3;
use rayon::prelude::*;

/// The last linearisation and each point's damped H_pp^-1 at the last step, kept for their
/// storage from step to step, from one Huber stage to the next and for the standard
/// deviations: on a large flight they are hundreds of megabytes, and fresh pages cost more
/// than the arithmetic that fills them (the 1,000-frame fixed wing's final solve, 1.6 M tie
/// points: its first linearisation 2.4 s against 0.9 s for each that reused one, the
/// reduced system 1.3 s against 0.5 s).
#[derive(Default)]
pub(super) struct Storage {
    pub linear: Option<Linear>,
    pub inverses: Inverses,
    /// Each point's back-substituted step at the last step (zero where it has none).
    pub point_steps: Vec<Vec3>,
    /// The reduced system's symbolic factorisation, shared by the steps and the standard
    /// deviations.
    pub factoriser: Factoriser,
}

/// The adjustment as the loop's model: the problem, its starting points (the parameter
/// tolerance is relative to the corrections, not to world coordinates) and the last
/// linearisation.
pub(super) struct Solver<'p, 'a> {
    pub problem: &'p Problem<'a>,
    pub start: Vec<Vec3>,
    /// Only [`crate::lm::Model::linearise`] reads the linearisation it holds at the start
    /// (for its storage); every step reads the one that linearise made.
    pub storage: Storage,
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
        self.storage.linear = self.problem.linear(s, self.storage.linear.take());
        self.storage.linear.as_ref().map(Linear::gradient_max_norm)
    }

    fn step(&mut self, s: &State, lambda: f64) -> Option<crate::lm::Step<State>> {
        let lin = self.storage.linear.as_ref()?;
        let mut inverses = std::mem::take(&mut self.storage.inverses);
        let (entries, rhs) = lin.reduced(lambda, &mut inverses);
        let par = faer::get_global_parallelism();
        let dc = self
            .storage
            .factoriser
            .factor(rhs.len(), &entries, par)?
            .solve(&rhs)?;
        let mut next = self.problem.layout.moved(s, &dc);
        let mut step2: f64 = dc.iter().map(|d| d * d).sum();
        // The points back-substituted in parallel, part by part; the step's norm summed in
        // their order (a point without one adds zero).
        let mut steps = std::mem::take(&mut self.storage.point_steps);
        steps.resize(next.points.len(), Vec3::zeros());
        (next.points.par_chunks_mut(PART), steps.par_chunks_mut(PART))
            .into_par_iter()
            .zip(lin.parts.par_iter().zip(inverses.par_iter()))
            .for_each(|((xs, dxs), (part, invs))| {
                for (((x, dx), p), inv) in xs.iter_mut().zip(dxs).zip(&part.points).zip(invs) {
                    *dx = Vec3::zeros();
                    if let Some(inv) = inv {
                        let hd =
                            (part.hpc(p).iter()).fold(Vec3::zeros(), |a, (i, v)| a + v * dc[*i]);
                        *dx = inv * (p.bp - hd);
                        *x += *dx;
                    }
                }
            });
        step2 = steps.iter().fold(step2, |a, dx| a + dx.norm_squared());
        self.storage.point_steps = steps;
        self.storage.inverses = inverses;
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
    use super::super::linear::summed_by_index;
    use super::super::{Observation, TiePoint};
    use super::*;
    use std::collections::BTreeMap;

    /// A problem of two frames and 40 tie points over a sloping terrain, one observation in
    /// Huber's linear arm, attitudes and positions free, and a state near its minimum.
    fn with_fixture(run: impl FnOnce(&Problem<'_>, &State)) {
        with_ties(40, run)
    }

    /// [`with_fixture`]'s problem with `n` tie points: its 40 again and again, each copy
    /// shifted by about a centimetre, one observation in 40 in Huber's linear arm.
    fn with_ties(n: usize, run: impl FnOnce(&Problem<'_>, &State)) {
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
        let ties: Vec<TiePoint> = (0..n)
            .map(|k| {
                let copy = (k / 40) as f64;
                let g = [
                    (k % 8) as f64 * 6.0 - 20.0 + 0.01 * copy,
                    (k / 8 % 5) as f64 * 7.0 - 14.0 - 0.013 * copy,
                    1.0,
                ];
                let at = |f: usize, dx: f64| Observation {
                    frame: f,
                    pixel: [500.0 + g[0] * 7.0 + dx, 380.0 - g[1] * 7.0],
                    weight: 1.0,
                };
                TiePoint {
                    ground: g,
                    observations: vec![at(0, 140.0), at(1, -175.0 + f64::from(k % 40 == 7) * 40.0)],
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
    /// dense normal matrices with the priors, damped, and each point eliminated by a dense
    /// Schur complement of its own block (the points' blocks are independent). With 40 tie
    /// points (one part) and with 4,500 (18 parts over two chunks, the last of each short),
    /// the second damping on a linearisation and inverses that reuse the first's storage.
    #[test]
    fn the_reduced_system_is_the_dense_schur_complement() {
        for n in [40, 4500] {
            with_ties(n, |p, s| {
                let mut lin = p.linear(s, None).unwrap();
                let mut inverses = Vec::new();
                for lambda in [0.0, 1e-3] {
                    let (want, want_rhs) = dense_reduced(p, s, lambda);
                    lin = p.linear(s, Some(lin)).unwrap();
                    let (entries, rhs) = lin.reduced(lambda, &mut inverses);
                    assert!(inverses.iter().flatten().all(Option::is_some));
                    assert_eq!(inverses.iter().flatten().count(), n);
                    let nc = p.layout.len();
                    let mut got = nalgebra::DMatrix::<f64>::zeros(nc, nc);
                    for (i, j, v) in entries.lower_triplets() {
                        got[(i, j)] = v;
                        got[(j, i)] = v;
                    }
                    let scale = want.amax();
                    assert!((&got - &want).amax() <= 1e-9 * scale, "{n}: {got}\n{want}");
                    let rhs = nalgebra::DVector::from_vec(rhs);
                    let tol = 1e-9 * want_rhs.amax().max(1.0);
                    assert!((&rhs - &want_rhs).amax() <= tol, "{n}");
                }
            });
        }
    }

    /// The dense oracle of [`the_reduced_system_is_the_dense_schur_complement`].
    fn dense_reduced(
        p: &Problem<'_>,
        s: &State,
        lambda: f64,
    ) -> (nalgebra::DMatrix<f64>, nalgebra::DVector<f64>) {
        use super::super::jacobian::pixel_jacobian;
        use nalgebra::{DMatrix, DVector};
        let nc = p.layout.len();
        let (mut ncc, mut bc) = (DMatrix::<f64>::zeros(nc, nc), DVector::<f64>::zeros(nc));
        // Per point: its (nc + 3)-square normal matrix's point rows and its right-hand side.
        let mut points = Vec::new();
        let sig = p.opts.pixel_sigma;
        for (tie, x) in p.ties.iter().zip(&s.points) {
            let mut n = DMatrix::<f64>::zeros(nc + 3, nc + 3);
            let mut b = DVector::<f64>::zeros(nc + 3);
            for o in &tie.observations {
                let fr = &p.frames[o.frame];
                let (fb, cb) = (&s.frames[o.frame], &s.cameras[fr.camera]);
                let pj = pixel_jacobian(fr, &p.cameras[fr.camera], fb, cb, x).unwrap();
                let r = nalgebra::Vector2::new(pj.pixel[0] - o.pixel[0], pj.pixel[1] - o.pixel[1])
                    / sig;
                let w = p.weight(&r, o);
                let mut j = DMatrix::<f64>::zeros(2, nc + 3);
                for (a, i) in p.layout.local(o.frame, fr.camera).iter().enumerate() {
                    if let Some(i) = i {
                        j.set_column(*i, &(pj.local.column(a) / sig));
                    }
                }
                for k in 0..3 {
                    j.set_column(nc + k, &(pj.point.column(k) / sig));
                }
                n += j.transpose() * &j * w;
                b -= j.transpose() * DVector::from_column_slice(r.as_slice()) * w;
            }
            let (hp, bp) = p.point_prior_blocks(tie, x);
            let mut block = n.view_mut((nc, nc), (3, 3));
            block += hp;
            let mut rows = b.rows_mut(nc, 3);
            rows -= bp;
            ncc += n.view((0, 0), (nc, nc));
            bc += b.rows(0, nc);
            points.push((n, b));
        }
        for row in p.prior_rows(s) {
            let w = row.weight / (row.sigma * row.sigma);
            for &(i, a) in &row.terms {
                bc[i] -= w * a * row.value;
                for &(j, c) in &row.terms {
                    ncc[(i, j)] += w * a * c;
                }
            }
        }
        for i in 0..nc {
            ncc[(i, i)] += lambda * ncc[(i, i)].max(1e-9);
        }
        for (n, b) in &points {
            let mut pp = n.view((nc, nc), (3, 3)).clone_owned();
            for k in 0..3 {
                pp[(k, k)] += lambda * n[(nc + k, nc + k)].max(1e-9);
            }
            let ipp = pp.try_inverse().unwrap();
            let cp = n.view((0, nc), (nc, 3));
            ncc -= cp * &ipp * cp.transpose();
            bc -= cp * &ipp * b.rows(nc, 3);
        }
        (ncc, bc)
    }

    /// The points' blocks alone (a warm start's point passes) are those of the full
    /// linearisation, bit for bit, over a terrain prior and with one observation in Huber's
    /// linear arm.
    #[test]
    fn point_blocks_are_the_full_linearisations_points() {
        with_fixture(|p, s| {
            let lin = p.linear(s, None).unwrap();
            let blocks = p.point_blocks(s).unwrap();
            assert_eq!(blocks.len(), lin.points().count());
            assert!(lin.points().any(|q| q.robust), "no point in Huber's arm");
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for ((hpp, bp), q) in blocks.iter().zip(lin.points()) {
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
