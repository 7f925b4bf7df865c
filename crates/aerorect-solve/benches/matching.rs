//! Descriptor matching speed: one pair of frames' SIFT-like descriptors (1,000 and 2,000 a
//! frame, the 1,000-frame simulation's 1,051 on average), half of them noisy copies of the
//! other frame's, by `match_float` (ratio test and mutual check).
#![allow(clippy::unwrap_used)]

use aerorect_solve::matching::{MatchOptions, match_float};
use criterion::{Criterion, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const DIM: usize = 128;

/// `n` descriptors of two frames: non-negative values, each row normalised to 512 as SIFT's
/// are; the second frame's first half are the first frame's with noise.
fn pair(n: usize, seed: u64) -> (Vec<f32>, Vec<f32>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut row = |base: Option<&[f32]>| -> Vec<f32> {
        let mut v: Vec<f32> = (0..DIM)
            .map(|k| match base {
                Some(b) => (b[k] + rng.random_range(-20.0f32..20.0)).max(0.0),
                None => rng.random_range(0.0f32..1.0).powi(3) * 100.0,
            })
            .collect();
        let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt().max(1e-6);
        v.iter_mut().for_each(|x| *x *= 512.0 / norm);
        v
    };
    let a: Vec<f32> = (0..n).flat_map(|_| row(None)).collect();
    let mut b = Vec::with_capacity(n * DIM);
    for i in 0..n {
        let r = if i < n / 2 {
            row(Some(&a[i * DIM..(i + 1) * DIM]))
        } else {
            row(None)
        };
        b.extend(r);
    }
    (a, b)
}

fn bench(c: &mut Criterion) {
    let opts = MatchOptions::default();
    for n in [1000, 2000] {
        let (a, b) = pair(n, 7);
        let found = match_float(&a, &b, DIM, &opts).unwrap();
        assert!(found.len() > n / 4, "{} matches of {n}", found.len());
        c.bench_function(&format!("match_float {n} x {n}"), |bch| {
            bch.iter(|| match_float(&a, &b, DIM, &opts))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
