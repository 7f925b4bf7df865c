//! The fundamental matrix: Hartley's normalised 8-point algorithm (Hartley 1997; Hartley &
//! Zisserman, "Multiple View Geometry", algorithm 11.1) with the rank-2 constraint, the Sampson
//! distance, and a seeded RANSAC over minimal 8-point samples.
//!
//! `F` relates pixel positions x in the first frame and x' in the second by x'^T F x = 0.

use crate::ransac::{RansacOptions, hopeless_after, iterations_for};
use crate::{SolveError, normaliser};
use aerorect_core::Mat3;
use nalgebra::{DMatrix, Vector3};
use rand::SeedableRng;
use rand::seq::index::sample;
use rand_chacha::ChaCha8Rng;

/// x'^T F x = 0 for x in the first frame and x' in the second; unit Frobenius norm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fundamental {
    pub matrix: Mat3,
}

impl Fundamental {
    /// The algebraic residual x'^T F x.
    pub fn residual(&self, x: [f64; 2], x2: [f64; 2]) -> f64 {
        (Vector3::new(x2[0], x2[1], 1.0).transpose() * self.matrix * Vector3::new(x[0], x[1], 1.0))
            [0]
    }

    /// The Sampson distance in pixels: the first-order distance of the pair (x, x') from the
    /// nearest pair that satisfies the epipolar constraint.
    pub fn sampson(&self, x: [f64; 2], x2: [f64; 2]) -> f64 {
        let (p, q) = (
            Vector3::new(x[0], x[1], 1.0),
            Vector3::new(x2[0], x2[1], 1.0),
        );
        let fp = self.matrix * p;
        let ftq = self.matrix.transpose() * q;
        let g = fp.x * fp.x + fp.y * fp.y + ftq.x * ftq.x + ftq.y * ftq.y;
        if g <= 0.0 {
            return f64::INFINITY;
        }
        (q.dot(&fp)).abs() / g.sqrt()
    }
}

/// The fundamental matrix through eight or more pairs by the normalised 8-point algorithm,
/// rank 2 enforced by zeroing the smallest singular value.
pub fn fit_fundamental(first: &[[f64; 2]], second: &[[f64; 2]]) -> Result<Fundamental, SolveError> {
    let n = first.len().min(second.len());
    if n < 8 {
        return Err(SolveError::TooFewPoints { got: n, need: 8 });
    }
    if let Some(index) = (0..n).find(|&i| first[i].iter().chain(&second[i]).any(|v| !v.is_finite()))
    {
        return Err(SolveError::NotFinite { index });
    }
    let (ta, tb) = (normaliser(&first[..n]), normaliser(&second[..n]));
    let mut a = DMatrix::<f64>::zeros(n.max(9), 9);
    for i in 0..n {
        let p = ta * Vector3::new(first[i][0], first[i][1], 1.0);
        let q = tb * Vector3::new(second[i][0], second[i][1], 1.0);
        let (x, y, u, v) = (p.x, p.y, q.x, q.y);
        a.row_mut(i)
            .copy_from_slice(&[u * x, u * y, u, v * x, v * y, v, x, y, 1.0]);
    }
    let svd = a.svd(false, true);
    let v_t = svd.v_t.ok_or(SolveError::Degenerate)?;
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[i].total_cmp(&svd.singular_values[j]));
    if svd.singular_values[order[1]] <= 1e-10 * svd.singular_values.max() {
        return Err(SolveError::Degenerate);
    }
    let f = v_t.row(order[0]);
    let fn_ = Mat3::new(f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8]);
    let rank2 = rank_two(fn_)?;
    let m = tb.transpose() * rank2 * ta;
    let norm = m.norm();
    if !(norm > 0.0 && norm.is_finite()) {
        return Err(SolveError::Degenerate);
    }
    Ok(Fundamental { matrix: m / norm })
}

/// The nearest rank-2 matrix in the Frobenius norm.
fn rank_two(m: Mat3) -> Result<Mat3, SolveError> {
    let svd = m.svd(true, true);
    let (u, v_t) = (
        svd.u.ok_or(SolveError::Degenerate)?,
        svd.v_t.ok_or(SolveError::Degenerate)?,
    );
    let mut s = svd.singular_values;
    let k = s.imin();
    s[k] = 0.0;
    Ok(u * Mat3::from_diagonal(&s) * v_t)
}

/// The consensus fundamental matrix and which pairs lie within the threshold (Sampson
/// distance, pixels) of it.
#[derive(Debug, Clone)]
pub struct FundamentalFit {
    pub model: Fundamental,
    pub inliers: Vec<bool>,
    pub iterations: usize,
}

impl FundamentalFit {
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

fn agree(f: &Fundamental, a: &[[f64; 2]], b: &[[f64; 2]], threshold: f64) -> Vec<bool> {
    a.iter()
        .zip(b)
        .map(|(x, y)| f.sampson(*x, *y) <= threshold)
        .collect()
}

fn kept(points: &[[f64; 2]], keep: &[bool]) -> Vec<[f64; 2]> {
    points
        .iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(*p))
        .collect()
}

/// RANSAC over minimal 8-point samples (sample count adapted to the inlier ratio at
/// `opts.confidence`), then the 8-point fit on the consensus set, refitted until the set stops
/// changing. Refuses fewer than 8 pairs or a consensus below 8.
pub fn ransac_fundamental(
    first: &[[f64; 2]],
    second: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<FundamentalFit, SolveError> {
    let n = first.len().min(second.len());
    if n < 8 {
        return Err(SolveError::TooFewPoints { got: n, need: 8 });
    }
    let (a, b) = (&first[..n], &second[..n]);
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let (mut best, mut best_count) = (None::<Vec<bool>>, 0usize);
    let (mut needed, mut it) = (opts.max_iterations, 0);
    let hopeless = hopeless_after(n, 8, opts);
    while it < needed.min(opts.max_iterations) {
        if best_count < opts.min_inliers && it >= hopeless {
            break;
        }
        it += 1;
        let pick = sample(&mut rng, n, 8).into_vec();
        let (f, t): (Vec<_>, Vec<_>) = pick.iter().map(|&k| (a[k], b[k])).unzip();
        let Ok(model) = fit_fundamental(&f, &t) else {
            continue;
        };
        let inl = agree(&model, a, b, opts.threshold);
        let count = inl.iter().filter(|&&k| k).count();
        if count > best_count {
            best_count = count;
            best = Some(inl);
            needed = iterations_for(count as f64 / n as f64, 8, opts.confidence).max(it);
        }
    }
    let mut inliers = best.ok_or(SolveError::Degenerate)?;
    if best_count < 8 {
        return Err(SolveError::TooFewPoints {
            got: best_count,
            need: 8,
        });
    }
    let mut model = fit_fundamental(&kept(a, &inliers), &kept(b, &inliers))?;
    for _ in 0..5 {
        let next = agree(&model, a, b, opts.threshold);
        if next == inliers || next.iter().filter(|&&k| k).count() < 8 {
            break;
        }
        inliers = next;
        model = fit_fundamental(&kept(a, &inliers), &kept(b, &inliers))?;
    }
    let last = agree(&model, a, b, opts.threshold);
    if last.iter().filter(|&&k| k).count() >= 8 {
        inliers = last;
    }
    Ok(FundamentalFit {
        model,
        inliers,
        iterations: it,
    })
}
