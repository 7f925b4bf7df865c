//! What both forms of the joint transform correlator share (see `jtc`): the options, the
//! prepared frames (mean removed, optional Laplacian) and the window of the correlation plane
//! with its peak search, sub-pixel fit and confidence.

use super::parabola_vertex;

/// How the integer peak is refined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SubPixel {
    /// Intensity centroid over the 3 x 3 neighbourhood, values above its minimum (the paper).
    Centroid,
    /// Vertex of the parabola through the peak and its two neighbours, per axis.
    Parabola,
    /// Three-point Gaussian fit per axis (a parabola through the logarithms) of the values above
    /// the minimum of the 5 x 5 neighbourhood: the most accurate here (see the crate's notes).
    #[default]
    Gaussian,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JtcOptions {
    pub laplacian: bool,
    pub spectral_filter: bool,
    pub binarize: bool,
    pub subpixel: SubPixel,
}

impl Default for JtcOptions {
    /// The paper's full processing, with the Gaussian peak fit (the paper's centroid is
    /// `SubPixel::Centroid`).
    fn default() -> Self {
        Self {
            laplacian: true,
            spectral_filter: true,
            binarize: true,
            subpixel: SubPixel::Gaussian,
        }
    }
}

/// Mean removal, then the optional Laplacian (4-neighbour, edges repeated).
pub(super) fn prepare(
    src: &[f32],
    mean: f32,
    w: usize,
    h: usize,
    laplacian: bool,
    dst: &mut [f32],
) {
    for (y, out) in dst.chunks_exact_mut(w).take(h).enumerate() {
        prepared_row(src, w, h, y, mean, laplacian, out);
    }
}

/// A window of the correlation plane: `rows` rows of `stride` values; row r is dy = r - h/2.
pub(super) struct Plane<'a> {
    pub data: &'a [f32],
    pub stride: usize,
    pub rows: usize,
}

impl Plane<'_> {
    fn at(&self, x: usize, y: usize) -> f64 {
        self.data[y * self.stride + x] as f64
    }

    /// Integer peak in columns `c0..c1` (rows 1..rows - 1) and its sub-pixel position
    /// (column, row) and height.
    pub(super) fn peak(&self, c0: usize, c1: usize, subpixel: SubPixel) -> (f64, f64, f32) {
        let (bx, by, best) = self.peak_index(c0, c1);
        let (fx, fy) = self.sub_pixel(bx, by, subpixel);
        (bx as f64 + fx, by as f64 + fy, best)
    }

    /// The first of the largest values in rows 1..rows - 1, columns max(c0, 1)..min(c1,
    /// stride - 1) in row-major order (as a scan with `>` finds it; NaN never): its column, row
    /// and value. Each row's largest value comes first, sixteen running maxima at a time
    /// (vectorised; a running index is not), then its column only where it beats the best so far.
    fn peak_index(&self, c0: usize, c1: usize) -> (usize, usize, f32) {
        let (mut best, mut bx, mut by) = (f32::NEG_INFINITY, c0, 0);
        let x0 = c0.max(1);
        let x1 = c1.min(self.stride - 1).max(x0);
        for y in 1..self.rows.saturating_sub(1) {
            let row = &self.data[y * self.stride + x0..y * self.stride + x1];
            let m = row_max(row);
            if m > best {
                let x = row.iter().position(|&v| v == m).unwrap_or(0);
                (best, bx, by) = (m, x0 + x, y);
            }
        }
        (bx, by, best)
    }

    /// The sub-pixel offset of the peak at (bx, by), 1 <= bx, by inside the window.
    fn sub_pixel(&self, bx: usize, by: usize, subpixel: SubPixel) -> (f64, f64) {
        let floor = |r: usize| {
            let mut lo = f64::INFINITY;
            for y in by.saturating_sub(r)..=(by + r).min(self.rows - 1) {
                for x in bx.saturating_sub(r)..=(bx + r).min(self.stride - 1) {
                    lo = lo.min(self.at(x, y));
                }
            }
            lo
        };
        let axes = |f: &dyn Fn(f64, f64, f64) -> f64| {
            (
                f(self.at(bx - 1, by), self.at(bx, by), self.at(bx + 1, by)),
                f(self.at(bx, by - 1), self.at(bx, by), self.at(bx, by + 1)),
            )
        };
        match subpixel {
            SubPixel::Parabola => axes(&parabola_vertex),
            SubPixel::Gaussian => {
                let lo = floor(2);
                let eps = 1e-3 * (self.at(bx, by) - lo);
                let ln = |v: f64| (v - lo + eps).ln();
                axes(&|a, b, c| parabola_vertex(ln(a), ln(b), ln(c)))
            }
            SubPixel::Centroid => {
                let lo = floor(1);
                let (mut s, mut sx, mut sy) = (0.0, 0.0, 0.0);
                for dy in -1i32..=1 {
                    for dx in -1i32..=1 {
                        let m = self.at((bx as i32 + dx) as usize, (by as i32 + dy) as usize) - lo;
                        (s, sx, sy) = (s + m, sx + m * dx as f64, sy + m * dy as f64);
                    }
                }
                if s > 0.0 {
                    (sx / s, sy / s)
                } else {
                    (0.0, 0.0)
                }
            }
        }
    }

    /// 1 - (highest value outside the 5 x 5 around the peak) / peak, over columns 0..cols.
    pub(super) fn confidence(&self, px: f64, py: f64, peak: f32, cols: usize) -> f64 {
        let (px, py) = (px.round() as isize, py.round() as isize);
        let mut second = f32::NEG_INFINITY;
        for y in 0..self.rows {
            for x in 0..cols {
                if (x as isize - px).abs() > 2 || (y as isize - py).abs() > 2 {
                    second = second.max(self.data[y * self.stride + x]);
                }
            }
        }
        if peak > 0.0 {
            (1.0 - (second.max(0.0) / peak) as f64).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// The largest value of `row` (NaN never, as with `>`), or -inf.
fn row_max(row: &[f32]) -> f32 {
    let mut acc = [f32::NEG_INFINITY; 16];
    let chunks = row.chunks_exact(16);
    let rest = chunks.remainder();
    for c in chunks {
        for (a, &v) in acc.iter_mut().zip(c) {
            if v > *a {
                *a = v;
            }
        }
    }
    for &v in rest {
        if v > acc[0] {
            acc[0] = v;
        }
    }
    acc.iter()
        .fold(f32::NEG_INFINITY, |m, &a| if a > m { a } else { m })
}

/// Row y of the prepared frame: mean removed, or the 4-neighbour Laplacian (edges repeated).
pub(super) fn prepared_row(
    src: &[f32],
    w: usize,
    h: usize,
    y: usize,
    mean: f32,
    laplacian: bool,
    out: &mut [f32],
) {
    let row = &src[y * w..(y + 1) * w];
    if !laplacian {
        for (o, s) in out.iter_mut().zip(row) {
            *o = s - mean;
        }
        return;
    }
    let up = &src[y.saturating_sub(1) * w..][..w];
    let down = &src[(y + 1).min(h - 1) * w..][..w];
    let at = |x: usize| {
        let sum = row[x.saturating_sub(1)] + row[(x + 1).min(w - 1)] + up[x] + down[x];
        4.0 * row[x] - sum
    };
    // The interior as straight runs (the same sums in the same order), the ends repeated.
    let inner = out[1..w - 1]
        .iter_mut()
        .zip(row.iter().zip(&row[1..]).zip(&row[2..]))
        .zip(up[1..].iter().zip(&down[1..]));
    for ((o, ((&l, &c), &r)), (&u, &d)) in inner {
        *o = 4.0 * c - (l + r + u + d);
    }
    out[0] = at(0);
    out[w - 1] = at(w - 1);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The peak search against a plain scan with `>` (the first of the largest values in
    /// row-major order), on planes with ties, a few integer levels so that they are common.
    #[test]
    fn the_peak_is_the_first_of_the_largest() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for case in 0..400 {
            let (stride, rows) = (rng.random_range(3..70), rng.random_range(3..12));
            let levels = if case % 2 == 0 { 3 } else { 1000 };
            let data: Vec<f32> = (0..stride * rows)
                .map(|_| rng.random_range(0..levels) as f32 - 1.0)
                .collect();
            let plane = Plane {
                data: &data,
                stride,
                rows,
            };
            let (c0, c1) = (rng.random_range(0..stride), rng.random_range(0..stride + 3));
            let (mut best, mut bx, mut by) = (f32::NEG_INFINITY, c0, 0);
            for y in 1..rows - 1 {
                for x in c0.max(1)..c1.min(stride - 1) {
                    if data[y * stride + x] > best {
                        (best, bx, by) = (data[y * stride + x], x, y);
                    }
                }
            }
            assert_eq!(plane.peak_index(c0, c1), (bx, by, best), "case {case}");
        }
    }
}
