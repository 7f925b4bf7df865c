//! `calibrate --images`: chessboard photos to calibration observations, with a line per photo.

use aerorect::calibration::{Board, BoardObservations, observations_from_images};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// The fewest photos with the whole board that a calibration accepts.
const MIN_VIEWS: usize = 3;

/// `--board COLSxROWS` as numbers.
fn parse_board(s: &str) -> Result<(usize, usize)> {
    let parse = || -> Option<(usize, usize)> {
        let (c, r) = s.split_once(['x', 'X'])?;
        Some((c.trim().parse().ok()?, r.trim().parse().ok()?))
    };
    match parse() {
        Some((c, r)) if c >= 3 && r >= 3 => Ok((c, r)),
        _ => bail!("--board '{s}': expected COLSxROWS inner corners, each at least 3, e.g. 9x6"),
    }
}

/// The board's corners in every photo; prints what became of each and refuses fewer than 3.
pub(crate) fn board_observations(
    images: &[PathBuf],
    board: &Option<String>,
    square_m: Option<f64>,
    fixed_half_window: Option<usize>,
) -> Result<BoardObservations> {
    let (cols, rows) = parse_board(board.as_deref().context("--board COLSxROWS is required")?)?;
    let square_m = square_m.context("--square-m is required with --images")?;
    let board = Board {
        cols,
        rows,
        square_m,
        fixed_half_window,
    };
    board
        .validate()
        .with_context(|| format!("--square-m {}", aerorect::core::error::Num(square_m)))?;
    let found = observations_from_images(images, board)?;
    outln!(
        "chessboard {cols} x {rows} inner corners, squares {square_m} m, photos {} x {}:",
        found.size.width,
        found.size.height
    );
    for v in &found.views {
        match &v.outcome {
            Ok(n) => outln!(
                "  {:<14} {n} corners ({:.1} ms)",
                v.image,
                v.detect_seconds * 1e3
            ),
            Err(why) => outln!("  {:<14} skipped: {why}", v.image),
        }
    }
    let n = found.found();
    if n < MIN_VIEWS {
        bail!(
            "only {n} of {} photos show the whole {cols} x {rows} board: calibration needs at least {MIN_VIEWS}",
            found.views.len()
        );
    }
    Ok(found)
}
