//! The JTC in its cross-spectrum form (see `jtc`): without binarisation the joint image's window
//! around the cross peak is the frames' linear cross-correlation, weighted by the spectral
//! filter's 2 - 2 cos(2 pi x / 6w) at the joint column x; computed from 2w x 2h transforms.
//!
//! Tracking: the spectrum of the last `current` frame is kept, and when the next call's
//! `reference` is that same frame (bit for bit) it is reused instead of transformed again.

use super::fft2::Fft2;
use super::jtc_common::{JtcOptions, Plane, prepared_row};
use super::pair::PairSpectra;
use super::{ShiftError, ShiftEstimate};
use rustfft::num_complex::Complex32;
use std::f64::consts::PI;

pub(crate) struct CrossJtc {
    w: usize,
    h: usize,
    opts: JtcOptions,
    fft: Fft2,
    /// The frames' spectra, the current one kept for the next pair.
    pair: PairSpectra,
    /// conj(R) T, destroyed by the inverse transform.
    work: Vec<Complex32>,
    /// The linear cross-correlation k(s, dy) for s in -w..=w (column s + w) and dy in
    /// -h/2..=h/2 (row dy + h/2).
    window: Vec<f32>,
    /// One way's weighted window: h rows of 2w + 1 (the paper form's window, first cross term).
    plane: Vec<f32>,
    /// The spectral filter's weight per window column (1 without the filter).
    weight: Vec<f32>,
}

impl CrossJtc {
    pub(crate) fn new(width: usize, height: usize, opts: JtcOptions) -> Self {
        let fft = Fft2::new(2 * width, 2 * height);
        let n = fft.spectrum_len();
        let cols = 2 * width + 1;
        let weight = (0..cols)
            .map(|c| {
                if opts.spectral_filter {
                    // Joint column x = 2w + s = w + c.
                    let x = (width + c) as f64;
                    (2.0 - 2.0 * (2.0 * PI * x / (6 * width) as f64).cos()) as f32
                } else {
                    1.0
                }
            })
            .collect();
        Self {
            w: width,
            h: height,
            opts,
            fft,
            pair: PairSpectra::new(n, width, height),
            work: vec![Complex32::default(); n],
            window: vec![0.0; (2 * (height / 2) + 1) * cols],
            plane: vec![0.0; height * cols],
            weight,
        }
    }

    pub(crate) fn estimate(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        let (w, h) = (self.w, self.h);
        let mut pair = std::mem::take(&mut self.pair);
        let checked = pair.update((reference, current), (w, h), |f, m, out| {
            self.transform(f, m, out)
        });
        self.pair = pair;
        checked?;
        self.correlate();
        let forward = self.one_way(false);
        let backward = self.one_way(true);
        Ok(ShiftEstimate {
            dx: 0.5 * (forward.dx - backward.dx),
            dy: 0.5 * (forward.dy - backward.dy),
            confidence: forward.confidence.min(backward.confidence),
        })
    }

    /// The 2w x 2h spectrum of the prepared frame (mean removed, optional Laplacian), zero
    /// padded.
    fn transform(&mut self, frame: &[f32], mean: f32, spec: &mut [Complex32]) {
        let (w, h, laplacian) = (self.w, self.h, self.opts.laplacian);
        self.fft.forward_rows(
            h,
            |y, buf| {
                let (out, pad) = buf.split_at_mut(w);
                pad.fill(0.0);
                prepared_row(frame, w, h, y, mean, laplacian, out);
            },
            spec,
        );
    }

    /// The window of the linear cross-correlation from conj(R) T.
    fn correlate(&mut self) {
        let (w, h, half) = (self.w, self.h, self.h / 2);
        for ((q, r), t) in self.work.iter_mut().zip(&self.pair.r).zip(&self.pair.t) {
            *q = r.conj() * t;
        }
        let (hh, cols) = (2 * h, 2 * w + 1);
        let window = &mut self.window;
        self.fft.inverse_rows(
            &mut self.work,
            |row| row <= half || row >= hh - half,
            |row, data| {
                let wr = if row <= half {
                    row + half
                } else {
                    row + half - hh
                };
                let out = &mut window[wr * cols..(wr + 1) * cols];
                // Column c is lag s = c - w, at index s mod 2w of the plane.
                out[..w].copy_from_slice(&data[w..]);
                out[w..2 * w].copy_from_slice(&data[..w]);
                out[2 * w] = data[w];
            },
        );
    }

    /// The shift of the current frame relative to the reference (`backward`: the reverse), from
    /// the first cross term of the joint image that order would make.
    fn one_way(&mut self, backward: bool) -> ShiftEstimate {
        let (w, h, half) = (self.w, self.h, self.h / 2);
        let cols = 2 * w + 1;
        for y in 0..h {
            let out = &mut self.plane[y * cols..(y + 1) * cols];
            if backward {
                // The frames swapped: k(-s, -dy), at column 2w - c and row 2 (h/2) - y.
                let src = &self.window[(2 * half - y) * cols..(2 * half - y + 1) * cols];
                for ((o, k), g) in out.iter_mut().zip(src.iter().rev()).zip(&self.weight) {
                    *o = g * k;
                }
            } else {
                let src = &self.window[y * cols..(y + 1) * cols];
                for ((o, k), g) in out.iter_mut().zip(src).zip(&self.weight) {
                    *o = g * k;
                }
            }
        }
        let plane = Plane {
            data: &self.plane,
            stride: cols,
            rows: h,
        };
        let (x, y, p) = plane.peak(0, 2 * w, self.opts.subpixel);
        ShiftEstimate {
            dx: x - w as f64,
            dy: y - half as f64,
            confidence: plane.confidence(x, y, p, 2 * w),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::JointTransformCorrelator;
    use super::super::jtc_common::SubPixel;
    use super::super::jtc_oracle::{joint_image_f64, pairs};
    use super::super::{ShiftEstimate, ShiftEstimator};
    use super::*;

    fn all_linear_options() -> Vec<JtcOptions> {
        let mut v = vec![];
        for subpixel in [SubPixel::Gaussian, SubPixel::Centroid, SubPixel::Parabola] {
            for (laplacian, spectral_filter) in
                [(true, true), (true, false), (false, true), (false, false)]
            {
                v.push(JtcOptions {
                    laplacian,
                    spectral_filter,
                    binarize: false,
                    subpixel,
                });
            }
        }
        v
    }

    /// Every option without binarisation, on noisy textured pairs: the cross-spectrum form's
    /// peak is the joint image's (the f64 oracle above) to 1e-6 px with the Laplacian (sharp
    /// peaks; measured: 1.5e-7 at most), to 2e-5 px without it (broad peaks, where the f32 joint
    /// image `new_joint_image` is as far: 1e-5 measured); confidences agree to 1e-4.
    #[test]
    fn the_cross_spectrum_form_finds_the_joint_images_peak() {
        let (mut worst_cross, mut worst_paper) = (0.0f64, 0.0f64);
        for (w, h) in [(64, 64), (96, 80), (128, 128)] {
            for opts in all_linear_options() {
                let mut paper = JointTransformCorrelator::new_joint_image(w, h, opts).unwrap();
                let mut cross = JointTransformCorrelator::new(w, h, opts).unwrap();
                for (r, t) in pairs(w, h) {
                    let (ox, oy) = joint_image_f64(&r, &t, w, h, opts);
                    let a = paper.estimate(&r, &t).unwrap();
                    let b = cross.estimate(&r, &t).unwrap();
                    let dc = (ox - b.dx).abs().max((oy - b.dy).abs());
                    let dp = (ox - a.dx).abs().max((oy - a.dy).abs());
                    (worst_cross, worst_paper) = (worst_cross.max(dc), worst_paper.max(dp));
                    // Without the Laplacian the correlation peak of these smooth scenes is
                    // broad (its neighbours within 1 % of it): an f32 plane's rounding alone
                    // moves the fit by ~1e-5 px, in either form.
                    let tol = if opts.laplacian { 1e-6 } else { 2e-5 };
                    assert!(dc < tol, "{w}x{h} {opts:?}: ({ox}, {oy}) vs {b:?}");
                    assert!(dp < 2e-5, "{w}x{h} {opts:?}: ({ox}, {oy}) vs {a:?}");
                    assert!((a.confidence - b.confidence).abs() < 1e-4, "{a:?} vs {b:?}");
                }
            }
        }
        eprintln!(
            "worst difference from the f64 joint image: cross-spectrum {worst_cross:e} px, f32 joint image {worst_paper:e} px"
        );
    }

    /// A track (each frame against the previous one, the previous spectrum reused) gives what a
    /// fresh estimator gives for each pair.
    #[test]
    fn reusing_the_previous_spectrum_changes_nothing() {
        let (w, h) = (64, 48);
        let frames: Vec<Vec<f32>> = pairs(w, h).into_iter().flat_map(|(r, t)| [r, t]).collect();
        let opts = JtcOptions {
            binarize: false,
            ..JtcOptions::default()
        };
        let mut track = CrossJtc::new(w, h, opts);
        for pair in frames.windows(2) {
            let reused: ShiftEstimate = track.estimate(&pair[0], &pair[1]).unwrap();
            let fresh = CrossJtc::new(w, h, opts)
                .estimate(&pair[0], &pair[1])
                .unwrap();
            assert_eq!(reused, fresh);
        }
        // A bad current frame does not leave a stale spectrum behind.
        let bad = vec![1.0; w * h];
        assert!(track.estimate(&frames[0], &bad).is_err());
        let again = track.estimate(&frames[2], &frames[3]).unwrap();
        let fresh = CrossJtc::new(w, h, opts)
            .estimate(&frames[2], &frames[3])
            .unwrap();
        assert_eq!(again, fresh);
    }
}
