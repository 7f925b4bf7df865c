//! The joint transform correlator (Li & Yang 2015, section 3.2 and 4).
//!
//! Geometry for frames of w x h: the joint image is 6w wide and 2h high; the reference occupies
//! columns 0..w and the current frame columns 2w..3w of rows 0..h (centres 2w apart, the rest
//! zero). Each term of the correlation plane spans (2w - 1) x (2h - 1), so the central term
//! (columns -w..w), the cross term at +(2w + dx, dy) (columns w..3w) and its mirror at
//! -(2w + dx, -dy) (columns 3w..5w) never overlap or wrap for |dx| < w/2... and |dy| < h/2.
//!
//! Steps: mean removal and optional Laplacian enhancement of each frame; the joint power
//! spectrum |FFT(joint)|^2; optionally the [-1 2 -1] filter along the separation axis (it
//! removes the smooth central-term spectrum and triples the fringes, whose period is 3 samples);
//! optionally binarisation (+1 above the median of the spectrum, estimated from every 8th
//! value, -1 below: the binary JTC); the
//! inverse FFT; the two cross peaks; a sub-pixel fit around each: the paper's 3 x 3 centroid,
//! a parabola, or (the default) a three-point Gaussian fit, which alone meets the paper's
//! 0.1 px at 4 dB on the shared scenes. The estimate is antisymmetrised: half the difference
//! of the shifts with the frames in both orders (see `estimate`).
//!
//! Two implementations of these steps (the joint geometry above is the definition of both):
//!
//! - Without binarisation every step is linear in the joint power spectrum
//!   |R + T c|^2 = |R|^2 + |T|^2 + conj(R) T c + R conj(T) conj(c) (R, T the frames' spectra on
//!   the joint grid, c the separation's phase ramp): the window around the cross peak is exactly
//!   the linear cross-correlation of the two prepared frames at lags (s, dy), |s| <= w, which the
//!   inverse transform of conj(R) T on a 2w x 2h grid gives without wrap-around, and the
//!   [-1 2 -1] filter along u is, in the plane, the weight 2 - 2 cos(2 pi x / 6w) at joint
//!   column x = 2w + s. The plane is even (the spectrum is real and even), so the mirror peak
//!   repeats the first one and is not computed. Two 2w x 2h forward transforms and one inverse
//!   per pair (the frames in the other order read the same plane reflected), against two
//!   6w x 2h forward transforms and two inverses for the joint image both ways: `cross`
//!   (module `jtc_cross`).
//! - Binarisation (a threshold at the median of the whole filtered joint spectrum, central term
//!   included) is not linear and has no cross-spectrum form: with `binarize` the joint image is
//!   transformed as the paper does (module `jtc_paper`). Tests hold the cross-spectrum form to
//!   the paper form's peak within 1e-6 px.

use super::jtc_cross::CrossJtc;
use super::jtc_paper::PaperJtc;
use super::{ShiftError, ShiftEstimate, ShiftEstimator, check_size, parabola_vertex};

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

/// Planned for one frame size; reuse it for every pair.
pub struct JointTransformCorrelator {
    engine: Engine,
}

enum Engine {
    Paper(Box<PaperJtc>),
    Cross(Box<CrossJtc>),
}

impl JointTransformCorrelator {
    /// The cross-spectrum form where the options allow it (no binarisation), else the paper's
    /// joint image.
    pub fn new(width: usize, height: usize, opts: JtcOptions) -> Result<Self, ShiftError> {
        check_size(width, height)?;
        let engine = if opts.binarize {
            Engine::Paper(Box::new(PaperJtc::new(width, height, opts)))
        } else {
            Engine::Cross(Box::new(CrossJtc::new(width, height, opts)))
        };
        Ok(Self { engine })
    }

    /// The paper's joint-image implementation whatever the options (the reference the
    /// cross-spectrum form is tested against; slower).
    pub fn new_joint_image(
        width: usize,
        height: usize,
        opts: JtcOptions,
    ) -> Result<Self, ShiftError> {
        check_size(width, height)?;
        Ok(Self {
            engine: Engine::Paper(Box::new(PaperJtc::new(width, height, opts))),
        })
    }
}

impl ShiftEstimator for JointTransformCorrelator {
    /// The antisymmetrised estimate (e(reference, current) - e(current, reference)) / 2: the
    /// binarised spectrum's background and the spectral filter's weight 2 - 2 cos(2 pi x / 6w)
    /// (not symmetric about the cross peak at 2w) pull the peak the same way whichever frame
    /// comes first, so the difference cancels them; a frame against itself gives exactly 0
    /// (one way alone gave up to 0.1 px on small frames).
    fn estimate(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        match &mut self.engine {
            Engine::Paper(p) => p.estimate(reference, current),
            Engine::Cross(c) => c.estimate(reference, current),
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
        super::jtc_cross::prepared_row(src, w, h, y, mean, laplacian, out);
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
