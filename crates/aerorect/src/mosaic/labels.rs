//! The boxes of a window's cells that frames' scores cover, and each cell's best frame.

/// A box of cells of a window or a tile: columns [c0, c1), rows [r0, r1).
#[derive(Debug, Clone, Copy)]
pub(super) struct CellBox {
    pub c0: usize,
    pub c1: usize,
    pub r0: usize,
    pub r1: usize,
}

impl CellBox {
    pub fn width(&self) -> usize {
        self.c1 - self.c0
    }

    pub fn height(&self) -> usize {
        self.r1 - self.r0
    }

    /// `inner`, a box given from this box's first cell, in the coordinates this box is in.
    pub fn shifted(&self, inner: CellBox) -> CellBox {
        CellBox {
            c0: self.c0 + inner.c0,
            c1: self.c0 + inner.c1,
            r0: self.r0 + inner.r0,
            r1: self.r0 + inner.r1,
        }
    }
}

/// The bounding box of the cells of a grid `width` cells wide (`values` row by row) where
/// `keep` holds; `None` where it holds nowhere.
pub(super) fn box_where<T>(
    values: &[T],
    width: usize,
    keep: impl Fn(&T) -> bool,
) -> Option<CellBox> {
    let (mut c0, mut c1, mut r0, mut r1) = (usize::MAX, 0, usize::MAX, 0);
    for (r, row) in values.chunks_exact(width).enumerate() {
        let (Some(first), Some(last)) = (row.iter().position(&keep), row.iter().rposition(&keep))
        else {
            continue;
        };
        (c0, c1, r0, r1) = (c0.min(first), c1.max(last + 1), r0.min(r), r + 1);
    }
    (c0 < c1).then_some(CellBox { c0, c1, r0, r1 })
}

/// A frame's scores over a box of a window's cells (row-major; infinity where it does not
/// cover); the window's other cells it does not cover.
pub(super) struct BoxScores {
    pub cells: CellBox,
    pub values: Vec<f64>,
}

impl BoxScores {
    /// Each row of the scores, with the index of its first cell in a window `ww` cells wide.
    pub fn rows_in(&self, ww: usize) -> impl Iterator<Item = (usize, &[f64])> {
        let b = self.cells;
        let rows = self.values.chunks_exact(b.width()).enumerate();
        rows.map(move |(r, row)| ((b.r0 + r) * ww + b.c0, row))
    }
}

/// [`best_of`]'s label of a cell no frame covers.
pub(super) const NO_FRAME: usize = usize::MAX;

/// The lowest finite score's frame per cell of a window of `size` (the first of equals;
/// [`NO_FRAME`] where none is finite).
pub(super) fn best_of(
    cands: &[usize],
    scores: &[BoxScores],
    size: aerorect_core::ImageSize,
) -> Vec<usize> {
    let (n, ww) = (size.pixels(), size.width);
    let (mut best, mut labels) = (vec![f64::INFINITY; n], vec![NO_FRAME; n]);
    let mut row_labels = vec![NO_FRAME; ww];
    for (&k, s) in cands.iter().zip(scores) {
        for (at, row) in s.rows_in(ww) {
            let (best, labels) = (
                &mut best[at..at + row.len()],
                &mut labels[at..at + row.len()],
            );
            // Every cell stored, whether or not it changes: the least score as a minimum,
            // the labels through a row of their own. Stored only where better, they were
            // masked stores (slow on AMD's cores: best_of took 3.8 % of snowpeak's CPU).
            let new_labels = &mut row_labels[..row.len()];
            let cells = best
                .iter_mut()
                .zip(labels.iter())
                .zip(new_labels.iter_mut());
            for (&v, ((b, &l), nl)) in row.iter().zip(cells) {
                let w = if v.is_finite() { v } else { f64::INFINITY };
                *nl = if w < *b { k } else { l };
                *b = b.min(w);
            }
            labels.copy_from_slice(new_labels);
        }
    }
    labels
}
