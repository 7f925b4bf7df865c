//! Descriptor matching speed: one pair of frames' SIFT-like descriptors (1,000 and 2,000 a
//! frame, the 1,000-frame simulation's 1,051 on average), half of them noisy copies of the
//! other frame's, by `match_float` (ratio test and mutual check), and guided within a window
//! around each query's predicted position (`match_float_within`), the same as bytes
//! (`match_bytes_within`).
#![allow(clippy::unwrap_used)]

use aerorect_solve::matching::{
    MatchOptions, Window, bytes_of_whole, match_bytes_within, match_float, match_float_within,
};
use criterion::{Criterion, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const DIM: usize = 128;

/// `n` descriptors of two frames: non-negative whole numbers, each row normalised to 512 and
/// saturated to 255 as SIFT's are; the second frame's first half are the first frame's with noise.
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
        // Rounded and saturated to whole numbers in 0..=255, as SIFT's are.
        v.iter_mut()
            .for_each(|x| *x = (*x * 512.0 / norm).round_ties_even().min(255.0));
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

/// Positions for [`pair`]'s rows on a 480 x 360 frame (the simulation's): the second frame's
/// copies where the first frame's rows are, the rest anywhere; each query predicted within
/// 20 px of its row's position.
fn positions(n: usize, seed: u64) -> (Vec<Option<[f64; 2]>>, Vec<[f64; 2]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut anywhere = || [rng.random_range(0.0..480.0), rng.random_range(0.0..360.0)];
    let a: Vec<[f64; 2]> = (0..n).map(|_| anywhere()).collect();
    let b: Vec<[f64; 2]> = (0..n)
        .map(|i| if i < n / 2 { a[i] } else { anywhere() })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed + 1);
    let predicted = a
        .iter()
        .map(|p| Some(p.map(|v| v + rng.random_range(-20.0..20.0))))
        .collect();
    (predicted, b)
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
        // Guided, at about the 1,000-frame simulation's radius (a 1 degree prior: 70 px).
        let (query_at, train_at) = positions(n, 9);
        let w = Window {
            query_at: &query_at,
            train_at: &train_at,
            radius: 70.0,
        };
        let found = match_float_within(&a, &b, DIM, &w, &opts).unwrap();
        assert!(found.len() > n / 4, "{} guided matches of {n}", found.len());
        c.bench_function(&format!("match_float_within {n} x {n}, radius 70"), |bch| {
            bch.iter(|| match_float_within(&a, &b, DIM, &w, &opts))
        });
        // The same descriptors held as bytes (the same matches).
        let (ab, bb) = (bytes_of_whole(&a).unwrap(), bytes_of_whole(&b).unwrap());
        assert_eq!(match_bytes_within(&ab, &bb, DIM, &w, &opts).unwrap(), found);
        c.bench_function(&format!("match_bytes_within {n} x {n}, radius 70"), |bch| {
            bch.iter(|| match_bytes_within(&ab, &bb, DIM, &w, &opts))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
