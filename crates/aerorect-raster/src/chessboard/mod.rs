//! Chessboard detection for camera calibration: the inner corners of a `cols x rows` board,
//! numbered as OpenCV numbers them, refined to sub-pixel accuracy.
//!
//! 1. On a pyramid level no larger than 1280 pixels a side, the image is blurred (sigma 1.5) and
//!    saddle points of the Hessian that look like X-junctions become candidates (`saddle`).
//! 2. From the strongest candidates a grid is grown along the edge lines (`grid`); the first
//!    grid with exactly the board's shape and no hole is the board. A smaller grid is a partial
//!    board, refused with the count found.
//! 3. The grid is numbered in OpenCV's order (`order`, CONVENTIONS.md) and every corner refined
//!    on the full-resolution image by OpenCV's `cornerSubPix` method (`subpix`), with a window
//!    no wider than the local square size allows.

mod grid;
mod image;
mod order;
mod saddle;
mod subpix;

use crate::Raster;
use crate::pyramid::{full_from_level, pyramid};
use image::{Gray, blur, gaussian_kernel};
use thiserror::Error;

/// Invalid detector settings.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ChessboardError {
    #[error("board of {cols} x {rows} inner corners: each side needs at least 3")]
    BoardSize { cols: usize, rows: usize },
    #[error("refinement half window {half}: must be 1 to 64 pixels")]
    Window { half: usize },
}

/// Why a board was not found in an image (a normal outcome, reported per image).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BoardMiss {
    #[error("no chessboard corners (found {candidates} X-junctions, no grid of them)")]
    NoGrid { candidates: usize },
    #[error(
        "partial board: a grid of {cols} x {rows} corners{holes} of the {want_cols} x {want_rows} \
         (board cut by the image edge, occluded or blurred)"
    )]
    Partial {
        cols: usize,
        rows: usize,
        want_cols: usize,
        want_rows: usize,
        holes: &'static str,
    },
    #[error("a grid of {cols} x {rows} corners, larger than the {want_cols} x {want_rows} board")]
    Larger {
        cols: usize,
        rows: usize,
        want_cols: usize,
        want_rows: usize,
    },
}

/// The detector for one board size; build once, run on many images.
#[derive(Debug, Clone)]
pub struct ChessboardFinder {
    cols: usize,
    rows: usize,
    max_half_window: usize,
    /// Refine every corner in this half window, whatever the square size (OpenCV's way).
    fixed_half_window: bool,
    kernel: Vec<f32>,
}

/// Pyramid levels are halved until the larger side is at most this.
const DETECTION_SIDE: usize = 1280;
/// Seeds tried, strongest first, before giving up.
const MAX_SEEDS: usize = 400;

impl ChessboardFinder {
    /// A finder for `cols x rows` inner corners (OpenCV's `patternSize`), refining in windows of
    /// at most 23 x 23 pixels (half 11, the usual `cornerSubPix` window).
    pub fn new(cols: usize, rows: usize) -> Result<Self, ChessboardError> {
        if cols < 3 || rows < 3 {
            return Err(ChessboardError::BoardSize { cols, rows });
        }
        Ok(Self {
            cols,
            rows,
            max_half_window: 11,
            fixed_half_window: false,
            kernel: gaussian_kernel(1.5),
        })
    }

    /// The largest refinement half window (the window is 2 half + 1 pixels square).
    pub fn with_max_half_window(mut self, half: usize) -> Result<Self, ChessboardError> {
        if !(1..=64).contains(&half) {
            return Err(ChessboardError::Window { half });
        }
        self.max_half_window = half;
        Ok(self)
    }

    /// Every corner refined in a `(2 half + 1)` pixel window, as OpenCV's `cornerSubPix` with
    /// `winSize = (half, half)` does, even where the window reaches past the four squares about
    /// the corner (on strongly foreshortened or small squares, where the default narrows it).
    pub fn with_fixed_half_window(mut self, half: usize) -> Result<Self, ChessboardError> {
        self = self.with_max_half_window(half)?;
        self.fixed_half_window = true;
        Ok(self)
    }

    /// The board's inner corners in band 0 of `img`, row by row (`cols` a row), in pixels.
    pub fn find(&self, img: &Raster<f32>) -> Result<Vec<[f64; 2]>, BoardMiss> {
        let levels = pyramid(img, DETECTION_SIDE);
        let level = levels.len() - 1;
        let top = &levels[level];
        let top_gray = Gray {
            data: top.plane(0),
            width: top.width(),
            height: top.height(),
        };
        let blurred = blur(top_gray, &self.kernel);
        let blurred = Gray {
            data: &blurred,
            ..top_gray
        };
        let coarse = self.coarse_corners(blurred)?;
        let full = Gray {
            data: img.plane(0),
            width: img.width(),
            height: img.height(),
        };
        let coarse: Vec<[f64; 2]> = coarse.iter().map(|&p| full_from_level(level, p)).collect();
        Ok(self.refined(full, &coarse))
    }

    /// The board's corners, ordered, at the detection level.
    fn coarse_corners(&self, blurred: Gray<'_>) -> Result<Vec<[f64; 2]>, BoardMiss> {
        let cands = saddle::candidates(blurred);
        let buckets = grid::Buckets::new(&cands, blurred.width, blurred.height, 16.0);
        let mut visited = vec![false; cands.len()];
        let mut best: Option<grid::Grid> = None;
        for seed in 0..cands.len().min(MAX_SEEDS) {
            if visited[seed] {
                continue;
            }
            visited[seed] = true;
            let Some(g) = grid::grow(&cands, &buckets, seed) else {
                continue;
            };
            for &c in g.cells.values() {
                visited[c] = true;
            }
            if let Some(pts) = self.board_in(&g, &cands, blurred) {
                return Ok(pts);
            }
            if best.as_ref().is_none_or(|b| g.cells.len() > b.cells.len()) {
                best = Some(g);
            }
        }
        Err(self.miss(best.as_ref(), cands.len()))
    }

    /// The board's corners in board order when `g` holds a full board-sized window.
    fn board_in(
        &self,
        g: &grid::Grid,
        cands: &[saddle::Candidate],
        blurred: Gray<'_>,
    ) -> Option<Vec<[f64; 2]>> {
        let board = (self.cols, self.rows);
        let w = g.board_window(cands, board)?;
        if g.extends_past(&w, cands) {
            return None;
        }
        let (i0, j0, nx, ny) = w.bounds();
        let at = |i: usize, j: usize| {
            let k = (i0 + i as i32, j0 + j as i32);
            w.cells.get(&k).map_or([0.0; 2], |&c| cands[c].p)
        };
        order::board_order(at, (nx, ny), board, blurred)
    }

    fn miss(&self, best: Option<&grid::Grid>, candidates: usize) -> BoardMiss {
        let Some(g) = best.filter(|g| g.cells.len() >= 4) else {
            return BoardMiss::NoGrid { candidates };
        };
        let (_, _, nx, ny) = g.bounds();
        let (lo, hi) = (nx.min(ny), nx.max(ny));
        let (want_lo, want_hi) = (self.cols.min(self.rows), self.cols.max(self.rows));
        if hi > want_hi || lo > want_lo {
            return BoardMiss::Larger {
                cols: nx,
                rows: ny,
                want_cols: self.cols,
                want_rows: self.rows,
            };
        }
        BoardMiss::Partial {
            cols: nx,
            rows: ny,
            want_cols: self.cols,
            want_rows: self.rows,
            holes: if g.is_full() { "" } else { " with holes" },
        }
    }

    /// Every corner refined in `img`. The window's half size is at most 0.75 of the corner's
    /// distance to the nearest edge that does not pass through it (the far sides of its four
    /// squares); when that result moves more than 0.25 px from the one in a window of 0.45 of
    /// the distance, something else reached into the larger window and the smaller one is kept.
    fn refined(&self, img: Gray<'_>, coarse: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let refine = |p: [f64; 2], half: usize| {
            let settings = subpix::Refine {
                half,
                max_iterations: 30,
                eps_px: 1e-3,
            };
            subpix::refine(img, p, settings)
        };
        (0..coarse.len())
            .map(|k| {
                let p = coarse[k];
                if self.fixed_half_window {
                    return refine(p, self.max_half_window);
                }
                let free = clear_distance(coarse, self.cols, self.rows, k);
                let half = |f: f64| ((f * free) as usize).clamp(2, self.max_half_window);
                let (wide, narrow) = (half(WIDE), half(NARROW));
                let a = refine(p, wide);
                if wide == narrow {
                    return a;
                }
                let b = refine(p, narrow);
                if (a[0] - b[0]).hypot(a[1] - b[1]) > WINDOW_DISAGREEMENT_PX {
                    b
                } else {
                    a
                }
            })
            .collect()
    }
}

/// Refinement half windows as fractions of the distance to the nearest foreign edge.
const WIDE: f64 = 0.75;
const NARROW: f64 = 0.45;
/// Wide and narrow windows that disagree by more than this (pixels) mean a foreign edge.
const WINDOW_DISAGREEMENT_PX: f64 = 0.25;

/// Corner (c, r) of the grid, extended one square past the board's edge by straight steps.
fn grid_at(p: &[[f64; 2]], cols: usize, rows: usize, c: isize, r: isize) -> [f64; 2] {
    let (cc, rc) = (c.clamp(0, cols as isize - 1), r.clamp(0, rows as isize - 1));
    let idx = |c: isize, r: isize| p[r as usize * cols + c as usize];
    let base = idx(cc, rc);
    let mut out = base;
    for (d, inward) in [
        (
            c - cc,
            idx((cc - (c - cc).signum()).clamp(0, cols as isize - 1), rc),
        ),
        (
            r - rc,
            idx(cc, (rc - (r - rc).signum()).clamp(0, rows as isize - 1)),
        ),
    ] {
        if d != 0 {
            let k = d.abs() as f64;
            out = [
                out[0] + k * (base[0] - inward[0]),
                out[1] + k * (base[1] - inward[1]),
            ];
        }
    }
    out
}

/// The distance from corner `k` to the nearest grid line that does not pass through it: the
/// eight far sides of the four squares about it.
fn clear_distance(p: &[[f64; 2]], cols: usize, rows: usize, k: usize) -> f64 {
    let (c, r) = ((k % cols) as isize, (k / cols) as isize);
    let at = |dc: isize, dr: isize| grid_at(p, cols, rows, c + dc, r + dr);
    let o = p[k];
    let sides = [
        ((1, -1), (1, 0)),
        ((1, 0), (1, 1)),
        ((-1, -1), (-1, 0)),
        ((-1, 0), (-1, 1)),
        ((-1, 1), (0, 1)),
        ((0, 1), (1, 1)),
        ((-1, -1), (0, -1)),
        ((0, -1), (1, -1)),
    ];
    sides
        .iter()
        .map(|&(a, b)| {
            let (a, b) = (at(a.0, a.1), at(b.0, b.1));
            let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
            let len = dx.hypot(dy).max(1e-9);
            ((o[0] - a[0]) * dy - (o[1] - a[1]) * dx).abs() / len
        })
        .fold(f64::MAX, f64::min)
}
