//! The scans of one query's row of the float distance matrix ([`super::nearest_float`]): its
//! two nearest train rows, and each train row's nearest query so far. Eight train rows at a
//! time with AVX2 ([`super::scan_avx2`]), else the portable passes below, which are its oracle:
//! the same distances bit for bit, the same rows chosen.

/// Lanes of the portable two-smallest search ([`two_smallest`]): independent chains, meant for
/// vector registers (on x86-64 the compiler kept them in memory, updated by masked stores:
/// hence [`super::scan_avx2`]).
const LANES: usize = 16;

/// One query's row of the distance matrix: its squared norm, its products with every train
/// row, the train rows' squared norms, and its index.
pub(super) struct Row<'a> {
    pub(super) qn: f32,
    pub(super) products: &'a [f32],
    pub(super) tn: &'a [f32],
    pub(super) i: usize,
}

impl Row<'_> {
    /// The squared distance to train row `j`: `|q|^2 + |t|^2 - 2 q.t`, at least 0.
    #[inline(always)]
    pub(super) fn distance(&self, j: usize) -> f32 {
        (self.qn + self.tn[j] - 2.0 * self.products[j]).max(0.0)
    }
}

/// The two smallest and their train rows: `((best, row), (second, row))`.
pub(super) type Two = ((f32, usize), (f32, usize));

/// Room for one row's scan: its distances (the portable passes), the columns' next state
/// (AVX2).
pub(super) struct Scratch {
    dist: Vec<f32>,
    next: Columns,
}

impl Scratch {
    /// For rows of `n` train rows.
    pub(super) fn new(n: usize) -> Self {
        Self {
            dist: vec![0.0; n],
            next: Columns::new(n),
        }
    }
}

/// The row's two nearest train rows (as [`two_smallest`] of its distances), each train row's
/// best query updated with the row's ([`Columns::update`]).
pub(super) fn scan_row(row: Row<'_>, columns: &mut Columns, scratch: &mut Scratch) -> Two {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        let next = &mut scratch.next;
        // SAFETY: the CPU has AVX2.
        let (lanes, done) = unsafe { super::scan_avx2::scan(&row, (columns, next)) };
        let mut two = TwoSmallest::default();
        for (d, j) in lanes {
            two.offer(d, j);
        }
        for j in done..row.products.len() {
            let d = row.distance(j);
            two.offer(d, j);
            let closer = d < columns.distance[j];
            next.distance[j] = if closer { d } else { columns.distance[j] };
            next.query[j] = if closer {
                row.i as u32
            } else {
                columns.query[j]
            };
        }
        std::mem::swap(columns, next);
        return two.0;
    }
    let dist = &mut scratch.dist;
    for (j, x) in dist.iter_mut().enumerate() {
        *x = row.distance(j);
    }
    columns.update(dist, row.i);
    two_smallest(dist)
}

/// The two smallest `(value, index)` offered so far, ties to the lower index; only values
/// below infinity count (as in the one-pass scan: `d < best`).
pub(super) struct TwoSmallest(Two);

impl Default for TwoSmallest {
    fn default() -> Self {
        let none = (f32::INFINITY, usize::MAX);
        Self((none, none))
    }
}

impl TwoSmallest {
    pub(super) fn offer(&mut self, d: f32, j: usize) {
        if j == usize::MAX || d.is_nan() || d == f32::INFINITY {
            return;
        }
        let before = |a: (f32, usize), b: (f32, usize)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
        let two = &mut self.0;
        if before((d, j), two.0) {
            two.1 = two.0;
            two.0 = (d, j);
        } else if before((d, j), two.1) {
            two.1 = (d, j);
        }
    }
}

/// The smallest and second-smallest `(value, index)` of `values`, ties to the lower index
/// (what one pass keeping the first strictly smaller value finds); `(inf, usize::MAX)` where
/// there are not enough values below infinity. [`LANES`] independent running pairs, merged
/// at the end: every lane keeps its own two smallest, and the two smallest of all are among
/// them.
pub(super) fn two_smallest(values: &[f32]) -> Two {
    let mut b1 = [f32::INFINITY; LANES];
    let mut b2 = [f32::INFINITY; LANES];
    let mut i1 = [u32::MAX; LANES];
    let mut i2 = [u32::MAX; LANES];
    let chunks = values.chunks_exact(LANES);
    let tail = chunks.remainder();
    for (c, chunk) in chunks.enumerate() {
        let base = (c * LANES) as u32;
        for k in 0..LANES {
            let (d, j) = (chunk[k], base + k as u32);
            let (below1, below2) = (d < b1[k], d < b2[k]);
            i2[k] = if below1 {
                i1[k]
            } else if below2 {
                j
            } else {
                i2[k]
            };
            b2[k] = if below1 {
                b1[k]
            } else if below2 {
                d
            } else {
                b2[k]
            };
            i1[k] = if below1 { j } else { i1[k] };
            b1[k] = if below1 { d } else { b1[k] };
        }
    }
    let mut two = TwoSmallest::default();
    for k in 0..LANES {
        for (d, j) in [(b1[k], i1[k]), (b2[k], i2[k])] {
            if j != u32::MAX {
                two.offer(d, j as usize);
            }
        }
    }
    let tail_start = values.len() - tail.len();
    for (k, &d) in tail.iter().enumerate() {
        two.offer(d, tail_start + k);
    }
    two.0
}

/// Per train row, the best query so far and its distance (`u32::MAX`: none yet), as two
/// arrays so that [`Columns::update`] vectorises.
pub(super) struct Columns {
    pub(super) distance: Vec<f32>,
    pub(super) query: Vec<u32>,
}

impl Columns {
    /// No query yet for any of `n` train rows.
    pub(super) fn new(n: usize) -> Self {
        Self {
            distance: vec![f32::INFINITY; n],
            query: vec![u32::MAX; n],
        }
    }

    /// Query `i`'s distances to every train row: each row keeps the first query strictly
    /// closer than its best so far.
    pub(super) fn update(&mut self, dist: &[f32], i: usize) {
        let i = i as u32;
        for ((d, q), &x) in self.distance.iter_mut().zip(&mut self.query).zip(dist) {
            let closer = x < *d;
            *q = if closer { i } else { *q };
            *d = if closer { x } else { *d };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The one-pass scan [`two_smallest`] replaces: keep the first strictly smaller value.
    fn one_pass(values: &[f32]) -> ((f32, usize), (f32, usize)) {
        let inf = (f32::INFINITY, usize::MAX);
        let (mut best, mut second) = (inf, inf);
        for (j, &d) in values.iter().enumerate() {
            if d < best.0 {
                second = best;
                best = (d, j);
            } else if d < second.0 {
                second = (d, j);
            }
        }
        (best, second)
    }

    /// The lane-wise search finds what one pass finds, ties (values drawn from a few levels)
    /// and infinities included, for lengths below, at and past multiples of the lanes.
    #[test]
    fn two_smallest_equals_one_pass_with_ties() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for len in [0, 1, 2, 15, 16, 17, 31, 33, 100, 257] {
            for levels in [1, 3, 50] {
                let v: Vec<f32> = (0..len)
                    .map(|_| match rng.random_range(0..=levels) {
                        0 => f32::INFINITY,
                        l => l as f32,
                    })
                    .collect();
                let (got, want) = (two_smallest(&v), one_pass(&v));
                assert_eq!(got.0.1, want.0.1, "best of {v:?}");
                assert_eq!(got.1.1, want.1.1, "second of {v:?}");
                assert_eq!(got.0.0.to_bits(), want.0.0.to_bits());
                assert_eq!(got.1.0.to_bits(), want.1.0.to_bits());
            }
        }
    }

    /// Each train row keeps the first query closest to it, ties included.
    #[test]
    fn columns_keep_the_first_closest_query() {
        let rows = [[3.0, 1.0, 2.0], [3.0, 0.5, 2.0], [1.0, 0.5, f32::INFINITY]];
        let mut c = Columns {
            distance: vec![f32::INFINITY; 3],
            query: vec![u32::MAX; 3],
        };
        for (i, r) in rows.iter().enumerate() {
            c.update(r, i);
        }
        assert_eq!(c.query, [2, 1, 0]);
        assert_eq!(c.distance, [1.0, 0.5, 2.0]);
    }

    /// A row's scan (AVX2 where the CPU has it) chooses the portable passes' rows and leaves
    /// the columns as they leave them, bit for bit: ties (products from a few levels),
    /// distances clamped at 0, lengths below, at and past multiples of eight, and queries
    /// after others.
    #[test]
    fn a_rows_scan_equals_the_portable_passes() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for len in [0, 1, 7, 8, 9, 16, 23, 64, 250] {
            let tn: Vec<f32> = (0..len)
                .map(|_| rng.random_range(0..4) as f32 * 0.5)
                .collect();
            let (mut got_c, mut want_c) = (Columns::new(len), Columns::new(len));
            let mut scratch = Scratch::new(len);
            for i in 0..6 {
                let products: Vec<f32> = (0..len)
                    .map(|_| rng.random_range(0..6) as f32 * 0.25)
                    .collect();
                let qn = rng.random_range(0..3) as f32;
                let row = || Row {
                    qn,
                    products: &products,
                    tn: &tn,
                    i,
                };
                let got = scan_row(row(), &mut got_c, &mut scratch);
                let all: Vec<f32> = (0..len).map(|j| row().distance(j)).collect();
                want_c.update(&all, i);
                let want = two_smallest(&all);
                assert_eq!(
                    (got.0.1, got.1.1),
                    (want.0.1, want.1.1),
                    "len {len}, query {i}"
                );
                assert_eq!(got.0.0.to_bits(), want.0.0.to_bits());
                assert_eq!(got_c.query, want_c.query, "len {len}, query {i}");
                let bits = |c: &Columns| c.distance.iter().map(|d| d.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got_c), bits(&want_c));
            }
            assert!(len == 0 || got_c.query.iter().all(|&q| q != u32::MAX));
        }
    }
}
