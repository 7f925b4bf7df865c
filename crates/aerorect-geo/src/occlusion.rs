//! Occlusion: output pixels whose ground point the camera cannot see because terrain stands
//! between them. Each ground point's line of sight to the camera is marched over the height
//! grid until it rises above the highest terrain; a point is hidden where terrain rises above
//! the line.

use crate::{GroundMap, Terrain};
use aerorect_raster::PixelMap;
use rayon::prelude::*;

/// Whether the line of sight from ground point `p` to the camera centre `c` passes below the
/// terrain, marched in horizontal steps of `step` metres up to the height `top`.
fn line_of_sight_blocked(terrain: &Terrain, p: [f64; 3], c: [f64; 3], step: f64, top: f64) -> bool {
    let d = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    let horizontal = d[0].hypot(d[1]);
    if horizontal < step || d[2] <= 0.0 {
        return false;
    }
    // Fraction of the way to the camera per step; stop once the line is above all terrain.
    let dt = step / horizontal;
    let t_end = ((top - p[2]) / d[2]).min(1.0);
    let mut t = dt;
    while t < t_end {
        let q = [p[0] + t * d[0], p[1] + t * d[1], p[2] + t * d[2]];
        if terrain.height_at(q[0], q[1]) > q[2] + 1e-3 {
            return true;
        }
        t += dt;
    }
    false
}

/// Which output pixels of `map` are hidden; `step` is the march's horizontal step (about half
/// the height grid's spacing) and `top` the highest terrain.
pub fn occlusion_mask(map: &GroundMap, step: f64, top: f64) -> Vec<bool> {
    let g = map.grid.size;
    let c = map.pose.centre;
    let mut hidden = vec![false; g.pixels()];
    hidden
        .par_chunks_mut(g.width.max(1))
        .enumerate()
        .for_each(|(r, row)| {
            for (col, h) in row.iter_mut().enumerate() {
                let [x, y] = map.grid.centre_of(col as f64, r as f64);
                let z = map.terrain.height_at(x, y);
                *h = line_of_sight_blocked(&map.terrain, [x, y, z], c, step, top);
            }
        });
    hidden
}

/// A map that has no source where `hidden` says so (nodata in the output).
#[derive(Debug, Clone)]
pub struct Visible {
    pub map: GroundMap,
    pub hidden: Vec<bool>,
}

impl PixelMap for Visible {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        let w = self.map.grid.size.width;
        let i = row as usize * w + col as usize;
        if self.hidden.get(i).copied().unwrap_or(false) {
            return None;
        }
        self.map.source_of(col, row)
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        self.map.source_row(row, col0, xs, ys);
        let w = self.map.grid.size.width;
        let start = (row * w + col0).min(self.hidden.len());
        let end = (start + xs.len()).min(self.hidden.len());
        for (i, &h) in self.hidden[start..end].iter().enumerate() {
            if h {
                (xs[i], ys[i]) = (f64::NAN, f64::NAN);
            }
        }
    }
}
