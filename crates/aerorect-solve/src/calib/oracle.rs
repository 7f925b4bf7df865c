//! The analytic Jacobian against central differences (the numeric Jacobian the adjustment used
//! before, kept here as the oracle), the block solve against a dense one, and whole adjustments
//! against the same adjustment driven by the numeric Jacobian.
#![allow(clippy::unwrap_used, clippy::needless_range_loop)]

use super::blocks::BlockNormal;
use super::inputs::{CalibrationOptions, Observation};
use super::lm::NormalEquations;
use super::lm::{Dense, Problem, minimise};
use super::plan::{plan, point_shift};
use super::problem::Calib;
use aerorect_core::ImageSize;
use aerorect_core::distortion::Distortion;
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Central differences, step 1e-6 max(|start value|, 0.01) (the former adjustment's Jacobian).
fn numeric_jacobian(c: &Calib, z: &DVector<f64>) -> DMatrix<f64> {
    let m = c.residual_count();
    let mut j = DMatrix::zeros(m, z.len());
    let (mut rp, mut rm) = (DVector::zeros(m), DVector::zeros(m));
    for col in 0..z.len() {
        let h = 1e-6 * c.full0[c.free[col]].abs().max(1e-2);
        let (mut zp, mut zm) = (z.clone(), z.clone());
        zp[col] += h;
        zm[col] -= h;
        c.residuals_into(&zp, &mut rp);
        c.residuals_into(&zm, &mut rm);
        j.set_column(col, &((&rp - &rm) / (2.0 * h)));
    }
    j
}

/// Fourth-order central differences (step 1e-3 max(|x|, 0.01)): rounding and truncation
/// both near 1e-10 of a column, so the comparison can be tight.
fn five_point_jacobian(c: &Calib, z: &DVector<f64>) -> DMatrix<f64> {
    let m = c.residual_count();
    let mut j = DMatrix::zeros(m, z.len());
    let mut r = DVector::zeros(m);
    for col in 0..z.len() {
        let h = 1e-3 * z[col].abs().max(1e-2);
        for (k, w) in [(-2.0, 1.0), (-1.0, -8.0), (1.0, 8.0), (2.0, -1.0)] {
            let mut zk = z.clone();
            zk[col] += k * h;
            c.residuals_into(&zk, &mut r);
            let mut column = j.column_mut(col);
            column.axpy(w / (12.0 * h), &r, 1.0);
        }
    }
    j
}

/// The whole analytic Jacobian, read back from the blocks the adjustment builds.
fn analytic_jacobian(c: &Calib, z: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>, BlockNormal) {
    let m = c.residual_count();
    let mut r = DVector::zeros(m);
    c.residuals_into(z, &mut r);
    let mut n = c.new_normal();
    c.normal_into(z, &r, &mut n);
    let ng = c.free_globals;
    let mut j = DMatrix::zeros(m, z.len());
    for (v, b) in n.views.iter().enumerate() {
        for (k, &i) in c.views[v].iter().enumerate() {
            for row in 0..2 {
                for col in 0..ng {
                    j[(2 * i + row, col)] = b.jg[(2 * k + row, col)];
                }
                for col in 0..6 {
                    j[(2 * i + row, ng + 6 * v + col)] = b.jp[(2 * k + row, col)];
                }
            }
        }
    }
    (j, r, n)
}

/// Three views of a 3-D field (30 points each) at random poses (the first turned by 2e-9 rad:
/// the rotation's small-angle branch), seen at pinhole pixels plus up to 3 px of noise.
fn field(rng: &mut ChaCha8Rng, k: [f64; 5]) -> (Vec<Observation>, Vec<f64>) {
    let mut obs = vec![];
    let mut poses = vec![];
    for v in 0..3 {
        let w = if v == 0 {
            Vector3::new(1e-9, -2e-9, 0.0)
        } else {
            Vector3::from_fn(|_, _| rng.random_range(-0.4..0.4))
        };
        let t = Vector3::new(
            rng.random_range(-0.1..0.1),
            rng.random_range(-0.1..0.1),
            rng.random_range(1.5..2.5),
        );
        let rot = Rotation3::from_scaled_axis(w);
        for i in 0..30 {
            let world = [
                -0.6 + 0.2 * (i % 6) as f64,
                -0.5 + 0.25 * (i / 6) as f64,
                rng.random_range(0.0..0.2),
            ];
            let xc = rot * Vector3::from(world) + t;
            let (x, y) = (xc.x / xc.z, xc.y / xc.z);
            obs.push(Observation {
                image: format!("v{v}"),
                world,
                pixel: [
                    k[0] * x + k[4] * y + k[2] + rng.random_range(-3.0..3.0),
                    k[1] * y + k[3] + rng.random_range(-3.0..3.0),
                ],
            });
        }
        poses.extend(w.iter().chain(t.iter()));
    }
    (obs, poses)
}

/// A coefficient's random value on its usual scale.
fn coefficient(rng: &mut ChaCha8Rng, name: &str) -> f64 {
    let scale = match name {
        "k1" => 0.3,
        "k2" => 0.1,
        "k3" | "k4" | "k5" | "k6" => 0.05,
        _ => 2e-3,
    };
    rng.random_range(-scale..scale)
}

/// A random problem with every parameter free (skew too), or fy held at `aspect` fx.
fn random_problem(
    name: &str,
    seed: u64,
    aspect: Option<f64>,
) -> (Vec<Observation>, Distortion, Vec<usize>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let fx = rng.random_range(500.0..900.0);
    let fy = aspect.map_or_else(|| fx * rng.random_range(0.95..1.05), |a| fx * a);
    let k = [
        fx,
        fy,
        rng.random_range(300.0..340.0),
        rng.random_range(220.0..260.0),
        rng.random_range(-2.0..2.0),
    ];
    let mut model = Distortion::zero(name).unwrap();
    let coefficients: Vec<f64> = model
        .model()
        .names()
        .iter()
        .map(|n| coefficient(&mut rng, n))
        .collect();
    model.model_mut().set_params(&coefficients);
    let (obs, poses) = field(&mut rng, k);
    let mut full0 = k.to_vec();
    full0.extend(&coefficients);
    full0.extend(poses);
    let free = (0..full0.len())
        .filter(|&i| !(i == 1 && aspect.is_some()))
        .collect();
    (obs, model, free, full0)
}

fn views_of(obs: &[Observation]) -> Vec<Vec<usize>> {
    (0..3)
        .map(|v| {
            (0..obs.len())
                .filter(|&i| obs[i].image == format!("v{v}"))
                .collect()
        })
        .collect()
}

/// The largest difference in each column over the column's largest magnitude.
fn worst_column_error(a: &DMatrix<f64>, b: &DMatrix<f64>) -> (usize, f64) {
    (0..a.ncols())
        .map(|c| {
            let scale = b.column(c).amax().max(1e-300);
            (c, (a.column(c) - b.column(c)).amax() / scale)
        })
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .unwrap()
}

#[test]
fn analytic_jacobian_equals_central_differences_for_every_model() {
    for name in Distortion::NAMES {
        for seed in 0..4 {
            let aspect = (seed == 3).then_some(1.02);
            let (obs, model, free, full0) = random_problem(name, seed, aspect);
            let z = DVector::from_iterator(free.len(), free.iter().map(|&i| full0[i]));
            let c = Calib::new(&obs, views_of(&obs), model, free, full0, aspect);
            let (ja, _, _) = analytic_jacobian(&c, &z);
            let jn = five_point_jacobian(&c, &z);
            let (col, err) = worst_column_error(&ja, &jn);
            assert!(
                err < 5e-8,
                "{name}, seed {seed}: column {col} differs by {err:e} of its size"
            );
        }
    }
}

#[test]
fn block_solve_equals_the_dense_solve() {
    // Brown's offsets duplicate cx, cy and the rational terms k1..k3: their J^T J is nearly
    // singular undamped, so the covariance is compared on the other two.
    for name in ["opencv-rational-thin-prism", "brown", "opencv", "tsai"] {
        let (obs, model, free, full0) = random_problem(name, 7, None);
        let z = DVector::from_iterator(free.len(), free.iter().map(|&i| full0[i]));
        let c = Calib::new(&obs, views_of(&obs), model, free, full0, None);
        let (j, r, mut blocks) = analytic_jacobian(&c, &z);
        let mut dense = Dense {
            jtj: j.transpose() * &j,
            g: j.transpose() * &r,
        };
        for lambda in [1e-3, 1.0, 100.0] {
            let (mut a, mut b) = (DVector::zeros(z.len()), DVector::zeros(z.len()));
            assert!(dense.solve_damped(lambda, &mut a) && blocks.solve_damped(lambda, &mut b));
            let rel = (&a - &b).norm() / a.norm();
            assert!(
                rel < 1e-8,
                "{name}, lambda {lambda}: steps differ by {rel:e}"
            );
        }
        if ["brown", "opencv-rational-thin-prism"].contains(&name) {
            continue;
        }
        let ng = c.free_globals;
        let full = dense.jtj.clone().try_inverse().unwrap();
        let want = full.view((0, 0), (ng, ng));
        let got = blocks.global_inverse().unwrap();
        let rel = (&got - want).norm() / want.norm();
        assert!(rel < 1e-8, "{name}: covariance differs by {rel:e}");
    }
}

/// The adjustment driven by the numeric Jacobian (dense normal equations).
struct Numeric<'a, 'b>(&'b Calib<'a>);

impl Problem for Numeric<'_, '_> {
    type Normal = Dense;
    fn residual_count(&self) -> usize {
        self.0.residual_count()
    }
    fn residuals_into(&self, x: &DVector<f64>, r: &mut DVector<f64>) {
        self.0.residuals_into(x, r);
    }
    fn new_normal(&self) -> Dense {
        let n = self.0.free.len();
        Dense {
            jtj: DMatrix::zeros(n, n),
            g: DVector::zeros(n),
        }
    }
    fn normal_into(&self, x: &DVector<f64>, r: &DVector<f64>, n: &mut Dense) {
        let j = numeric_jacobian(self.0, x);
        n.jtj = j.transpose() * &j;
        n.g = j.transpose() * r;
    }
}

fn opencv_corners() -> Vec<Observation> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_corners.csv");
    let mut rdr = csv::Reader::from_path(path).unwrap();
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| r[i].parse::<f64>().unwrap();
            Observation {
                image: r[0].to_string(),
                world: [f(1), f(2), f(3)],
                pixel: [f(4), f(5)],
            }
        })
        .collect()
}

/// OpenCV's 13 chessboard views, every model but the rational ones (on one plane their terms
/// duplicate k1..k3 and `calibrate` holds them): the same RMS, and fx, fy, cx, cy within 1e-5 px
/// (seen: 7e-6 at most); the thin prism, which a plane barely separates from the principal
/// point, within 1e-3 px (seen: 4e-4 in cx).
#[test]
fn adjustment_lands_where_the_numeric_jacobian_did() {
    let obs = opencv_corners();
    for (name, tol) in [
        ("tsai", 1e-5),
        ("brown", 1e-5),
        ("improved", 1e-5),
        ("opencv", 1e-5),
        ("opencv-thin-prism", 1e-3),
    ] {
        let mut opts =
            CalibrationOptions::new(Distortion::zero(name).unwrap(), ImageSize::new(640, 480));
        opts.stop_px = 1e-6;
        let p = plan(&obs, &opts).unwrap();
        let a = minimise(&p.problem, p.z0.clone(), 200, 1e-6, point_shift);
        let n = minimise(&Numeric(&p.problem), p.z0.clone(), 200, 1e-6, point_shift);
        let (rms_a, rms_n) = (a.residuals.norm(), n.residuals.norm());
        assert!(
            (rms_a - rms_n).abs() < 1e-9 * rms_n,
            "{name}: |r| {rms_a} vs {rms_n}"
        );
        let (xa, xn) = (p.problem.expand(&a.x), p.problem.expand(&n.x));
        for i in 0..4 {
            assert!(
                (xa[i] - xn[i]).abs() < tol,
                "{name}: {} {} vs {}",
                p.global[i],
                xa[i],
                xn[i]
            );
        }
    }
}
