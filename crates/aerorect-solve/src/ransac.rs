//! Seeded RANSAC for a homography between tie points.

use crate::SolveError;
use crate::gcp::fit_projective;
use aerorect_core::Homography;
use rand::SeedableRng;
use rand::seq::index::sample;
use rand_chacha::ChaCha8Rng;

/// RANSAC settings; the same seed gives the same result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RansacOptions {
    /// A pair is an inlier when the model maps `from` within this distance of `to`.
    pub threshold: f64,
    pub max_iterations: usize,
    /// Stop sampling once an all-inlier sample has been drawn with this probability.
    pub confidence: f64,
    pub seed: u64,
}

impl Default for RansacOptions {
    fn default() -> Self {
        Self {
            threshold: 2.0,
            max_iterations: 2000,
            confidence: 0.999,
            seed: 1,
        }
    }
}

/// The consensus homography and which pairs agree with it.
#[derive(Debug, Clone)]
pub struct RansacFit {
    pub model: Homography,
    pub inliers: Vec<bool>,
    pub iterations: usize,
}

impl RansacFit {
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

fn agree(h: &Homography, from: &[[f64; 2]], to: &[[f64; 2]], threshold: f64) -> Vec<bool> {
    from.iter()
        .zip(to)
        .map(|(f, t)| {
            h.map(f[0], f[1])
                .is_some_and(|m| (m[0] - t[0]).hypot(m[1] - t[1]) <= threshold)
        })
        .collect()
}

fn subset(points: &[[f64; 2]], keep: &[bool]) -> Vec<[f64; 2]> {
    points
        .iter()
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(p, _)| *p)
        .collect()
}

/// `to_from_from` by RANSAC over minimal 4-point samples, then least squares on the consensus
/// set, repeated until the set stops changing. Refuses fewer than 4 pairs, or no consensus of
/// at least 4.
pub fn ransac_homography(
    from: &[[f64; 2]],
    to: &[[f64; 2]],
    opts: &RansacOptions,
) -> Result<RansacFit, SolveError> {
    let n = from.len().min(to.len());
    if n < 4 {
        return Err(SolveError::TooFewPoints { got: n, need: 4 });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let (mut best, mut best_count) = (None::<Vec<bool>>, 0usize);
    let (mut needed, mut it) = (opts.max_iterations, 0);
    while it < needed.min(opts.max_iterations) {
        it += 1;
        let pick = sample(&mut rng, n, 4).into_vec();
        let (f, t): (Vec<_>, Vec<_>) = pick.iter().map(|&k| (from[k], to[k])).unzip();
        let Ok(h) = crate::fit_homography(&f, &t) else {
            continue;
        };
        let inl = agree(&h, &from[..n], &to[..n], opts.threshold);
        let count = inl.iter().filter(|&&b| b).count();
        if count > best_count {
            best_count = count;
            best = Some(inl);
            let ratio = count as f64 / n as f64;
            let miss = 1.0 - ratio.powi(4);
            if miss <= f64::EPSILON {
                needed = it;
            } else {
                needed = ((1.0 - opts.confidence).ln() / miss.ln()).ceil().max(1.0) as usize;
            }
        }
    }
    let mut inliers = best.ok_or(SolveError::Degenerate)?;
    if best_count < 4 {
        return Err(SolveError::TooFewPoints {
            got: best_count,
            need: 4,
        });
    }
    let mut model = fit_projective(&subset(&from[..n], &inliers), &subset(&to[..n], &inliers))?;
    for _ in 0..5 {
        let next = agree(&model, &from[..n], &to[..n], opts.threshold);
        if next == inliers || next.iter().filter(|&&b| b).count() < 4 {
            break;
        }
        inliers = next;
        model = fit_projective(&subset(&from[..n], &inliers), &subset(&to[..n], &inliers))?;
    }
    Ok(RansacFit {
        model,
        inliers,
        iterations: it,
    })
}
