//! Growing a grid of corners from one candidate: its neighbours along its two edge lines give
//! the first cells, then every empty cell next to the grid is predicted (straight-line
//! extrapolation along a row or column, or the fourth corner of a parallelogram) and takes the
//! nearest free candidate within 30 % of the local corner spacing.

use super::saddle::{Candidate, wrap};
use std::collections::HashMap;

/// A corner joins a grid only with at least this fraction of the grid's median contrast.
const MIN_RELATIVE_CONTRAST: f64 = 0.4;

/// Candidates binned in square buckets for radius queries.
pub struct Buckets {
    cell: f64,
    cols: usize,
    rows: usize,
    bins: Vec<Vec<usize>>,
}

impl Buckets {
    pub fn new(cands: &[Candidate], width: usize, height: usize, cell: f64) -> Self {
        let cols = (width as f64 / cell).ceil().max(1.0) as usize;
        let rows = (height as f64 / cell).ceil().max(1.0) as usize;
        let mut bins = vec![Vec::new(); cols * rows];
        for (i, c) in cands.iter().enumerate() {
            let (bx, by) = (
                ((c.p[0] / cell) as usize).min(cols - 1),
                ((c.p[1] / cell) as usize).min(rows - 1),
            );
            bins[by * cols + bx].push(i);
        }
        Self {
            cell,
            cols,
            rows,
            bins,
        }
    }

    /// Indices of the candidates within `radius` of `p` (and possibly a few more).
    fn near(&self, p: [f64; 2], radius: f64) -> impl Iterator<Item = usize> + '_ {
        let lo = |v: f64| ((v - radius) / self.cell).floor().max(0.0) as usize;
        let hi =
            |v: f64, n: usize| (((v + radius) / self.cell).floor().max(0.0) as usize).min(n - 1);
        let (x0, x1) = (lo(p[0]), hi(p[0], self.cols));
        let (y0, y1) = (lo(p[1]), hi(p[1], self.rows));
        (y0..=y1)
            .flat_map(move |by| (x0..=x1).map(move |bx| by * self.cols + bx))
            .flat_map(move |b| self.bins.get(b).into_iter().flatten().copied())
    }
}

/// A grid of candidate indices keyed by (i, j).
#[derive(Debug, Default, Clone)]
pub struct Grid {
    pub cells: HashMap<(i32, i32), usize>,
}

impl Grid {
    /// (i_min, j_min, columns, rows) of the bounding box.
    pub fn bounds(&self) -> (i32, i32, usize, usize) {
        let is = self.cells.keys().map(|k| k.0);
        let js = self.cells.keys().map(|k| k.1);
        let (i0, i1) = (is.clone().min().unwrap_or(0), is.max().unwrap_or(-1));
        let (j0, j1) = (js.clone().min().unwrap_or(0), js.max().unwrap_or(-1));
        (i0, j0, (i1 - i0 + 1) as usize, (j1 - j0 + 1) as usize)
    }

    /// The full `w x h` window (either way round) with the highest total contrast, when the grid
    /// holds one: a grid grown past the board's edge onto a few border junctions loses them here.
    pub fn board_window(&self, cands: &[Candidate], (w, h): (usize, usize)) -> Option<Grid> {
        let (i0, j0, nx, ny) = self.bounds();
        let mut best: Option<(f64, Grid)> = None;
        for (ww, hh) in [(w, h), (h, w)] {
            for di in 0..=nx.saturating_sub(ww) {
                for dj in 0..=ny.saturating_sub(hh) {
                    if ww > nx || hh > ny {
                        continue;
                    }
                    let (a, b) = (i0 + di as i32, j0 + dj as i32);
                    let cells: HashMap<(i32, i32), usize> = self
                        .cells
                        .iter()
                        .filter(|(k, _)| {
                            (a..a + ww as i32).contains(&k.0) && (b..b + hh as i32).contains(&k.1)
                        })
                        .map(|(k, v)| (*k, *v))
                        .collect();
                    if cells.len() != ww * hh {
                        continue;
                    }
                    let score: f64 = cells.values().map(|&c| cands[c].contrast).sum();
                    if best.as_ref().is_none_or(|(s, _)| score > *s) {
                        best = Some((score, Grid { cells }));
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Whether this grid holds most (80 %) of a row or column just outside `window` in corners
    /// of at least half the window's median contrast: a larger board than the one asked for,
    /// rather than a few junctions on the board's border.
    pub fn extends_past(&self, window: &Grid, cands: &[Candidate]) -> bool {
        let (i0, j0, nx, ny) = window.bounds();
        let (i1, j1) = (i0 + nx as i32 - 1, j0 + ny as i32 - 1);
        let mut c: Vec<f64> = window.cells.values().map(|&k| cands[k].contrast).collect();
        c.sort_by(f64::total_cmp);
        let strong = 0.5 * c.get(c.len() / 2).copied().unwrap_or(0.0);
        let count = |keys: &mut dyn Iterator<Item = (i32, i32)>| {
            keys.filter(|k| {
                self.cells
                    .get(k)
                    .is_some_and(|&v| cands[v].contrast >= strong)
            })
            .count()
        };
        let cols_out = [i0 - 1, i1 + 1]
            .iter()
            .any(|&i| 5 * count(&mut (j0..=j1).map(|j| (i, j))) >= 4 * ny);
        let rows_out = [j0 - 1, j1 + 1]
            .iter()
            .any(|&j| 5 * count(&mut (i0..=i1).map(|i| (i, j))) >= 4 * nx);
        cols_out || rows_out
    }

    /// Whether every cell of the bounding box holds a corner.
    pub fn is_full(&self) -> bool {
        let (_, _, n, m) = self.bounds();
        n * m == self.cells.len()
    }
}

/// The grid grown from candidate `seed`; `None` when it lacks a neighbour along both lines.
pub fn grow(cands: &[Candidate], buckets: &Buckets, seed: usize) -> Option<Grid> {
    let s = cands[seed];
    let mut grid = Grid::default();
    grid.cells.insert((0, 0), seed);
    let mut axis_found = [false; 2];
    for (axis, &angle) in s.lines.iter().enumerate() {
        for (sign, forward) in [(1i32, 0.0), (-1, std::f64::consts::PI)] {
            let Some(n) = neighbour_along(cands, buckets, seed, angle + forward) else {
                continue;
            };
            if grid.cells.values().any(|&v| v == n) {
                continue;
            }
            let key = if axis == 0 { (sign, 0) } else { (0, sign) };
            grid.cells.insert(key, n);
            axis_found[axis] = true;
        }
    }
    if !(axis_found[0] && axis_found[1]) {
        return None;
    }
    while extend(&mut grid, cands, buckets) {}
    Some(grid)
}

/// The nearest candidate in direction `angle` (within 15 degrees) from `from`, one of whose own
/// lines runs along the step (within 20 degrees).
fn neighbour_along(
    cands: &[Candidate],
    buckets: &Buckets,
    from: usize,
    angle: f64,
) -> Option<usize> {
    let p = cands[from].p;
    let mut best: Option<(f64, usize)> = None;
    let radius = buckets.cell * 8.0;
    for i in buckets.near(p, radius) {
        let q = cands[i].p;
        let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
        let d = dx.hypot(dy);
        if i == from || d < 3.0 || d > radius {
            continue;
        }
        let a = dy.atan2(dx);
        if wrap(a - angle).abs() > 15f64.to_radians() {
            continue;
        }
        let along = cands[i]
            .lines
            .iter()
            .any(|&l| wrap(2.0 * (l - a)).abs() < 40f64.to_radians());
        if along && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, i));
        }
    }
    best.map(|b| b.1)
}

/// Adds every predictable empty neighbour cell that has a candidate near its prediction.
fn extend(grid: &mut Grid, cands: &[Candidate], buckets: &Buckets) -> bool {
    let mut frontier: Vec<(i32, i32)> = grid
        .cells
        .keys()
        .flat_map(|&(i, j)| [(i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)])
        .filter(|k| !grid.cells.contains_key(k))
        .collect();
    frontier.sort_unstable();
    frontier.dedup();
    let mut contrasts: Vec<f64> = grid.cells.values().map(|&c| cands[c].contrast).collect();
    contrasts.sort_by(f64::total_cmp);
    let min_contrast = MIN_RELATIVE_CONTRAST * contrasts[contrasts.len() / 2];
    let mut added = false;
    for key in frontier {
        let Some((pred, spacing)) = predict(grid, cands, key) else {
            continue;
        };
        let radius = 0.3 * spacing;
        let hit = buckets
            .near(pred, radius)
            .filter(|&i| cands[i].contrast >= min_contrast)
            .filter(|i| !grid.cells.values().any(|v| v == i))
            .map(|i| {
                let q = cands[i].p;
                ((q[0] - pred[0]).hypot(q[1] - pred[1]), i)
            })
            .filter(|(d, _)| *d <= radius)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, i)) = hit {
            grid.cells.insert(key, i);
            added = true;
        }
    }
    added
}

/// The mean of every available prediction of cell `key` and the local spacing.
fn predict(grid: &Grid, cands: &[Candidate], (i, j): (i32, i32)) -> Option<([f64; 2], f64)> {
    let at = |k: (i32, i32)| grid.cells.get(&k).map(|&c| cands[c].p);
    let mut sum = [0.0, 0.0];
    let mut n = 0.0;
    let mut spacing = f64::MAX;
    let mut add = |p: [f64; 2], near: [f64; 2]| {
        sum[0] += p[0];
        sum[1] += p[1];
        n += 1.0;
        spacing = spacing.min((p[0] - near[0]).hypot(p[1] - near[1]));
    };
    for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
        if let (Some(a), Some(b)) = (at((i - di, j - dj)), at((i - 2 * di, j - 2 * dj))) {
            add([2.0 * a[0] - b[0], 2.0 * a[1] - b[1]], a);
        }
    }
    for (di, dj) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
        let (a, b, c) = (at((i - di, j)), at((i, j - dj)), at((i - di, j - dj)));
        if let (Some(a), Some(b), Some(c)) = (a, b, c) {
            add([a[0] + b[0] - c[0], a[1] + b[1] - c[1]], a);
        }
    }
    (n > 0.0).then(|| ([sum[0] / n, sum[1] / n], spacing))
}
