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

    /// The rows in the 3 x 3 cells around `p`'s, cell by cell.
    fn around(&self, p: [f64; 2]) -> impl Iterator<Item = u32> + '_ {
        let [cx, cy] = self.cell_of(p);
        (cy - 1..=cy + 1)
            .flat_map(move |y| (cx - 1..=cx + 1).map(move |x| (x, y)))
            .filter_map(|(x, y)| self.index(x, y))
            .flat_map(|c| {
                self.rows[self.starts[c]..self.starts[c + 1]]
                    .iter()
                    .copied()
            })
    }
}

/// Per query the best and second-best train row within its window by exact squared L2
/// distance, and per train row the best query whose window holds it (the first of equals).
fn nearest_within(
    query: &[f32],
    train: &[f32],
    dim: usize,
    window: &Window,
) -> (RowBest, ColumnBest) {
    let (nq, nt) = (query.len() / dim, train.len() / dim);
    let mut row = vec![(usize::MAX, f32::INFINITY, f32::INFINITY); nq];
    let mut column = vec![(usize::MAX, f32::INFINITY); nt];
    let Some(grid) = Grid::new(window.train_at, window.radius) else {
        return (row, column);
    };
    let r2 = window.radius * window.radius;
    for (i, at) in window.query_at.iter().enumerate() {
        let Some(p) = at.filter(|p| p[0].is_finite() && p[1].is_finite()) else {
            continue;
        };
        let q = &query[i * dim..(i + 1) * dim];
        let (mut best, mut second) = ((f32::INFINITY, usize::MAX), f32::INFINITY);
        for j in grid.around(p).map(|j| j as usize) {
            let t = window.train_at[j];
            if (t[0] - p[0]).powi(2) + (t[1] - p[1]).powi(2) > r2 {
                continue;
            }
            let d = l2_squared(q, &train[j * dim..(j + 1) * dim]);
            // Candidates come cell by cell, not in row order: equal distances go to the
            // lower row, as in a scan in row order.
            if d < best.0 || (d == best.0 && j < best.1) {
                second = best.0;
                best = (d, j);
            } else if d < second {
                second = d;
            }
            let col = &mut column[j];
            if d < col.1 {
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
