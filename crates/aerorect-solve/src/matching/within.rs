//! Guided matching: each query is compared only with the train rows within a radius of where
//! it is predicted to lie in the train frame (a pair's recorded orientation over the ground),
//! instead of with all of them. With attitudes known to a degree, the window is a few percent
//! of a frame: a fifth of the distances or less, each computed exactly (no matrix product),
//! and the ratio test and the mutual check are taken among the candidates the window allows.

use super::*;

/// Where each query may find its match: the train rows within `radius` of its predicted
/// position (all positions in the train frame's pixels).
#[derive(Debug, Clone, Copy)]
pub struct Window<'a> {
    /// Each query row's predicted position (`None`, or a non-finite one: nowhere).
    pub query_at: &'a [Option<[f64; 2]>],
    /// Each train row's position (a non-finite one is never a candidate).
    pub train_at: &'a [[f64; 2]],
    pub radius: f64,
}

/// The most cells per side of the grid over the train rows: a radius far below their spread
/// gets cells wider than itself, never a grid too large to allocate.
const MAX_GRID_SIDE: f64 = 1024.0;

/// The train rows bucketed by square cells at least `radius` wide, so that a circle of that
/// radius lies within the 3 x 3 cells around its centre's.
struct Grid {
    origin: [f64; 2],
    cell: f64,
    side: [usize; 2],
    /// Cell `c`'s rows are `rows[starts[c]..starts[c + 1]]`, ascending.
    starts: Vec<usize>,
    rows: Vec<u32>,
}

impl Grid {
    /// None when no train row has a finite position.
    fn new(at: &[[f64; 2]], radius: f64) -> Option<Self> {
        let finite = |p: &&[f64; 2]| p[0].is_finite() && p[1].is_finite();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in at.iter().filter(finite) {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        if lo[0] > hi[0] {
            return None;
        }
        let spread = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let cell = radius.max(spread / MAX_GRID_SIDE);
        let side = [0, 1].map(|a| ((hi[a] - lo[a]) / cell) as usize + 1);
        let mut grid = Grid {
            origin: lo,
            cell,
            side,
            starts: vec![0; side[0] * side[1] + 1],
            rows: Vec::new(),
        };
        let cells: Vec<Option<usize>> = at
            .iter()
            .map(|p| {
                let [x, y] = finite(&p).then(|| grid.cell_of(*p))?;
                grid.index(x, y)
            })
            .collect();
        for c in cells.iter().flatten() {
            grid.starts[c + 1] += 1;
        }
        for c in 0..grid.side[0] * grid.side[1] {
            grid.starts[c + 1] += grid.starts[c];
        }
        let mut next = grid.starts.clone();
        grid.rows = vec![0; grid.starts[grid.side[0] * grid.side[1]]];
        for (j, c) in cells.iter().enumerate() {
            if let Some(c) = *c {
                grid.rows[next[c]] = j as u32;
                next[c] += 1;
            }
        }
        Some(grid)
    }

    /// The cell of `p`, clamped to one cell beyond the grid's border (a position far outside,
    /// even 1e300, is as far as that from every row).
    fn cell_of(&self, p: [f64; 2]) -> [i64; 2] {
        [0, 1].map(|a| {
            let c = ((p[a] - self.origin[a]) / self.cell).floor();
            c.clamp(-2.0, self.side[a] as f64 + 1.0) as i64
        })
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let inside = |v: i64, n: usize| v >= 0 && (v as usize) < n;
        (inside(x, self.side[0]) && inside(y, self.side[1]))
            .then(|| y as usize * self.side[0] + x as usize)
    }

    /// The rows in the 3 x 3 cells around `p`'s as ranges of positions in [`Grid::rows`]: one
    /// per row of cells, the (up to) three cells of a row being adjacent there.
    fn around(&self, p: [f64; 2]) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let [cx, cy] = self.cell_of(p);
        let (x0, x1) = ((cx - 1).max(0), (cx + 1).min(self.side[0] as i64 - 1));
        (cy - 1..=cy + 1).filter_map(move |y| {
            let (first, last) = (self.index(x0, y)?, self.index(x1, y)?);
            Some(self.starts[first]..self.starts[last + 1])
        })
    }

    /// The order in which to take the queries: cell by cell (ascending row within a cell), so
    /// that consecutive queries compare with the same train rows while they are in cache.
    /// Queries predicted nowhere are left out.
    fn query_order(&self, query_at: &[Option<[f64; 2]>]) -> Vec<u32> {
        let mut order: Vec<(i64, i64, u32)> = query_at
            .iter()
            .enumerate()
            .filter_map(|(i, at)| {
                let p = at.filter(|p| p[0].is_finite() && p[1].is_finite())?;
                let [x, y] = self.cell_of(p);
                Some((y, x, i as u32))
            })
            .collect();
        order.sort_unstable();
        order.into_iter().map(|(_, _, i)| i).collect()
    }
}

/// A descriptor value guided matching compares by squared Euclidean distance: `f32`, or `u8`
/// for descriptors held as bytes ([`bytes_of_whole`]).
pub trait Element: Copy + Default {
    fn l2_squared(a: &[Self], b: &[Self]) -> f32;
}

impl Element for f32 {
    fn l2_squared(a: &[f32], b: &[f32]) -> f32 {
        l2_squared(a, b)
    }
}

/// Exact up to 258 values a row (a squared distance below 2^24); longer rows' distances are
/// rounded to `f32`, which keeps their order but may make near ones equal.
impl Element for u8 {
    fn l2_squared(a: &[u8], b: &[u8]) -> f32 {
        l2_squared_bytes(a, b) as f32
    }
}

/// Per query the best and second-best train row within its window by exact squared L2
/// distance, and per train row the best query whose window holds it (the first of equals).
/// The train rows are copied in the grid's cell order ([`Grid::rows`]) and the queries taken
/// cell by cell ([`Grid::query_order`]), so that the rows a run of queries compares with stay
/// in cache; the result does not depend on either order.
fn nearest_within<T: Element>(
    query: &[T],
    train: &[T],
    dim: usize,
    window: &Window,
) -> (RowBest, ColumnBest) {
    let (nq, nt) = (query.len() / dim, train.len() / dim);
    let Some(grid) = Grid::new(window.train_at, window.radius) else {
        return (
            vec![(usize::MAX, f32::INFINITY, f32::INFINITY); nq],
            vec![(usize::MAX, f32::INFINITY); nt],
        );
    };
    let mut packed = vec![T::default(); grid.rows.len() * dim];
    for (&j, out) in grid.rows.iter().zip(packed.chunks_exact_mut(dim)) {
        out.copy_from_slice(&train[j as usize * dim..(j as usize + 1) * dim]);
    }
    search(&grid, window, (nq, nt), |i, k| {
        T::l2_squared(
            &query[i * dim..(i + 1) * dim],
            &packed[k * dim..(k + 1) * dim],
        )
    })
}

/// [`nearest_within`]'s search, `distance(i, k)` being query `i`'s squared distance to the
/// train row at position `k` of [`Grid::rows`].
fn search(
    grid: &Grid,
    window: &Window,
    (nq, nt): (usize, usize),
    distance: impl Fn(usize, usize) -> f32,
) -> (RowBest, ColumnBest) {
    let mut row = vec![(usize::MAX, f32::INFINITY, f32::INFINITY); nq];
    let mut column = vec![(usize::MAX, f32::INFINITY); nt];
    let at: Vec<[f64; 2]> = grid
        .rows
        .iter()
        .map(|&j| window.train_at[j as usize])
        .collect();
    let r2 = window.radius * window.radius;
    let mut near: Vec<u32> = Vec::new();
    for i in grid
        .query_order(window.query_at)
        .into_iter()
        .map(|i| i as usize)
    {
        let Some(p) = window.query_at[i] else {
            continue;
        };
        // The candidates within the radius, gathered without a branch per row (a row inside
        // or not is a coin toss to the branch predictor).
        near.clear();
        for cells in grid.around(p) {
            let start = near.len();
            near.resize(start + cells.len(), 0);
            let mut n = start;
            for k in cells {
                let t = at[k];
                near[n] = k as u32;
                n += usize::from((t[0] - p[0]).powi(2) + (t[1] - p[1]).powi(2) <= r2);
            }
            near.truncate(n);
        }
        let (mut best, mut second) = ((f32::INFINITY, usize::MAX), f32::INFINITY);
        for k in near.iter().map(|&k| k as usize) {
            let (d, j) = (distance(i, k), grid.rows[k] as usize);
            // Candidates come cell by cell, not in row order: equal distances go to the
            // lower row, as in a scan in row order (which takes only distances below
            // infinity).
            if d < best.0 || (d == best.0 && j < best.1 && best.1 != usize::MAX) {
                second = best.0;
                best = (d, j);
            } else if d < second {
                second = d;
            }
            // Queries come cell by cell too: equal distances go to the lower query (a row
            // that has none yet takes only a distance below infinity, as in a scan in order).
            let col = &mut column[j];
            if d < col.1 || (d == col.1 && i < col.0 && col.0 != usize::MAX) {
                *col = (i, d);
            }
        }
        row[i] = (best.1, best.0, second);
    }
    (row, column)
}

/// Matches float descriptors (rows of `dim` values) of `query` against `train` by Euclidean
/// distance, each query only against the train rows its `window` allows (see [`Window`]).
pub fn match_float_within(
    query: &[f32],
    train: &[f32],
    dim: usize,
    window: &Window,
    opts: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    match_within(query, train, dim, window, opts)
}

/// [`match_float_within`] for descriptors held as bytes ([`bytes_of_whole`]): the same
/// matches at the same distances as their float values give (rows of up to 258 values),
/// comparing a quarter of the memory per row, twice the values per instruction.
pub fn match_bytes_within(
    query: &[u8],
    train: &[u8],
    dim: usize,
    window: &Window,
    opts: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    match_within(query, train, dim, window, opts)
}

/// Float descriptors as bytes when every value is a whole number in 0..=255 (SIFT's are:
/// OpenCV rounds and saturates them to bytes), else `None`.
pub fn bytes_of_whole(values: &[f32]) -> Option<Vec<u8>> {
    // Saturating: a negative, fractional, too large or NaN value does not come back.
    let bytes: Vec<u8> = values.iter().map(|&x| x as u8).collect();
    let whole = (bytes.iter().zip(values)).fold(true, |all, (&b, &x)| all & (f32::from(b) == x));
    whole.then_some(bytes)
}

fn match_within<T: Element>(
    query: &[T],
    train: &[T],
    dim: usize,
    window: &Window,
    opts: &MatchOptions,
) -> Result<Vec<Match>, MatchError> {
    opts.validate()?;
    let nq = counted_rows("query", query.len(), dim)?;
    let nt = counted_rows("train", train.len(), dim)?;
    for (which, positions, rows) in [
        ("query", window.query_at.len(), nq),
        ("train", window.train_at.len(), nt),
    ] {
        if positions != rows {
            return Err(MatchError::Positions {
                which,
                positions,
                rows,
            });
        }
    }
    if !(window.radius > 0.0 && window.radius.is_finite()) {
        return Err(MatchError::Radius {
            radius: window.radius,
        });
    }
    let (row, column) = nearest_within(query, train, dim, window);
    Ok(select(&row, &column, opts, true))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The slow oracle: per query the train rows within the radius of its predicted position,
    /// per train row the queries whose window holds it.
    fn oracle(
        q: &[Vec<f32>],
        t: &[Vec<f32>],
        w: &Window,
        opts: &MatchOptions,
    ) -> Vec<(usize, usize)> {
        super::super::tests::oracle_where(q, t, opts, |i, j| {
            w.query_at[i].is_some_and(|p| {
                let t = w.train_at[j];
                (t[0] - p[0]).hypot(t[1] - p[1]) <= w.radius
            })
        })
    }

    /// Train rows scattered over a 300 x 200 frame; queries are noisy copies of some of them
    /// predicted within a few pixels, copies predicted far from their original (which the
    /// window must keep apart), unrelated rows and rows predicted nowhere.
    #[test]
    fn windowed_matches_equal_the_sorted_distance_oracle() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let dim = 24;
        let t: Vec<Vec<f32>> = (0..300)
            .map(|_| (0..dim).map(|_| rng.random::<f32>()).collect())
            .collect();
        let train_at: Vec<[f64; 2]> = (0..300)
            .map(|_| [rng.random_range(0.0..300.0), rng.random_range(0.0..200.0)])
            .collect();
        let mut q = vec![];
        let mut query_at = vec![];
        for i in 0..240 {
            let near = |rng: &mut ChaCha8Rng, p: [f64; 2], by: f64| {
                [0, 1].map(|a| p[a] + rng.random_range(-by..by))
            };
            let (row, at): (Vec<f32>, _) = match i % 4 {
                0 => ((0..dim).map(|_| rng.random::<f32>()).collect(), None),
                1 => (t[i].clone(), Some([train_at[i][0] + 150.0, train_at[i][1]])),
                _ => (t[i].clone(), Some(near(&mut rng, train_at[i], 8.0))),
            };
            q.push(
                row.iter()
                    .map(|v| v + 0.05 * rng.random::<f32>())
                    .collect::<Vec<f32>>(),
            );
            query_at.push(at);
        }
        let w = Window {
            query_at: &query_at,
            train_at: &train_at,
            radius: 25.0,
        };
        for opts in [
            MatchOptions::default(),
            MatchOptions {
                ratio: 0.95,
                mutual: false,
            },
        ] {
            let got = match_float_within(&q.concat(), &t.concat(), dim, &w, &opts).expect("match");
            let got: Vec<(usize, usize)> = got.iter().map(|m| (m.query, m.train)).collect();
            assert_eq!(got, oracle(&q, &t, &w, &opts));
            // Copies predicted near their original match it; none predicted far does.
            let (near, far): (Vec<_>, Vec<_>) = got.iter().partition(|m| m.0 % 4 >= 2);
            assert!(near.iter().all(|&(i, j)| i == j), "{near:?}");
            assert!(far.iter().all(|&(i, j)| i != j), "{far:?}");
            assert!(near.len() >= 100, "{} matches", near.len());
        }
    }

    /// SIFT-like whole-number descriptors, with repeated train rows and repeated queries so
    /// that equal distances decide: the cell-by-cell search must give what the oracle's scan
    /// in row order gives, as bytes and as floats, at the same distances.
    #[test]
    fn whole_number_descriptors_with_equal_distances_match_as_the_oracle_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        // Not a multiple of the byte distance's sixteen running sums.
        let dim = 37;
        let whole = |rng: &mut ChaCha8Rng| -> Vec<f32> {
            (0..dim).map(|_| rng.random_range(0..=255) as f32).collect()
        };
        let mut t: Vec<Vec<f32>> = (0..200).map(|_| whole(&mut rng)).collect();
        for j in (0..200).step_by(10) {
            t[j + 1] = t[j].clone();
        }
        let train_at: Vec<[f64; 2]> = (0..200)
            .map(|_| [rng.random_range(0.0..200.0), rng.random_range(0.0..150.0)])
            .collect();
        let (mut q, mut query_at) = (vec![], vec![]);
        for i in 0..180 {
            q.push(match i % 3 {
                0 => whole(&mut rng),
                _ => (t[i].iter())
                    .map(|v| (v + rng.random_range(-3..=3) as f32).clamp(0.0, 255.0))
                    .collect(),
            });
            query_at.push(Some(train_at[i].map(|v| v + rng.random_range(-5.0..5.0))));
        }
        // Repeated queries predicted up and to the left, in an earlier cell of the search,
        // with the same train rows in their windows: the lower query must still win.
        for i in (0..180).step_by(9) {
            q[i + 1] = q[i].clone();
            query_at[i + 1] = query_at[i].map(|p| p.map(|v| v - 12.0));
        }
        let w = Window {
            query_at: &query_at,
            train_at: &train_at,
            radius: 30.0,
        };
        let bytes = |rows: &[Vec<f32>]| bytes_of_whole(&rows.concat()).expect("whole numbers");
        let (qb, tb) = (bytes(&q), bytes(&t));
        for (ratio, mutual) in [(1.0, true), (1.0, false), (0.9, true)] {
            let opts = MatchOptions { ratio, mutual };
            let got = match_bytes_within(&qb, &tb, dim, &w, &opts).expect("bytes");
            let pairs: Vec<(usize, usize)> = got.iter().map(|m| (m.query, m.train)).collect();
            assert_eq!(
                pairs,
                oracle(&q, &t, &w, &opts),
                "ratio {ratio}, mutual {mutual}"
            );
            assert!(got.len() >= 60, "{} matches", got.len());
            let floats = match_float_within(&q.concat(), &t.concat(), dim, &w, &opts);
            assert_eq!(
                got,
                floats.expect("floats"),
                "ratio {ratio}, mutual {mutual}"
            );
        }
    }

    #[test]
    fn only_whole_numbers_in_byte_range_become_bytes() {
        let whole = [0.0, 1.0, 254.0, 255.0, -0.0];
        assert_eq!(bytes_of_whole(&whole), Some(vec![0, 1, 254, 255, 0]));
        for bad in [0.5, -1.0, 256.0, 255.5, f32::NAN, f32::INFINITY, 1e9] {
            assert_eq!(bytes_of_whole(&[3.0, bad]), None, "{bad}");
        }
    }

    /// With the whole frame in every window, guided matching is brute-force matching.
    #[test]
    fn a_window_over_everything_matches_as_brute_force_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let dim = 16;
        let t: Vec<f32> = (0..100 * dim).map(|_| rng.random::<f32>()).collect();
        let q: Vec<f32> = t.iter().map(|v| v + 0.03 * rng.random::<f32>()).collect();
        let train_at: Vec<[f64; 2]> = (0..100).map(|k| [k as f64, 0.0]).collect();
        let query_at = vec![Some([50.0, 0.0]); 100];
        let w = Window {
            query_at: &query_at,
            train_at: &train_at,
            radius: 1e3,
        };
        let opts = MatchOptions::default();
        let got = match_float_within(&q, &t, dim, &w, &opts).expect("guided");
        assert_eq!(got, match_float(&q, &t, dim, &opts).expect("brute force"));
        assert_eq!(got.len(), 100);
        // Distances beyond f32's range (infinite) are no one's best, as in brute force.
        let huge: Vec<f32> = (0..2 * dim)
            .map(|k| if k < dim { 1e20 } else { -1e20 })
            .collect();
        for mutual in [true, false] {
            let w2 = Window {
                train_at: &train_at[..1],
                query_at: &query_at[..1],
                ..w
            };
            let two = MatchOptions { ratio: 1.0, mutual };
            let (q1, t1) = (&huge[..dim], &huge[dim..]);
            let brute = match_float(q1, t1, dim, &two).expect("brute force");
            assert_eq!(
                match_float_within(q1, t1, dim, &w2, &two).expect("guided"),
                brute
            );
            assert!(brute.is_empty());
        }
        // Predicted far beyond every row (a ray near the horizon): no candidate, no match.
        let far = vec![Some([1e300, -1e300]); 100];
        let w = Window {
            query_at: &far,
            ..w
        };
        assert!(
            match_float_within(&q, &t, dim, &w, &opts)
                .expect("far")
                .is_empty()
        );
    }

    #[test]
    fn windows_that_do_not_fit_the_rows_are_refused() {
        let at = [[0.0; 2]; 2];
        let o = MatchOptions::default();
        let w = Window {
            query_at: &[None],
            train_at: &at,
            radius: 5.0,
        };
        assert_eq!(
            match_float_within(&[0.0; 4], &[0.0; 4], 2, &w, &o).unwrap_err(),
            MatchError::Positions {
                which: "query",
                positions: 1,
                rows: 2
            }
        );
        let w = Window {
            query_at: &[None, None],
            radius: f64::NAN,
            ..w
        };
        assert!(matches!(
            match_float_within(&[0.0; 4], &[0.0; 4], 2, &w, &o),
            Err(MatchError::Radius { .. })
        ));
    }
}
