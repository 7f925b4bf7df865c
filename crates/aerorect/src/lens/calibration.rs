//! Calibration input from files: control points, or chessboard photos.

use crate::Error;
use aerorect_core::ImageSize;
use aerorect_io::{ControlPoint, read_image};
use aerorect_raster::chessboard::{BoardMiss, ChessboardFinder};
use aerorect_solve::calib::Observation;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Control points (CSV `image,X,Y,Z,u,v`) as calibration observations.
pub fn read_observations(path: &Path) -> Result<Vec<Observation>, Error> {
    Ok(aerorect_io::read_control_points(path)?
        .into_iter()
        .map(|p| Observation {
            image: p.image,
            world: [p.x, p.y, p.z],
            pixel: [p.u, p.v],
        })
        .collect())
}

/// A chessboard: `cols x rows` inner corners (OpenCV's `patternSize`), squares `square_m` wide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Board {
    pub cols: usize,
    pub rows: usize,
    pub square_m: f64,
    /// Refine every corner in a `(2 h + 1)`-pixel window, like OpenCV's `cornerSubPix` with
    /// `winSize = (h, h)`; `None`: at most h = 11, narrowed to 0.45 of the local square size.
    pub fixed_half_window: Option<usize>,
}

/// The widest chessboard square, metres.
pub const MAX_SQUARE_M: f64 = 1e3;

impl Board {
    /// Refuses a square size that is not a finite number in 0 < s <= [`MAX_SQUARE_M`].
    pub fn validate(&self) -> Result<(), Error> {
        let s = self.square_m;
        if s.is_finite() && s > 0.0 && s <= MAX_SQUARE_M {
            return Ok(());
        }
        Err(Error::Invalid(format!(
            "square size {} m: must be a finite number > 0 and at most {MAX_SQUARE_M} m",
            aerorect_core::error::Num(s)
        )))
    }
}

/// What became of one calibration photo.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// The id written in the `image` column (the file name, or the path when names repeat).
    pub image: String,
    pub path: PathBuf,
    /// The corners found, or why the view is skipped.
    pub outcome: Result<usize, BoardMiss>,
    pub detect_seconds: f64,
}

/// Calibration observations read off chessboard photos.
#[derive(Debug, Clone)]
pub struct BoardObservations {
    pub size: ImageSize,
    pub views: Vec<View>,
    /// Row by row per view (`cols` a row), X = column x square, Y = row x square, Z = 0.
    pub observations: Vec<Observation>,
}

impl BoardObservations {
    /// The views whose board was found.
    pub fn found(&self) -> usize {
        self.views.iter().filter(|v| v.outcome.is_ok()).count()
    }

    /// The observations as control points (`image,X,Y,Z,u,v`), for `--save-corners`.
    pub fn control_points(&self) -> Vec<ControlPoint> {
        self.observations
            .iter()
            .map(|o| ControlPoint {
                image: o.image.clone(),
                x: o.world[0],
                y: o.world[1],
                z: o.world[2],
                u: o.pixel[0],
                v: o.pixel[1],
            })
            .collect()
    }
}

/// The board's corners in every photo (decoded, turned gray, searched in parallel); photos
/// without the whole board are kept in `views` with the reason and give no observations. All
/// photos must have one size (an error names the first that differs).
pub fn observations_from_images(
    paths: &[PathBuf],
    board: Board,
) -> Result<BoardObservations, Error> {
    board.validate()?;
    let finder = ChessboardFinder::new(board.cols, board.rows)
        .and_then(|f| match board.fixed_half_window {
            Some(h) => f.with_fixed_half_window(h),
            None => Ok(f),
        })
        .map_err(Error::from)?;
    aerorect_io::refuse_duplicate_photos(paths)?;
    let ids = image_ids(paths);
    let found: Vec<(ImageSize, View, Vec<[f64; 2]>)> = paths
        .par_iter()
        .zip(ids)
        .map(|(path, image)| {
            let gray = crate::motion::gray(&read_image(path)?)?;
            let t = Instant::now();
            let outcome = finder.find(&gray);
            let detect_seconds = t.elapsed().as_secs_f64();
            let corners = outcome.clone().unwrap_or_default();
            let view = View {
                image,
                path: path.clone(),
                outcome: outcome.map(|c| c.len()),
                detect_seconds,
            };
            Ok((gray.size(), view, corners))
        })
        .collect::<Result<_, Error>>()?;
    let size = found.first().map(|f| f.0).unwrap_or(ImageSize::new(0, 0));
    if let Some((s, v, _)) = found.iter().find(|f| f.0 != size) {
        return Err(Error::Invalid(format!(
            "{}: {} x {} pixels, but {} is {} x {}: calibration photos must share one size",
            v.path.display(),
            s.width,
            s.height,
            paths[0].display(),
            size.width,
            size.height
        )));
    }
    let mut observations = Vec::new();
    for (_, view, corners) in &found {
        for (k, p) in corners.iter().enumerate() {
            let (c, r) = (k % board.cols, k / board.cols);
            observations.push(Observation {
                image: view.image.clone(),
                world: [c as f64 * board.square_m, r as f64 * board.square_m, 0.0],
                pixel: *p,
            });
        }
    }
    Ok(BoardObservations {
        size,
        views: found.into_iter().map(|f| f.1).collect(),
        observations,
    })
}

/// File names as ids, or the paths as given when two photos share a name.
fn image_ids(paths: &[PathBuf]) -> Vec<String> {
    let names: Vec<String> = paths
        .iter()
        .map(|p| {
            p.file_name().map_or_else(
                || p.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect();
    let unique = names.iter().collect::<std::collections::HashSet<_>>().len() == names.len();
    if unique {
        names
    } else {
        paths.iter().map(|p| p.display().to_string()).collect()
    }
}
