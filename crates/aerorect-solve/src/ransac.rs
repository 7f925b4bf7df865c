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
    /// A consensus smaller than this is of no use to the caller (0: any): sampling stops
    /// once a sample of that many inliers among the pairs would have been drawn with
    /// `confidence` ([`iterations_for_count`]) and none was. Two
    /// frames that share nothing give 20-45 chance matches and 8-12 chance inliers; without
    /// this their fundamental matrix drew all 4000 samples, most of a flight's verification.
    pub min_inliers: usize,
}

impl Default for RansacOptions {
    fn default() -> Self {
        Self {
            threshold: 2.0,
            max_iterations: 2000,
            confidence: 0.999,
            seed: 1,
            min_inliers: 0,
        }
    }
}

/// Samples of `size` pairs to draw so that one of them is all inliers with probability
/// `confidence`, when a fraction `ratio` of the pairs are inliers (at least 1; `usize::MAX`
/// when no sample can be all inliers).
pub fn iterations_for(ratio: f64, size: i32, confidence: f64) -> usize {
    let miss = 1.0 - ratio.clamp(0.0, 1.0).powi(size);
    if miss <= f64::EPSILON {
        return 1;
    }
    if miss >= 1.0 {
        return usize::MAX;
    }
    ((1.0 - confidence).ln() / miss.ln()).ceil().max(1.0) as usize
}

/// Samples of `size` distinct pairs of `n` to draw so that one of them is all inliers with
/// probability `confidence` when exactly `inliers` of the `n` are: the chance of one sample is
/// C(inliers, size) / C(n, size), drawn without replacement. For few pairs that is well below
/// [`iterations_for`]'s `ratio^size` (20 of 40 for 8: 0.0016, not 0.0039), so giving up after
/// that count would miss the consensus one time in twenty, not one in a thousand.
pub fn iterations_for_count(inliers: usize, n: usize, size: usize, confidence: f64) -> usize {
    if inliers < size || n < inliers {
        return usize::MAX;
    }
    let hit: f64 = (0..size)
        .map(|k| (inliers - k) as f64 / (n - k) as f64)
        .product();
    iterations_for(hit, 1, confidence)
}

/// The samples to draw before giving up on a consensus of `opts.min_inliers` among `n` pairs
/// when none so large has been found (`usize::MAX` when any consensus will do).
pub(crate) fn hopeless_after(n: usize, size: usize, opts: &RansacOptions) -> usize {
    if opts.min_inliers == 0 {
        return usize::MAX;
    }
    iterations_for_count(opts.min_inliers.min(n), n, size, opts.confidence)
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

/// Whether each pair agrees with `h` within `threshold` (compared squared: `hypot` was a
/// tenth of a pair's matching and verification).
fn agree(h: &Homography, from: &[[f64; 2]], to: &[[f64; 2]], threshold: f64) -> Vec<bool> {
    let t2 = threshold * threshold;
    from.iter()
        .zip(to)
        .map(|(f, t)| {
            h.map(f[0], f[1]).is_some_and(|m| {
                let (dx, dy) = (m[0] - t[0], m[1] - t[1]);
                dx * dx + dy * dy <= t2
            })
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
    let hopeless = hopeless_after(n, 4, opts);
    while it < needed.min(opts.max_iterations) {
        if best_count < opts.min_inliers && it >= hopeless {
            break;
        }
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
            needed = iterations_for(count as f64 / n as f64, 4, opts.confidence).max(it);
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
