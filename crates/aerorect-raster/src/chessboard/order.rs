//! Numbering a found grid the way OpenCV numbers a chessboard: row by row, `cols` corners a row.
//!
//! Of the eight ways to lay the board's (column, row) indices on the grid, only those of the
//! board's shape and handedness remain: the row direction is the column direction turned
//! clockwise on screen (u right, v down), so X along a row, Y down the rows and Z = X x Y points
//! away from a camera that sees the printed face. When one side of the board has an odd number
//! of inner corners and the other an even number, the colours tell the remaining half turn
//! apart: the square between corners 0, 1, cols and cols + 1 is dark (OpenCV's order on its own
//! samples). Otherwise the order whose rows run most downward in the image is taken.

use super::image::Gray;

/// The corners of the `nx x ny` grid `at(i, j)` in board order, or `None` when the grid's shape
/// is not the board's.
pub fn board_order(
    at: impl Fn(usize, usize) -> [f64; 2],
    (nx, ny): (usize, usize),
    (cols, rows): (usize, usize),
    img: Gray<'_>,
) -> Option<Vec<[f64; 2]>> {
    let mut best: Option<(f64, Vec<[f64; 2]>)> = None;
    for t in 0..8u8 {
        let (swap, fi, fj) = (t & 1 != 0, t & 2 != 0, t & 4 != 0);
        let (na, nb) = if swap { (ny, nx) } else { (nx, ny) };
        if (na, nb) != (cols, rows) {
            continue;
        }
        let pts: Vec<[f64; 2]> = (0..rows)
            .flat_map(|r| (0..cols).map(move |c| (c, r)))
            .map(|(c, r)| {
                let (i, j) = if swap { (r, c) } else { (c, r) };
                let i = if fi { nx - 1 - i } else { i };
                let j = if fj { ny - 1 - j } else { j };
                at(i, j)
            })
            .collect();
        if !right_handed(&pts, cols, rows) {
            continue;
        }
        if (cols + rows) % 2 == 1 && !first_square_dark(&pts, cols, rows, img) {
            continue;
        }
        let down = pts[(rows - 1) * cols][1] - pts[0][1];
        if best.as_ref().is_none_or(|(d, _)| down > *d) {
            best = Some((down, pts));
        }
    }
    best.map(|b| b.1)
}

fn right_handed(p: &[[f64; 2]], cols: usize, rows: usize) -> bool {
    let o = p[0];
    let x = [p[cols - 1][0] - o[0], p[cols - 1][1] - o[1]];
    let y = [
        p[(rows - 1) * cols][0] - o[0],
        p[(rows - 1) * cols][1] - o[1],
    ];
    x[0] * y[1] - x[1] * y[0] > 0.0
}

/// Whether the squares of the first square's colour (even c + r) are darker on average.
fn first_square_dark(p: &[[f64; 2]], cols: usize, rows: usize, img: Gray<'_>) -> bool {
    let mut diff = 0.0;
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let q = [
                p[r * cols + c],
                p[r * cols + c + 1],
                p[(r + 1) * cols + c],
                p[(r + 1) * cols + c + 1],
            ];
            let u = 0.25 * q.iter().map(|v| v[0]).sum::<f64>();
            let v = 0.25 * q.iter().map(|v| v[1]).sum::<f64>();
            let s = img.bilinear(u, v);
            diff += if (c + r) % 2 == 0 { s } else { -s };
        }
    }
    diff < 0.0
}
