//! Each frame's score over a window of the mosaic (the formula is in the module doc of
//! `mosaic`).
//!
//! The score changes slowly across a frame, so it is evaluated exactly only on a lattice:
//! nodes every [`SCORE_LATTICE`] cells of the frame's own grid (and at its last row and
//! column). A block of cells between four nodes takes the bilinear blend of their scores when
//! every node's centre lies at least [`LATTICE_MARGIN_PX`] inside the frame, so the whole
//! block is seen; a block whose four nodes all lie that far beyond one edge of the frame is not
//! scored. Other blocks (along the frame's edges) and blocks where the frame's map leaves out
//! ground hidden from the camera are scored cell by cell ([`MosaicPlan::score_at`]), so which
//! cells a frame covers is decided per cell. The lattice belongs to the frame's grid, so a
//! cell's score is the same whichever window asks for it, and tiles agree with the whole
//! mosaic.
//!
//! On snowpeak's 440-Mpx mosaic, scoring each cell exactly (two to five projections through
//! the camera and the terrain per frame and cell) took about half the mosaic's CPU time.

use super::labels::{BoxScores, CellBox, NO_FRAME, best_of, box_where};
use super::{MosaicPlan, Window};
use rayon::prelude::*;

/// Spacing (cells of a frame's grid) of the nodes where scores are evaluated exactly.
pub const SCORE_LATTICE: usize = 8;

/// How far inside the frame (frame pixels) a block's four nodes must lie for its cells to
/// count as covered without a test each (or beyond one edge, for none to be): meant to be far
/// more than a block's frame positions depart from the bilinear blend of its corners' over 8
/// cells of a survey frame. The tests find coverage equal to the exact rule's, cell for cell,
/// on frames tilted 20 degrees.
pub const LATTICE_MARGIN_PX: f64 = 2.0;

/// A cell evaluated exactly: the frame pixel of its centre (`None` beyond the horizon or
/// hidden) and its score (`None` where the frame does not cover it).
#[derive(Debug, Clone, Copy)]
struct Node {
    centre: Option<[f64; 2]>,
    score: Option<f64>,
}

/// How a block's cells are scored.
enum Block {
    /// Bilinear between the nodes' scores: the block is well inside the frame.
    Blend([f64; 4]),
    /// Not at all: the block lies beyond one edge of the frame.
    Outside,
    /// Each cell exactly.
    Cells,
}

impl MosaicPlan {
    /// Frame `k`'s exact score at mosaic pixel (col, row) (lower is better); `None` where the
    /// frame does not cover it. Five projections: the oracle of the lattice's nodes.
    pub fn score_at(&self, k: usize, col: usize, row: usize) -> Option<f64> {
        let [pc, pr] = self.frame_cell(k, col, row)?;
        self.exact(k, pc, pr).score
    }

    /// Frame `k`'s score at mosaic pixel (col, row) by the lattice rule of the module doc, one
    /// cell at a time: the oracle of [`Self::scores`].
    pub fn lattice_score_at(&self, k: usize, col: usize, row: usize) -> Option<f64> {
        let [pc, pr] = self.frame_cell(k, col, row)?;
        let s = self.frames[k].plan.grid.size;
        let ((c0, c1, tx), (r0, r1, ty)) = (span(pc, s.width), span(pr, s.height));
        let nodes = [
            self.exact(k, c0, r0),
            self.exact(k, c1, r0),
            self.exact(k, c0, r1),
            self.exact(k, c1, r1),
        ];
        match self.block(k, [c0, c1], [r0, r1], nodes) {
            Block::Blend(v) => Some(blend(v, tx, ty)),
            Block::Outside => None,
            Block::Cells => self.exact(k, pc, pr).score,
        }
    }

    /// Mosaic pixel (col, row) on frame `k`'s own grid; `None` off it.
    fn frame_cell(&self, k: usize, col: usize, row: usize) -> Option<[usize; 2]> {
        let s = self.frames[k].plan.grid.size;
        let (pc, pr) = (
            col as i64 - self.offsets[k][0],
            row as i64 - self.offsets[k][1],
        );
        let inside = pc >= 0 && pr >= 0 && pc < s.width as i64 && pr < s.height as i64;
        inside.then_some([pc as usize, pr as usize])
    }

    /// Frame `k`'s exact score at cell (pc, pr) of its own grid, from the frame pixels of the
    /// cell's centre and four corners (only the centre's where it is outside the frame).
    fn exact(&self, k: usize, pc: usize, pr: usize) -> Node {
        let p = &self.frames[k].plan;
        let (x, y) = (pc as f64, pr as f64);
        let centre = p.frame_pixel_of(x, y);
        let score = centre.filter(|c| self.in_frame(k, *c)).and_then(|_| {
            let q = [
                p.frame_pixel_of(x - 0.5, y - 0.5)?,
                p.frame_pixel_of(x + 0.5, y - 0.5)?,
                p.frame_pixel_of(x + 0.5, y + 0.5)?,
                p.frame_pixel_of(x - 0.5, y + 0.5)?,
            ];
            let cell = [
                (pc as i64 + self.offsets[k][0]) as f64,
                (pr as i64 + self.offsets[k][1]) as f64,
            ];
            self.score_from(k, q, cell)
        });
        Node { centre, score }
    }

    /// Whether frame pixel `c` is inside frame `k` (its pixels' outer edges).
    fn in_frame(&self, k: usize, c: [f64; 2]) -> bool {
        let size = self.frames[k].plan.camera.size;
        let (w, h) = (size.width as f64, size.height as f64);
        const EPS: f64 = 1e-6;
        c[0] >= -0.5 + EPS && c[0] < w - 0.5 - EPS && c[1] >= -0.5 + EPS && c[1] < h - 0.5 - EPS
    }

    /// The score of mosaic pixel `cell` from the frame pixels of its corners (clockwise from
    /// the top left); `None` when the cell maps to no area.
    fn score_from(&self, k: usize, q: [[f64; 2]; 4], cell: [f64; 2]) -> Option<f64> {
        let f = &self.frames[k];
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
        let g = self.grid.centre_of(cell[0], cell[1]);
        let (dx, dy) = (g[0] - f.nadir_xy[0], g[1] - f.nadir_xy[1]);
        // 1 / cos(theta) = sqrt(1 + tan^2), tan = horizontal distance / height.
        let tan2 = (dx * dx + dy * dy) / (f.height_m * f.height_m);
        Some(self.grid.gsd / area.sqrt() * (1.0 + tan2).sqrt())
    }

    /// How the block between node lines `cols` and `rows` is scored from its four nodes (top
    /// left, top right, bottom left, bottom right). Blended when all four are scored, each
    /// centre lies the margin inside the frame and no ground its cells or their corners look up
    /// is hidden from the camera; outside when all four centres lie the margin beyond one edge.
    fn block(&self, k: usize, cols: [usize; 2], rows: [usize; 2], nodes: [Node; 4]) -> Block {
        let plan = &self.frames[k].plan;
        let [Some(tl), Some(tr), Some(bl), Some(br)] = nodes.map(|n| n.centre) else {
            return Block::Cells;
        };
        let c = [tl, tr, bl, br];
        let size = plan.camera.size;
        let (w, h, m) = (
            size.width as f64 - 0.5,
            size.height as f64 - 0.5,
            LATTICE_MARGIN_PX,
        );
        let beyond = [
            c.iter().all(|p| p[0] <= -0.5 - m),
            c.iter().all(|p| p[0] >= w + m),
            c.iter().all(|p| p[1] <= -0.5 - m),
            c.iter().all(|p| p[1] >= h + m),
        ];
        if beyond.contains(&true) {
            return Block::Outside;
        }
        let inside = c
            .iter()
            .all(|p| p[0] >= m - 0.5 && p[0] <= w - m && p[1] >= m - 0.5 && p[1] <= h - m);
        // A corner half a cell up and left reads the cell before (see `Visible`).
        let (c0, r0) = (cols[0].saturating_sub(1), rows[0].saturating_sub(1));
        if !inside || plan.hides_any([c0, cols[1]], [r0, rows[1]]) {
            return Block::Cells;
        }
        match nodes.map(|n| n.score) {
            [Some(a), Some(b), Some(c), Some(d)] => Block::Blend([a, b, c, d]),
            _ => Block::Cells,
        }
    }

    /// Frame `k`'s scores over `w` (infinity where it does not cover), row-major: the lattice
    /// rule, each node evaluated once ([`Self::scores_in`] spread over the window).
    pub fn scores(&self, k: usize, w: Window) -> Vec<f64> {
        let mut out = vec![f64::INFINITY; w.size.pixels()];
        if let Some(s) = self.scores_in(k, w) {
            for (at, row) in s.rows_in(w.size.width) {
                out[at..at + row.len()].copy_from_slice(row);
            }
        }
        out
    }

    /// Frame `k`'s scores over the cells of `w` its grid meets, trimmed to the blocks of its
    /// lattice that are not wholly outside it (`None` where none is): a window meets dozens of
    /// a large flight's frames, each over a small part of it, and a tilted frame's grid box
    /// holds much that it does not see (on snowpeak, 42 % of the frames a tile meets see none
    /// of it, and the untrimmed boxes held 1.6 times the windows' cells).
    pub(super) fn scores_in(&self, k: usize, w: Window) -> Option<BoxScores> {
        let (off, s) = (self.offsets[k], self.frames[k].plan.grid.size);
        // The frame-grid cells inside the window: [lo, hi) per axis.
        let range = |w0: usize, n: usize, o: i64, len: usize| {
            let lo = (w0 as i64 - o).clamp(0, len as i64) as usize;
            let hi = ((w0 + n) as i64 - o).clamp(0, len as i64) as usize;
            (lo, hi)
        };
        let cols = range(w.col0, w.size.width, off[0], s.width);
        let rows = range(w.row0, w.size.height, off[1], s.height);
        if cols.0 >= cols.1 || rows.0 >= rows.1 {
            return None;
        }
        let (ncols, nrows) = (node_lines(cols, s.width), node_lines(rows, s.height));
        let nodes: Vec<Node> = nrows
            .par_iter()
            .flat_map_iter(|&r| ncols.iter().map(move |&c| self.exact(k, c, r)))
            .collect();
        let rules = self.block_rules(k, &nodes, (&ncols, &nrows));
        let nb = ncols.len() - 1;
        let seen = box_where(&rules, nb, |q| !matches!(q, Block::Outside))?;
        let (bc, br) = ((seen.c0, seen.c1), (seen.r0, seen.r1));
        // The cells of the blocks seen: [lo, hi) per axis, within the window's.
        let trim = |(lo, hi): (usize, usize), lines: &[usize], (b0, b1): (usize, usize)| {
            (lines[b0].max(lo), (lines[b1 - 1] + SCORE_LATTICE).min(hi))
        };
        let (cols, rows) = (trim(cols, &ncols, bc), trim(rows, &nrows, br));
        let c0 = (cols.0 as i64 + off[0]) as usize - w.col0;
        let r0 = (rows.0 as i64 + off[1]) as usize - w.row0;
        let cells = CellBox {
            c0,
            c1: c0 + cols.1 - cols.0,
            r0,
            r1: r0 + rows.1 - rows.0,
        };
        let bw = cells.width();
        let mut values = vec![f64::INFINITY; bw * cells.height()];
        let ncols = &ncols[bc.0..=bc.1];
        // One task per block row: the box's rows of that block row.
        let mut rest: &mut [f64] = &mut values;
        let mut tasks = Vec::with_capacity(br.1 - br.0);
        for (b, &line) in nrows.iter().enumerate().take(br.1).skip(br.0) {
            let (r_start, r_end) = (line.max(rows.0), (line + SCORE_LATTICE).min(rows.1));
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut((r_end - r_start) * bw);
            rest = tail;
            tasks.push((b, (r_start, r_end), mine));
        }
        tasks
            .into_par_iter()
            .for_each(|(b, (r_start, r_end), block)| {
                let band = BlockRow {
                    k,
                    node_rows: [nrows[b], nrows[b + 1]],
                    rules: &rules[b * nb + bc.0..b * nb + bc.1],
                    r_start,
                    r_end,
                };
                self.score_block_row(&band, ncols, cols, &mut block.chunks_mut(bw))
            });
        Some(BoxScores { cells, values })
    }

    /// How each block of a frame's lattice is scored, row-major (one fewer per row than the
    /// node columns), from the nodes (row-major over the node lines `lines`: columns, rows).
    fn block_rules(&self, k: usize, nodes: &[Node], lines: (&[usize], &[usize])) -> Vec<Block> {
        let (ncols, nrows) = lines;
        let nc = ncols.len();
        (0..nrows.len() - 1)
            .into_par_iter()
            .flat_map_iter(|b| {
                let (top, bottom) = (&nodes[b * nc..(b + 1) * nc], &nodes[(b + 1) * nc..]);
                (0..nc - 1).map(move |c| {
                    let q = [top[c], top[c + 1], bottom[c], bottom[c + 1]];
                    self.block(k, [ncols[c], ncols[c + 1]], [nrows[b], nrows[b + 1]], q)
                })
            })
            .collect()
    }

    /// The cells of one block row: per block, blended or scored cell by cell. `rows` holds the
    /// box's rows from the band's `r_start`, each from the frame's column `cols.0`; `ncols`
    /// are the node columns of the band's rules (one more).
    fn score_block_row<'r>(
        &self,
        band: &BlockRow<'_>,
        ncols: &[usize],
        cols: (usize, usize),
        rows: &mut impl Iterator<Item = &'r mut [f64]>,
    ) {
        let k = band.k;
        let quads = band.rules;
        // A blended block's blend along its top and bottom node rows, per column: each cell
        // then blends the two by its row (the operations of `blend`, in its order).
        let edges: Vec<[f64; 2]> = (cols.0..cols.1)
            .map(|pc| {
                let c = (pc / SCORE_LATTICE).saturating_sub(cols.0 / SCORE_LATTICE);
                match &quads[c] {
                    Block::Blend(v) => {
                        let tx = frac(pc, ncols[c], ncols[c + 1]);
                        [lerp(v[0], v[1], tx), lerp(v[2], v[3], tx)]
                    }
                    _ => [f64::NAN; 2],
                }
            })
            .collect();
        let corners = self.cell_corners(band, ncols, cols);
        let cw = cols.1 - cols.0 + 1;
        let [n0, n1] = band.node_rows;
        for (j, row) in rows.enumerate() {
            let pr = band.r_start + j;
            let ty = frac(pr, n0, n1);
            for (pair, quad) in ncols.windows(2).zip(quads) {
                let (c_start, c_end) = (pair[0].max(cols.0), (pair[0] + SCORE_LATTICE).min(cols.1));
                let out = &mut row[c_start - cols.0..c_end - cols.0];
                match quad {
                    Block::Blend(_) => {
                        for (o, e) in out.iter_mut().zip(&edges[c_start - cols.0..]) {
                            *o = lerp(e[0], e[1], ty);
                        }
                    }
                    Block::Outside => {}
                    Block::Cells => {
                        let at = |line: usize| {
                            let i = line * cw + c_start - cols.0;
                            &corners[i..i + c_end - c_start + 1]
                        };
                        let cells = CellRow {
                            cols: (c_start, c_end),
                            pr,
                            top: at(j),
                            bottom: at(j + 1),
                        };
                        self.exact_row(k, &cells, out);
                    }
                }
            }
        }
    }

    /// The frame pixels of the cells' corners of a band's blocks scored cell by cell: line
    /// `j` (from 0) holds the corners at frame row `r_start + j - 0.5`, `cols.1 - cols.0 + 1`
    /// columns from `cols.0 - 0.5` (`None` in the other blocks' columns, and where the
    /// frame's map has no source). A corner is the same point, bit for bit, from the cells
    /// either side of it (`pc + 0.5 = (pc + 1) - 0.5` exactly): projected once, not four
    /// times as [`Self::exact`] does.
    fn cell_corners(
        &self,
        band: &BlockRow<'_>,
        ncols: &[usize],
        cols: (usize, usize),
    ) -> Vec<Option<[f64; 2]>> {
        if !band.rules.iter().any(|q| matches!(q, Block::Cells)) {
            return Vec::new();
        }
        let p = &self.frames[band.k].plan;
        let cw = cols.1 - cols.0 + 1;
        let mut corners = vec![None; cw * (band.r_end - band.r_start + 1)];
        for (line, row) in corners.chunks_exact_mut(cw).enumerate() {
            let y = (band.r_start + line) as f64 - 0.5;
            for (pair, quad) in ncols.windows(2).zip(band.rules) {
                if !matches!(quad, Block::Cells) {
                    continue;
                }
                let (c_start, c_end) = (pair[0].max(cols.0), (pair[0] + SCORE_LATTICE).min(cols.1));
                for (c, pc) in row[c_start - cols.0..=c_end - cols.0]
                    .iter_mut()
                    .zip(c_start..)
                {
                    *c = p.frame_pixel_of(pc as f64 - 0.5, y);
                }
            }
        }
        corners
    }

    /// [`Self::exact`]'s scores of a row of cells into `out` (left as they are where the
    /// frame does not cover), from the corners projected once.
    fn exact_row(&self, k: usize, cells: &CellRow<'_>, out: &mut [f64]) {
        let p = &self.frames[k].plan;
        let y = cells.pr as f64;
        for (i, (o, pc)) in out.iter_mut().zip(cells.cols.0..cells.cols.1).enumerate() {
            let Some(centre) = p.frame_pixel_of(pc as f64, y) else {
                continue;
            };
            if !self.in_frame(k, centre) {
                continue;
            }
            let (t, b) = (&cells.top[i..i + 2], &cells.bottom[i..i + 2]);
            let [Some(q0), Some(q1), Some(q2), Some(q3)] = [t[0], t[1], b[1], b[0]] else {
                continue;
            };
            let cell = [
                (pc as i64 + self.offsets[k][0]) as f64,
                (cells.pr as i64 + self.offsets[k][1]) as f64,
            ];
            if let Some(v) = self.score_from(k, [q0, q1, q2, q3], cell) {
                *o = v;
            }
        }
    }

    /// The frames of `cands` whose grid meets `w`, and their scores there.
    pub(super) fn scores_of(&self, cands: &[usize], w: Window) -> (Vec<usize>, Vec<BoxScores>) {
        cands
            .iter()
            .filter_map(|&k| self.scores_in(k, w).map(|s| (k, s)))
            .unzip()
    }

    /// The best frame of each cell of `w` (row-major), `None` where no frame covers it.
    pub fn labels(&self, w: Window) -> Vec<Option<usize>> {
        let cands = self.meeting(w);
        let (cands, scores) = self.scores_of(&cands, w);
        let labels = best_of(&cands, &scores, w.size);
        labels
            .into_iter()
            .map(|l| (l != NO_FRAME).then_some(l))
            .collect()
    }
}

/// One block row of a frame's lattice: its two node rows' frame rows and nodes, and the
/// first frame row of its cells the window holds.
struct BlockRow<'a> {
    k: usize,
    node_rows: [usize; 2],
    /// How each of the row's blocks the box holds is scored.
    rules: &'a [Block],
    /// The box's frame rows in the band: [r_start, r_end).
    r_start: usize,
    r_end: usize,
}

/// A row of cells scored one by one: frame columns [c0, c1) of frame row `pr`, and the frame
/// pixels of their corners above and below (from `c0 - 0.5`, one more than the cells).
struct CellRow<'a> {
    cols: (usize, usize),
    pr: usize,
    top: &'a [Option<[f64; 2]>],
    bottom: &'a [Option<[f64; 2]>],
}

/// The block of cell `p` on an axis of `n` cells: its two node lines and `p`'s fraction of
/// the way between them.
fn span(p: usize, n: usize) -> (usize, usize, f64) {
    let a = p / SCORE_LATTICE * SCORE_LATTICE;
    let b = (a + SCORE_LATTICE).min(n - 1);
    (a, b, frac(p, a, b))
}

/// `p`'s fraction of the way from node line `a` to `b` (0 when they coincide, at a grid's
/// last cell).
fn frac(p: usize, a: usize, b: usize) -> f64 {
    if b > a {
        (p - a) as f64 / (b - a) as f64
    } else {
        0.0
    }
}

/// The node lines of the blocks that meet cells [lo, hi) of an axis of `n` cells: each
/// block's first line, then the last block's far line (which equals its first at a last cell
/// on the lattice).
fn node_lines((lo, hi): (usize, usize), n: usize) -> Vec<usize> {
    let (first, last) = (lo / SCORE_LATTICE, (hi - 1) / SCORE_LATTICE);
    let mut lines: Vec<usize> = (first..=last).map(|b| b * SCORE_LATTICE).collect();
    lines.push((last * SCORE_LATTICE + SCORE_LATTICE).min(n - 1));
    lines
}

/// The bilinear blend of nodes (top left, top right, bottom left, bottom right) at
/// fractions (tx, ty).
fn blend(v: [f64; 4], tx: f64, ty: f64) -> f64 {
    lerp(lerp(v[0], v[1], tx), lerp(v[2], v[3], tx), ty)
}

/// `a` to `b` by `t`, as `a (1 - t) + b t`: [`blend`]'s step, which the block rows repeat.
fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}
