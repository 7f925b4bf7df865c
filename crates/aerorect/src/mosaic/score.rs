//! Each frame's score over a window of the mosaic (the formula is in the module doc of
//! `mosaic`). A cell's score needs the frame pixels of its centre and of its four corners; the
//! window's scorer evaluates each corner once for the four cells that meet there (a little over
//! two frame projections per cell instead of five) and gives [`MosaicPlan::score_at`]'s scores
//! bit for bit, since a corner shared by two cells is the same f64 position for both
//! (m + 0.5 = (m + 1) - 0.5 exactly).

use super::{MosaicPlan, Window};
use rayon::prelude::*;

/// Rows scored by one parallel task; the corner row under a task's last row is evaluated again
/// by the next task.
const ROWS_PER_TASK: usize = 16;

/// A frame pixel that does not exist (beyond the horizon, hidden): NaN, which fails every test
/// of [`MosaicPlan::score_from`] as `None` does.
const NONE: [f64; 2] = [f64::NAN; 2];

impl MosaicPlan {
    /// Frame `k`'s score at mosaic pixel (col, row) (lower is better); `None` where the frame
    /// does not cover it. One cell at a time: the oracle of the window's scorer.
    pub fn score_at(&self, k: usize, col: usize, row: usize) -> Option<f64> {
        let [x, y] = self.frame_cell(k, col, row)?;
        let p = &self.frames[k].plan;
        let centre = p.frame_pixel_of(x, y)?;
        let q = [
            p.frame_pixel_of(x - 0.5, y - 0.5)?,
            p.frame_pixel_of(x + 0.5, y - 0.5)?,
            p.frame_pixel_of(x + 0.5, y + 0.5)?,
            p.frame_pixel_of(x - 0.5, y + 0.5)?,
        ];
        self.score_from(k, centre, q, [col, row])
    }

    /// Mosaic pixel (col, row) on frame `k`'s own grid; `None` off it.
    fn frame_cell(&self, k: usize, col: usize, row: usize) -> Option<[f64; 2]> {
        let s = self.frames[k].plan.grid.size;
        let (pc, pr) = (
            col as i64 - self.offsets[k][0],
            row as i64 - self.offsets[k][1],
        );
        let inside = pc >= 0 && pr >= 0 && pc < s.width as i64 && pr < s.height as i64;
        inside.then_some([pc as f64, pr as f64])
    }

    /// The score of mosaic pixel `cell` from the frame pixels of its centre and its corners
    /// (clockwise from the top left); `None` when the centre is outside the frame or the cell
    /// maps to no area.
    fn score_from(
        &self,
        k: usize,
        centre: [f64; 2],
        q: [[f64; 2]; 4],
        cell: [usize; 2],
    ) -> Option<f64> {
        let f = &self.frames[k];
        let (w, h) = (
            f.plan.camera.size.width as f64,
            f.plan.camera.size.height as f64,
        );
        const EPS: f64 = 1e-6;
        if !(centre[0] >= -0.5 + EPS
            && centre[0] < w - 0.5 - EPS
            && centre[1] >= -0.5 + EPS
            && centre[1] < h - 0.5 - EPS)
        {
            return None;
        }
        let area = 0.5
            * (0..4)
                .map(|i| {
                    let (a, b) = (q[i], q[(i + 1) % 4]);
                    a[0] * b[1] - b[0] * a[1]
                })
                .sum::<f64>()
                .abs();
        if area.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let g = self.grid.centre_of(cell[0] as f64, cell[1] as f64);
        let tan = (g[0] - f.nadir_xy[0]).hypot(g[1] - f.nadir_xy[1]) / f.height_m;
        Some(self.grid.gsd / area.sqrt() * tan.hypot(1.0))
    }

    /// Frame `k`'s scores over `w` (infinity where it does not cover), row-major.
    pub fn scores(&self, k: usize, w: Window) -> Vec<f64> {
        let mut out = vec![f64::INFINITY; w.size.pixels()];
        let (oc, s) = (self.offsets[k][0], self.frames[k].plan.grid.size);
        let clamp = |c: i64| c.clamp(0, w.size.width as i64) as usize;
        let cols = [
            clamp(oc - w.col0 as i64),
            clamp(oc + s.width as i64 - w.col0 as i64),
        ];
        if cols[0] >= cols[1] {
            return out;
        }
        let width = w.size.width;
        out.par_chunks_mut(width * ROWS_PER_TASK)
            .enumerate()
            .for_each(|(t, block)| self.score_rows(k, w, t * ROWS_PER_TASK, cols, block));
        out
    }

    /// Frame `k`'s scores of the window's rows from `r0` (as many as `block` holds), columns
    /// `cols` (window columns on the frame's grid), each corner row evaluated once.
    fn score_rows(&self, k: usize, w: Window, r0: usize, cols: [usize; 2], block: &mut [f64]) {
        let (p, s) = (&self.frames[k].plan, self.frames[k].plan.grid.size);
        let n = cols[1] - cols[0];
        let x0 = (w.col0 + cols[0]) as i64 - self.offsets[k][0];
        let along = |y: f64, half: f64, out: &mut [[f64; 2]]| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = p
                    .frame_pixel_of((x0 + i as i64) as f64 + half, y)
                    .unwrap_or(NONE);
            }
        };
        let (mut top, mut bottom) = (vec![NONE; n + 1], vec![NONE; n + 1]);
        let mut centre = vec![NONE; n];
        let mut top_of: Option<i64> = None;
        for (j, row) in block.chunks_mut(w.size.width).enumerate() {
            let mosaic_row = w.row0 + r0 + j;
            let pr = mosaic_row as i64 - self.offsets[k][1];
            if pr < 0 || pr >= s.height as i64 {
                continue;
            }
            let y = pr as f64;
            if top_of != Some(pr) {
                along(y - 0.5, -0.5, &mut top);
            }
            along(y, 0.0, &mut centre);
            along(y + 0.5, -0.5, &mut bottom);
            for (i, v) in row[cols[0]..cols[1]].iter_mut().enumerate() {
                let q = [top[i], top[i + 1], bottom[i + 1], bottom[i]];
                let cell = [w.col0 + cols[0] + i, mosaic_row];
                if let Some(score) = self.score_from(k, centre[i], q, cell) {
                    *v = score;
                }
            }
            std::mem::swap(&mut top, &mut bottom);
            top_of = Some(pr + 1);
        }
    }

    /// The best frame of each cell of `w` (row-major), `None` where no frame covers it.
    pub fn labels(&self, w: Window) -> Vec<Option<usize>> {
        let cands = self.meeting(w);
        let scores: Vec<Vec<f64>> = cands.iter().map(|&k| self.scores(k, w)).collect();
        best_of(&cands, &scores, w.size.pixels())
    }
}

/// The lowest finite score's frame per cell (the first of equals).
pub(super) fn best_of(cands: &[usize], scores: &[Vec<f64>], n: usize) -> Vec<Option<usize>> {
    (0..n)
        .map(|i| {
            let mut best: Option<(usize, f64)> = None;
            for (j, s) in scores.iter().enumerate() {
                if s[i].is_finite() && best.is_none_or(|b| s[i] < b.1) {
                    best = Some((cands[j], s[i]));
                }
            }
            best.map(|b| b.0)
        })
        .collect()
}
