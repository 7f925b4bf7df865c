//! How much of the image the control points cover: a grid of cells counting the observed points
//! (the heat map of the calibration report), and a warning when a corner ninth of the image (a
//! 3 x 3 split) holds none: the lens model is then extrapolated where distortion is largest.

use super::Observation;
use aerorect_core::ImageSize;
use serde::Serialize;

/// The default heat-map grid.
pub const COVERAGE_GRID: (usize, usize) = (8, 6);

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coverage {
    pub cols: usize,
    pub rows: usize,
    /// Points per cell, row-major from the top-left; cell (c, r) spans columns
    /// [c W / cols, (c + 1) W / cols) of the image's extent -0.5 .. W - 0.5.
    pub counts: Vec<usize>,
    /// The corner ninths (of a 3 x 3 split) with no point: top-left, top-right, bottom-left,
    /// bottom-right.
    pub empty_corners: Vec<String>,
}

/// The cell of pixel `p` in a cols x rows grid over an image of `size` (pixel centres at
/// integers, so the image spans -0.5 .. W - 0.5).
fn cell(p: [f64; 2], size: ImageSize, cols: usize, rows: usize) -> (usize, usize) {
    let f = |x: f64, extent: usize, n: usize| {
        let i = ((x + 0.5) / extent as f64 * n as f64).floor();
        (i.max(0.0) as usize).min(n - 1)
    };
    (f(p[0], size.width, cols), f(p[1], size.height, rows))
}

/// The coverage of the points of `obs` in an image of `size` on a cols x rows grid.
pub fn coverage(obs: &[Observation], size: ImageSize, cols: usize, rows: usize) -> Coverage {
    let (cols, rows) = (cols.max(1), rows.max(1));
    let mut counts = vec![0; cols * rows];
    let mut ninths = [0usize; 9];
    for o in obs {
        let (c, r) = cell(o.pixel, size, cols, rows);
        counts[r * cols + c] += 1;
        let (c3, r3) = cell(o.pixel, size, 3, 3);
        ninths[r3 * 3 + c3] += 1;
    }
    let empty_corners = [
        (0, "top-left"),
        (2, "top-right"),
        (6, "bottom-left"),
        (8, "bottom-right"),
    ]
    .iter()
    .filter(|(i, _)| ninths[*i] == 0)
    .map(|(_, n)| n.to_string())
    .collect();
    Coverage {
        cols,
        rows,
        counts,
        empty_corners,
    }
}

impl Coverage {
    /// The warning when a corner ninth holds no point.
    pub fn warning(&self) -> Option<String> {
        (!self.empty_corners.is_empty()).then(|| {
            format!(
                "no control point in the image's {} corner (of a 3 x 3 split): the lens is \
                 extrapolated there; add views with the target in the image corners",
                self.empty_corners.join(", ")
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(points: &[[f64; 2]]) -> Vec<Observation> {
        points
            .iter()
            .map(|p| Observation {
                image: "a".into(),
                world: [0.0; 3],
                pixel: *p,
            })
            .collect()
    }

    fn grid(u0: f64, u1: f64, v0: f64, v1: f64, n: usize) -> Vec<[f64; 2]> {
        let mut g = vec![];
        for i in 0..n {
            for j in 0..n {
                let t = |a: f64, b: f64, k: usize| a + (b - a) * k as f64 / (n - 1) as f64;
                g.push([t(u0, u1, i), t(v0, v1, j)]);
            }
        }
        g
    }

    #[test]
    fn points_only_in_the_centre_warn_and_full_coverage_does_not() {
        let size = ImageSize::new(640, 480);
        let centre = coverage(&obs(&grid(250.0, 390.0, 180.0, 300.0, 9)), size, 8, 6);
        assert_eq!(centre.empty_corners.len(), 4, "{centre:?}");
        assert!(centre.warning().unwrap().contains("top-left"));
        let full = coverage(&obs(&grid(-0.5, 639.4, -0.5, 479.4, 12)), size, 8, 6);
        assert!(
            full.empty_corners.is_empty() && full.warning().is_none(),
            "{full:?}"
        );
        // One missing corner is named alone.
        let mut pts = grid(-0.5, 639.4, -0.5, 479.4, 12);
        pts.retain(|p| !(p[0] > 426.0 && p[1] > 320.0));
        let one = coverage(&obs(&pts), size, 8, 6);
        assert_eq!(one.empty_corners, ["bottom-right"]);
    }

    #[test]
    fn heat_map_counts_equal_a_direct_count() {
        let size = ImageSize::new(640, 480);
        let pts = grid(3.3, 611.0, 7.7, 470.2, 23);
        let cov = coverage(&obs(&pts), size, 8, 6);
        assert_eq!(cov.counts.iter().sum::<usize>(), pts.len());
        // Cells are 80 x 80 pixels of the extent -0.5 .. 639.5: count each by its bounds.
        for r in 0..6 {
            for c in 0..8 {
                let (u0, v0) = (c as f64 * 80.0 - 0.5, r as f64 * 80.0 - 0.5);
                let n = pts
                    .iter()
                    .filter(|p| p[0] >= u0 && p[0] < u0 + 80.0 && p[1] >= v0 && p[1] < v0 + 80.0)
                    .count();
                assert_eq!(cov.counts[r * 8 + c], n, "cell ({c}, {r})");
            }
        }
    }
}
