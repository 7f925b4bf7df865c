//! Each frame's weight over a tile: 1 over the cells it is best at, cross-faded over
//! `feather_px` across each seam and faded out towards the edge of its cover.

use super::distance::distance_within;
use super::labels::{BoxScores, CellBox, box_where};
use super::{Blend, Window};
use aerorect_core::ImageSize;

/// Frame k's weights over a box of a tile's cells (tile coordinates); 0 elsewhere.
pub(super) struct Weights {
    cells: CellBox,
    values: Vec<f32>,
}

impl Weights {
    /// The weights of the tile's row `row`, columns [c0, c1), which must lie in the box.
    pub(super) fn row(&self, row: usize, (c0, c1): (usize, usize)) -> &[f32] {
        let start = (row - self.cells.r0) * self.cells.width() + c0 - self.cells.c0;
        &self.values[start..start + c1 - c0]
    }

    /// The bounding box of the positive weights (tile coordinates).
    pub(super) fn positive_box(&self) -> Option<CellBox> {
        let b = box_where(&self.values, self.cells.width(), |&v| v > 0.0)?;
        Some(self.cells.shifted(b))
    }
}

/// Frame k's weight over the cells of `tile` (within `win`, which `labels` and `scores` cover);
/// `None` where it weighs none.
pub(super) fn weights(
    (blend, cap): (Blend, usize),
    k: usize,
    (win, tile): (Window, Window),
    labels: &[usize],
    scores: &BoxScores,
) -> Option<Weights> {
    let ww = win.size.width;
    // Beyond the box of k's covered cells k's weight is 0. Feathered, the weights read
    // distances at covered cells to features within the feather's width, so the transforms
    // run over that box grown by one more: the whole window's distances there.
    let grow = match blend {
        Blend::Feather => cap + 1,
        Blend::None => 0,
    };
    let b = covered_box(scores, win.size, grow)?;
    let bw = b.width();
    let cells = bw * b.height();
    let feather = blend == Blend::Feather;
    let (mut mine, mut uncovered) = (Vec::with_capacity(cells), Vec::new());
    for r in b.r0..b.r1 {
        mine.extend(labels[r * ww + b.c0..r * ww + b.c1].iter().map(|&l| l == k));
        if feather {
            uncovered_row(scores, r, (b.c0, b.c1), &mut uncovered);
        }
    }
    if !mine.contains(&true) {
        return None;
    }
    let feathered = feather.then(|| Distances::new(&mine, &uncovered, bw, cap));
    // The tile's cells in the box (window coordinates).
    let (tc, tr) = (tile.col0 - win.col0, tile.row0 - win.row0);
    let cells = CellBox {
        c0: b.c0.max(tc),
        c1: b.c1.min(tc + tile.size.width),
        r0: b.r0.max(tr),
        r1: b.r1.min(tr + tile.size.height),
    };
    if cells.c0 >= cells.c1 || cells.r0 >= cells.r1 {
        return None;
    }
    let n = cap as f32;
    let mut values = Vec::with_capacity(cells.width() * cells.height());
    for r in cells.r0..cells.r1 {
        let j0 = (r - b.r0) * bw + cells.c0 - b.c0;
        let js = j0..j0 + cells.width();
        match &feathered {
            None => values.extend(mine[js].iter().map(|&m| f32::from(u8::from(m)))),
            Some(d) => {
                let ((d_in, d_out), d_cov) = (d.seam(), &d.to_uncovered);
                let seam = mine[js.clone()]
                    .iter()
                    .zip(&d_in[js.clone()])
                    .zip(&d_out[js.clone()]);
                let cover = uncovered[js.clone()].iter().zip(&d_cov[js]);
                values.extend(seam.zip(cover).map(|(((&m, &di), &dout), (&u, &dc))| {
                    let s = if m { di - 0.5 } else { 0.5 - dout };
                    let w = (0.5 + s / n).clamp(0.0, 1.0) * (dc / n).min(1.0);
                    if u { 0.0 } else { w }
                }));
            }
        }
    }
    Some(Weights {
        cells: CellBox {
            c0: cells.c0 - tc,
            c1: cells.c1 - tc,
            r0: cells.r0 - tr,
            r1: cells.r1 - tr,
        },
        values,
    })
}

/// The distances the cross-fade reads over a box of cells: to the uncovered cells, and
/// across the seam.
struct Distances {
    /// From each covered cell to the nearest uncovered one, within the feather.
    to_uncovered: Vec<f32>,
    /// From k's cells to the others' and from the others' to k's, within half the feather
    /// (plus one): `None` where k alone covers the box.
    seam: Option<[Vec<f32>; 2]>,
}

impl Distances {
    /// Over a box `bw` cells wide (`mine`: k's cells), for a feather of `cap`. The cross-fade
    /// is 0 or 1 beyond half the feather from the seam: a distance to it over `cap / 2 + 1`
    /// (infinity) gives the weight the exact distance would.
    fn new(mine: &[bool], uncovered: &[bool], bw: usize, cap: usize) -> Self {
        let to_uncovered = distance_within(uncovered, bw, cap);
        // k alone covers the box (most tiles of a flight): no seam.
        if mine.iter().zip(uncovered).all(|(&m, &u)| m != u) {
            return Self {
                to_uncovered,
                seam: None,
            };
        }
        let not_mine: Vec<bool> = mine.iter().map(|m| !m).collect();
        // The distance to k's cells is read only at the others' cells: where every cell is
        // k's, none is read (infinity stands in).
        let to_mine = match not_mine.contains(&true) {
            true => distance_within(mine, bw, cap / 2 + 1),
            false => vec![f32::INFINITY; mine.len()],
        };
        let to_others = distance_within(&not_mine, bw, cap / 2 + 1);
        Self {
            to_uncovered,
            seam: Some([to_others, to_mine]),
        }
    }

    /// The distances from k's cells to the others' and from the others' to k's. Where k alone
    /// covers the box, the cells not k's are the uncovered ones: the distance to them within
    /// the feather gives the cross-fade (saturated beyond half the feather) the weight the
    /// seam's would, and the distance to k's cells is read at no cell that weighs (each cell
    /// not k's is uncovered and weighs 0).
    fn seam(&self) -> (&[f32], &[f32]) {
        match &self.seam {
            Some([to_others, to_mine]) => (to_others, to_mine),
            None => (&self.to_uncovered, &self.to_uncovered),
        }
    }
}

/// Whether the frame leaves uncovered each cell of window row `r`, columns [c0, c1) (those
/// beyond its scores' box too), appended to `out`.
fn uncovered_row(scores: &BoxScores, r: usize, (c0, c1): (usize, usize), out: &mut Vec<bool>) {
    let sb = scores.cells;
    if r < sb.r0 || r >= sb.r1 {
        out.extend(std::iter::repeat_n(true, c1 - c0));
        return;
    }
    // The columns the box holds: [lo, hi), within [c0, c1).
    let lo = c0.max(sb.c0).min(c1);
    let hi = c1.min(sb.c1).max(lo);
    out.extend(std::iter::repeat_n(true, lo - c0));
    if hi > lo {
        let at = (r - sb.r0) * sb.width();
        let row = &scores.values[at + lo - sb.c0..at + hi - sb.c0];
        out.extend(row.iter().map(|v| !v.is_finite()));
    }
    out.extend(std::iter::repeat_n(true, c1 - hi));
}

/// The bounding box of the finite `scores` in a window of `size`, grown by `by` cells (within
/// the window); `None` when no score is finite.
fn covered_box(scores: &BoxScores, size: ImageSize, by: usize) -> Option<CellBox> {
    let b = scores.cells.shifted(box_where(
        &scores.values,
        scores.cells.width(),
        |s: &f64| s.is_finite(),
    )?);
    Some(CellBox {
        c0: b.c0.saturating_sub(by),
        c1: (b.c1 + by).min(size.width),
        r0: b.r0.saturating_sub(by),
        r1: (b.r1 + by).min(size.height),
    })
}
