//! Area-weighted averaging (`Interp::Average`), GDAL's `-r average` and OpenCV's `INTER_AREA`.
//!
//! Each destination pixel's footprint (a unit square about its centre) is carried into the source
//! by the map's local Jacobian J, estimated by differences of the source positions of the
//! neighbouring destination pixels (central where both neighbours have a source, one-sided
//! otherwise). The footprint is approximated by the axis-aligned bounding box of that
//! parallelogram: half-widths hx = (|J00| + |J01|) / 2, hy = (|J10| + |J11|) / 2, each at least
//! 0.5 (so upsampling degrades to bilinear: a one-pixel box straddling four pixels). Every source
//! pixel is weighted by the area its own footprint shares with the box; pixels outside the image
//! are left out and the weights renormalised. For an axis-aligned scale (OpenCV's resize) the box
//! is the exact footprint and the result is OpenCV's INTER_AREA; under a rotation the box is larger
//! than the footprint (up to sqrt(2) in each direction at 45 degrees): slightly more blur.
//!
//! Validity follows the other kernels: the destination pixel has a value when its centre maps
//! inside the source footprints (-0.5 <= x < W - 0.5), else nodata and alpha 0.
//!
//! Cost: about (2 hx + 1)(2 hy + 1) taps a pixel and band, so O(scale^2): 25 at 4x.

use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use rayon::prelude::*;

/// About this many destination pixels per rayon task (as the other kernels).
const PIXELS_PER_TASK: usize = 32 * 1024;

/// Source positions of a destination row and its neighbours, and the per-axis weights.
struct Scratch {
    prev: [Vec<f64>; 2],
    cur: [Vec<f64>; 2],
    next: [Vec<f64>; 2],
    wx: Vec<f32>,
    wy: Vec<f32>,
}

impl Scratch {
    fn new(width: usize) -> Self {
        let v = || [vec![0.0; width + 1], vec![0.0; width + 1]];
        Self {
            prev: v(),
            cur: v(),
            next: v(),
            wx: Vec::new(),
            wy: Vec::new(),
        }
    }
}

/// Fills `dst` by area averaging; `dst` has the source's bands plus alpha when `alpha`.
pub(crate) fn run<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    nodata: T,
    alpha: bool,
    dst: &mut Raster<T>,
) {
    let width = dst.width();
    let rows_per_task = (PIXELS_PER_TASK / width).max(1);
    super::types::row_strips(dst, rows_per_task)
        .into_par_iter()
        .enumerate()
        .for_each_init(
            || Scratch::new(width),
            |s, (t, mut chunks)| {
                let first_row = t * rows_per_task;
                let rows = chunks[0].len() / width;
                for r in 0..rows {
                    fill_positions(map, first_row + r, width, s);
                    let row = RowOut {
                        start: r * width,
                        width,
                        alpha,
                        nodata,
                    };
                    average_row(src, s, &mut chunks, row);
                }
            },
        );
}

/// Source positions of rows `row - 1`, `row`, `row + 1` (columns 0..=width; `prev` unused on
/// row 0).
fn fill_positions<M: PixelMap>(map: &M, row: usize, width: usize, s: &mut Scratch) {
    let [cx, cy] = &mut s.cur;
    map.source_row(row, 0, cx, cy);
    let [nx, ny] = &mut s.next;
    map.source_row(row + 1, 0, &mut nx[..width], &mut ny[..width]);
    if row > 0 {
        let [px, py] = &mut s.prev;
        map.source_row(row - 1, 0, &mut px[..width], &mut py[..width]);
    } else {
        s.prev[0].fill(f64::NAN);
        s.prev[1].fill(f64::NAN);
    }
}

/// The derivative at index `c` from its neighbours: central when both are finite, else
/// one-sided, else NaN.
fn derivative(before: f64, here: f64, after: f64) -> f64 {
    let central = 0.5 * (after - before);
    if central.is_finite() {
        return central;
    }
    let forward = after - here;
    if forward.is_finite() {
        return forward;
    }
    here - before
}

/// Half-widths (hx, hy) of the box about destination pixel `c` of the current row.
fn half_widths(s: &Scratch, c: usize) -> (f64, f64) {
    let axis = |a: usize| {
        let row = &s.cur[a];
        let before = if c > 0 { row[c - 1] } else { f64::NAN };
        let d_col = derivative(before, row[c], row[c + 1]);
        let d_row = derivative(s.prev[a][c], row[c], s.next[a][c]);
        let h = 0.5 * (d_col.abs() + d_row.abs());
        if h.is_finite() { h.max(0.5) } else { 0.5 }
    };
    (axis(0), axis(1))
}

/// Overlap weights of [centre - h, centre + h] with pixels [i - 0.5, i + 0.5], i in 0..n: the box
/// is clipped to the image; returns the first pixel and fills `w` (no zero weights at the ends).
fn axis_weights(centre: f64, h: f64, n: usize, w: &mut Vec<f32>) -> usize {
    let lo = (centre - h).max(-0.5);
    let hi = (centre + h).min(n as f64 - 0.5);
    // The pixel whose footprint [i - 0.5, i + 0.5) holds lo; the last one starting below hi.
    let first = ((lo + 0.5).floor().max(0.0) as usize).min(n - 1);
    let last = ((hi + 0.5).ceil().max(1.0) as usize - 1).clamp(first, n - 1);
    w.clear();
    w.resize(last - first + 1, 1.0);
    if first == last {
        w[0] = (hi - lo) as f32;
    } else {
        w[0] = (first as f64 + 0.5 - lo) as f32;
        w[last - first] = (hi - (last as f64 - 0.5)) as f32;
    }
    first
}

struct RowOut<T> {
    start: usize,
    width: usize,
    alpha: bool,
    nodata: T,
}

/// Averages one destination row into `chunks` (one per band, alpha last).
fn average_row<T: Sample>(src: &Raster<T>, s: &mut Scratch, chunks: &mut [&mut [T]], o: RowOut<T>) {
    let (w, h) = (src.width(), src.height());
    let bands = src.bands();
    let (mut last_y, mut y0, mut wy_sum) = ((f64::NAN, f64::NAN), 0, 0.0f32);
    for c in 0..o.width {
        let (x, y) = (s.cur[0][c], s.cur[1][c]);
        let inside = x >= -0.5 && x < w as f64 - 0.5 && y >= -0.5 && y < h as f64 - 0.5;
        let idx = o.start + c;
        if !inside {
            for chunk in chunks.iter_mut().take(bands) {
                chunk[idx] = o.nodata;
            }
            if o.alpha {
                chunks[bands][idx] = T::default();
            }
            continue;
        }
        let (hx, hy) = half_widths(s, c);
        let x0 = axis_weights(x, hx, w, &mut s.wx);
        if (y, hy) != last_y {
            // Along an axis-aligned row the vertical weights repeat: computed once.
            y0 = axis_weights(y, hy, h, &mut s.wy);
            wy_sum = s.wy.iter().sum::<f32>();
            last_y = (y, hy);
        }
        let total = s.wx.iter().sum::<f32>() * wy_sum;
        for (b, chunk) in chunks.iter_mut().take(bands).enumerate() {
            let plane = src.plane(b);
            let mut acc = 0.0f32;
            for (j, &wy) in s.wy.iter().enumerate() {
                let row = &plane[(y0 + j) * w + x0..];
                let mut sum = 0.0f32;
                for (&wx, p) in s.wx.iter().zip(row) {
                    sum += wx * p.to_f32();
                }
                acc += wy * sum;
            }
            chunk[idx] = T::from_f32(acc / total);
        }
        if o.alpha {
            chunks[bands][idx] = T::OPAQUE;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_are_the_overlaps_and_clip_to_the_image() {
        let mut w = Vec::new();
        // [1.5 - 2, 1.5 + 2] = [-0.5, 3.5]: pixels 0..=3 fully.
        assert_eq!(axis_weights(1.5, 2.0, 10, &mut w), 0);
        assert_eq!(w, vec![1.0; 4]);
        // [2.25 - 1.25, 2.25 + 1.25] = [1, 3.5]: half of 1, then 2, 3 fully.
        assert_eq!(axis_weights(2.25, 1.25, 10, &mut w), 1);
        assert_eq!(w, vec![0.5, 1.0, 1.0]);
        // Past the right edge: [8, 10] clipped to [8, 9.5] over pixels 8, 9.
        assert_eq!(axis_weights(9.0, 1.0, 10, &mut w), 8);
        assert_eq!(w, vec![0.5, 1.0]);
        // Starting exactly on a pixel edge: [0.5, 2.5] is pixels 1, 2, no zero weight for 0.
        assert_eq!(axis_weights(1.5, 1.0, 10, &mut w), 1);
        assert_eq!(w, vec![1.0, 1.0]);
    }

    #[test]
    fn derivative_falls_back_to_one_side() {
        assert_eq!(derivative(1.0, 2.0, 4.0), 1.5);
        assert_eq!(derivative(f64::NAN, 2.0, 4.0), 2.0);
        assert_eq!(derivative(1.0, 2.0, f64::NAN), 1.0);
        assert!(derivative(f64::NAN, 2.0, f64::NAN).is_nan());
    }
}
