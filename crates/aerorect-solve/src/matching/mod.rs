//! Brute-force descriptor matching: L2 for float descriptors (SIFT), Hamming for binary ones
//! (ORB), with Lowe's ratio test and a mutual (cross) check. Float distances come from one
//! matrix product per block of queries (`|q|^2 + |t|^2 - 2 q.t`, faer's SIMD kernels: about
//! ten times the plain loop's speed), the best and second-best of each query recomputed
//! directly so that the ratio test sees exact distances. Guided matching
//! ([`match_float_within`]) compares each query only with the train rows near where it is
//! predicted to lie.
//!
//! Descriptors are rows of one flat slice (`dim` values a row), so this crate needs no image
//! or keypoint type: the caller keeps the keypoints' positions in the same order (and passes
//! them as plain `[x, y]` for guided matching).

use thiserror::Error;

mod scan;
#[cfg(target_arch = "x86_64")]
mod scan_avx2;
mod within;
use scan::{Columns, Row, Scratch, scan_row};
pub use within::{Element, Window, bytes_of_whole, match_bytes_within, match_float_within};

#[derive(Debug, Error, Clone, PartialEq)]
pub enum MatchError {
    #[error("descriptor length {dim} is not usable (it must be at least 1)")]
    ZeroLength { dim: usize },
    #[error("{which} descriptors hold {len} values, not a multiple of the length {dim}")]
    Ragged {
        which: &'static str,
        len: usize,
        dim: usize,
    },
    #[error("ratio {ratio} is outside (0, 1]")]
    Ratio { ratio: f32 },
    #[error("{rows} {which} descriptors: at most {} can be matched", u32::MAX - 1)]
    TooMany { which: &'static str, rows: usize },
    #[error("{positions} {which} positions for {rows} {which} descriptors")]
    Positions {
        which: &'static str,
        positions: usize,
        rows: usize,
    },
    #[error("search radius {radius} is not a positive finite number")]
    Radius { radius: f64 },
}

/// Matching settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchOptions {
    /// Lowe's ratio: keep a match when its distance is below `ratio` times the second-best
    /// distance (0.8 in Lowe 2004; 1 turns the test off).
    pub ratio: f32,
    /// Keep a match only when each descriptor is the other's nearest neighbour.
    pub mutual: bool,
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self {
            ratio: 0.8,
            mutual: true,
        }
    }
}

impl MatchOptions {
    pub fn validate(&self) -> Result<(), MatchError> {
        if self.ratio > 0.0 && self.ratio <= 1.0 {
            Ok(())
        } else {
            Err(MatchError::Ratio { ratio: self.ratio })
        }
    }
}

/// Descriptor `query` of the first set matches descriptor `train` of the second at `distance`
/// (Euclidean for float descriptors, bits for binary ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    pub query: usize,
    pub train: usize,
    pub distance: f32,
}

fn rows(which: &'static str, len: usize, dim: usize) -> Result<usize, MatchError> {
    if dim == 0 {
        return Err(MatchError::ZeroLength { dim });
    }
    if !len.is_multiple_of(dim) {
        return Err(MatchError::Ragged { which, len, dim });
    }
    Ok(len / dim)
}

/// [`rows`], refusing more than `u32` indices (the searches keep them as `u32`).
fn counted_rows(which: &'static str, len: usize, dim: usize) -> Result<usize, MatchError> {
    let rows = rows(which, len, dim)?;
    if rows >= u32::MAX as usize {
        return Err(MatchError::TooMany { which, rows });
    }
    Ok(rows)
}

/// Squared Euclidean distance; eight running sums so the loop vectorises.
pub fn l2_squared(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            let d = x[k] - y[k];
            acc[k] += d * d;
        }
    }
    let tail: f32 = ra.iter().zip(rb).map(|(x, y)| (x - y) * (x - y)).sum();
    acc.iter().sum::<f32>() + tail
}

/// Squared Euclidean distance of byte rows, exact for rows of up to 66,051 values; sixteen
/// running sums of whole numbers so the loop vectorises (twice the values per instruction of
/// [`l2_squared`], a quarter of its memory per row).
pub fn l2_squared_bytes(a: &[u8], b: &[u8]) -> u32 {
    let mut acc = [0u32; 16];
    let (ca, cb) = (a.chunks_exact(16), b.chunks_exact(16));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..16 {
            let d = i32::from(i16::from(x[k]) - i16::from(y[k]));
            acc[k] += (d * d) as u32;
        }
    }
    let tail = ra.iter().zip(rb).map(|(&x, &y)| x.abs_diff(y) as u32);
    acc.iter().sum::<u32>() + tail.map(|d| d * d).sum::<u32>()
}

/// Number of differing bits.
pub fn hamming(a: &[u8], b: &[u8]) -> u32 {
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    let word = |c: &[u8]| u64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]);
    let full: u32 = ca
        .zip(cb)
        .map(|(x, y)| (word(x) ^ word(y)).count_ones())
        .sum();
    full + ra
        .iter()
        .zip(rb)
        .map(|(x, y)| (x ^ y).count_ones())
        .sum::<u32>()
}

/// Per query row: (best train row, best distance, second-best distance).
type RowBest = Vec<(usize, f32, f32)>;
/// Per train row: (best query row, its distance).
type ColumnBest = Vec<(usize, f32)>;

/// The best and second-best distance per query row, and the best query per train row, in one
/// pass over all (query, train) distances `dist(i, j)`.
fn nearest(nq: usize, nt: usize, dist: impl Fn(usize, usize) -> f32) -> (RowBest, ColumnBest) {
    let mut column = vec![(usize::MAX, f32::INFINITY); nt];
    let mut row = Vec::with_capacity(nq);
    for i in 0..nq {
        let (mut best, mut second, mut best_j) = (f32::INFINITY, f32::INFINITY, usize::MAX);
        for (j, col) in column.iter_mut().enumerate() {
            let d = dist(i, j);
            if d < best {
                second = best;
                best = d;
                best_j = j;
            } else if d < second {
                second = d;
            }
            if d < col.1 {
                *col = (i, d);
            }
        }
        row.push((best_j, best, second));
    }
    (row, column)
}

/// Applies the ratio test (on distances `d`, given as `d` itself or squared by `squared`) and
/// the mutual check.
fn select(
    row: &[(usize, f32, f32)],
    column: &[(usize, f32)],
    opts: &MatchOptions,
    squared: bool,
) -> Vec<Match> {
    let ratio = if squared {
        opts.ratio * opts.ratio
    } else {
        opts.ratio
    };
    row.iter()
        .enumerate()
        .filter(|(_, (j, best, second))| {
            *j != usize::MAX && (opts.ratio >= 1.0 || *best < ratio * *second)
        })
        .filter(|(i, (j, _, _))| !opts.mutual || column[*j].0 == *i)
        .map(|(i, &(j, best, _))| Match {
            query: i,
            train: j,
            distance: if squared { best.sqrt() } else { best },
        })
        .collect()
}

/// Queries per block of the float distance matrix (a block of 256 x 4000 distances is 4 MB).
const FLOAT_BLOCK: usize = 256;

/// Per query the best and second-best train row by squared L2 distance, and per train row the
/// best query, from matrix products of blocks of queries with all train rows. Each block's
/// products are stored one query per contiguous column, so the scans over train rows
/// ([`scan_row`]) run on contiguous slices and vectorise (they were
/// strided through the product and cost more than the product itself: 20 s of CPU against
/// its 16 s on the 1,000-frame simulation).
fn nearest_float(query: &[f32], train: &[f32], dim: usize) -> (RowBest, ColumnBest) {
    let (nq, nt) = (query.len() / dim, train.len() / dim);
    let norms = |v: &[f32]| -> Vec<f32> {
        v.chunks_exact(dim)
            .map(|r| r.iter().map(|x| x * x).sum())
            .collect()
    };
    let (qn, tn) = (norms(query), norms(train));
    let t = faer::MatRef::from_row_major_slice(train, nt, dim);
    let mut columns = Columns::new(nt);
    let mut row = Vec::with_capacity(nq);
    let mut dots = vec![0f32; nt * FLOAT_BLOCK.min(nq)];
    let mut scratch = Scratch::new(nt);
    for start in (0..nq).step_by(FLOAT_BLOCK) {
        let rows = FLOAT_BLOCK.min(nq - start);
        let q = faer::MatRef::from_row_major_slice(
            &query[start * dim..(start + rows) * dim],
            rows,
            dim,
        );
        // Train rows x queries, column-major: query r's products are one contiguous column.
        let d = faer::MatMut::from_column_major_slice_mut(&mut dots[..nt * rows], nt, rows);
        faer::linalg::matmul::matmul(
            d,
            faer::Accum::Replace,
            t,
            q.transpose(),
            1.0f32,
            faer::Par::Seq,
        );
        for (r, products) in dots.chunks_exact(nt).take(rows).enumerate() {
            let i = start + r;
            let (best, second) = scan_row(
                Row {
                    qn: qn[i],
                    products,
                    tn: &tn,
                    i,
                },
                &mut columns,
                &mut scratch,
            );
            let q = &query[i * dim..(i + 1) * dim];
            row.push(exact_two(q, train, dim, [best.1, second.1]));
        }
    }
    let column = columns
        .query
        .iter()
        .zip(&columns.distance)
        .map(|(&i, &d)| {
            (
                if i == u32::MAX {
                    usize::MAX
                } else {
                    i as usize
                },
                d,
            )
        })
        .collect();
    (row, column)
}

/// The two candidates' (train rows, `usize::MAX` for none) exact squared distances to query
/// row `q` (a matrix product's rounding is a few units of the norms' last place): (best row,
/// best, second best).
fn exact_two(q: &[f32], train: &[f32], dim: usize, candidates: [usize; 2]) -> (usize, f32, f32) {
    let exact = |j: usize| match j {
        usize::MAX => f32::INFINITY,
        j => l2_squared(q, &train[j * dim..(j + 1) * dim]),
    };
    let [b, s] = candidates.map(|j| (exact(j), j));
    let (b, s) = if s.0 < b.0 { (s, b) } else { (b, s) };
    (b.1, b.0, s.0)
}

/// Matches float descriptors (rows of `dim` values) of `query` against `train` by Euclidean
/// distance.
pub fn match_float(
    query: &[f32],
    train: &[f32],
    dim: usize,
    opts: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    opts.validate()?;
    counted_rows("query", query.len(), dim)?;
    counted_rows("train", train.len(), dim)?;
    let (row, column) = nearest_float(query, train, dim);
    Ok(select(&row, &column, opts, true))
}

/// Matches binary descriptors (rows of `bytes` bytes) of `query` against `train` by Hamming
/// distance.
pub fn match_binary(
    query: &[u8],
    train: &[u8],
    bytes: usize,
    opts: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    opts.validate()?;
    let (nq, nt) = (
        rows("query", query.len(), bytes)?,
        rows("train", train.len(), bytes)?,
    );
    let (row, column) = nearest(nq, nt, |i, j| {
        hamming(
            &query[i * bytes..(i + 1) * bytes],
            &train[j * bytes..(j + 1) * bytes],
        ) as f32
    });
    Ok(select(&row, &column, opts, false))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The slow oracle: every distance sorted, per query and per train row.
    fn oracle(q: &[Vec<f32>], t: &[Vec<f32>], opts: &MatchOptions) -> Vec<(usize, usize)> {
        oracle_where(q, t, opts, |_, _| true)
    }

    /// The slow oracle over the pairs (query, train) that `holds`: per query every such train
    /// row sorted by distance (f64), per train row every such query.
    pub(super) fn oracle_where(
        q: &[Vec<f32>],
        t: &[Vec<f32>],
        opts: &MatchOptions,
        holds: impl Fn(usize, usize) -> bool,
    ) -> Vec<(usize, usize)> {
        let d = |a: &[f32], b: &[f32]| -> f64 {
            let s: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
            s.sqrt()
        };
        let mut out = vec![];
        for (i, a) in q.iter().enumerate() {
            let mut ds: Vec<(f64, usize)> = (0..t.len())
                .filter(|&j| holds(i, j))
                .map(|j| (d(a, &t[j]), j))
                .collect();
            ds.sort_by(|x, y| x.0.total_cmp(&y.0));
            let Some(&(best, j)) = ds.first() else {
                continue;
            };
            let second = ds.get(1).map_or(f64::INFINITY, |s| s.0);
            if best >= opts.ratio as f64 * second {
                continue;
            }
            let back = (0..q.len())
                .filter(|&k| holds(k, j))
                .map(|k| (d(&q[k], &t[j]), k))
                .min_by(|x, y| x.0.total_cmp(&y.0))
                .map(|x| x.1);
            if !opts.mutual || back == Some(i) {
                out.push((i, j));
            }
        }
        out
    }

    #[test]
    fn float_matches_equal_the_sorted_distance_oracle() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let dim = 20;
        let t: Vec<Vec<f32>> = (0..150)
            .map(|_| (0..dim).map(|_| rng.random::<f32>()).collect())
            .collect();
        // Queries: noisy copies of some train rows, plus unrelated rows.
        let q: Vec<Vec<f32>> = (0..120)
            .map(|i| {
                if i % 3 == 0 {
                    (0..dim).map(|_| rng.random::<f32>()).collect()
                } else {
                    t[i].iter()
                        .map(|v| v + 0.05 * rng.random::<f32>())
                        .collect()
                }
            })
            .collect();
        for opts in [
            MatchOptions::default(),
            MatchOptions {
                ratio: 0.95,
                mutual: false,
            },
        ] {
            let got = match_float(&q.concat(), &t.concat(), dim, &opts).expect("match");
            let got: Vec<(usize, usize)> = got.iter().map(|m| (m.query, m.train)).collect();
            assert_eq!(got, oracle(&q, &t, &opts));
            assert!(got.len() >= 60, "{} matches", got.len());
        }
    }

    /// Byte rows' squared distances are the float distances of the same whole numbers, bit
    /// for bit, and an independent sum's, at every length around the sixteen running sums.
    #[test]
    fn byte_distances_are_the_float_distances_of_the_same_whole_numbers() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for dim in [1, 15, 16, 17, 128, 131, 258] {
            for extreme in [false, true] {
                let row = |rng: &mut ChaCha8Rng, v: u8| -> Vec<u8> {
                    (0..dim)
                        .map(|_| if extreme { v } else { rng.random() })
                        .collect()
                };
                let (a, b) = (row(&mut rng, 255), row(&mut rng, 0));
                let oracle: i64 = a
                    .iter()
                    .zip(&b)
                    .map(|(&x, &y)| (x as i64 - y as i64).pow(2))
                    .sum();
                let float = |r: &[u8]| -> Vec<f32> { r.iter().map(|&v| v as f32).collect() };
                assert_eq!(l2_squared_bytes(&a, &b) as i64, oracle, "dim {dim}");
                assert_eq!(
                    l2_squared_bytes(&a, &b) as f32,
                    l2_squared(&float(&a), &float(&b))
                );
            }
        }
    }

    #[test]
    fn hamming_counts_bits_and_binary_matching_finds_flipped_copies() {
        assert_eq!(hamming(&[0xFF; 11], &[0x0F; 11]), 44);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let t: Vec<u8> = (0..64 * 32).map(|_| rng.random()).collect();
        // Each query is a train row read backwards in row order with 10 bits flipped.
        let mut q = vec![];
        for i in (0..64).rev() {
            let mut row = t[i * 32..(i + 1) * 32].to_vec();
            for k in 0..10 {
                row[(k * 7 + i) % 32] ^= 1 << (k % 8);
            }
            q.extend(row);
        }
        let m = match_binary(&q, &t, 32, &MatchOptions::default()).expect("match");
        assert_eq!(m.len(), 64);
        assert!(
            m.iter()
                .all(|m| m.train == 63 - m.query && m.distance <= 10.0)
        );
    }

    #[test]
    fn bad_shapes_and_ratios_are_refused() {
        let o = MatchOptions::default();
        assert_eq!(
            match_float(&[0.0; 5], &[0.0; 4], 2, &o).unwrap_err(),
            MatchError::Ragged {
                which: "query",
                len: 5,
                dim: 2
            }
        );
        let bad = MatchOptions { ratio: 1.5, ..o };
        assert!(match_binary(&[0; 4], &[0; 4], 4, &bad).is_err());
    }
}
