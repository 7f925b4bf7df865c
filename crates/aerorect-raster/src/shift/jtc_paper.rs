//! The JTC on the paper's joint image (see `jtc`): the only form for a binarised spectrum, and
//! the reference for the cross-spectrum form.

use super::fft2::Fft2;
use super::jtc::{JtcOptions, Plane, prepare};
use super::{ShiftError, ShiftEstimate, check_frame};
use rustfft::num_complex::Complex32;

pub(crate) struct PaperJtc {
    w: usize,
    h: usize,
    opts: JtcOptions,
    fft: Fft2,
    r: Vec<f32>,
    t: Vec<f32>,
    spec: Vec<Complex32>,
    power: Vec<f32>,
    sorted: Vec<f32>,
    /// The correlation plane around the cross terms: rows dy in -h/2..h/2 (index dy + h/2), columns w..5w.
    window: Vec<f32>,
}

impl PaperJtc {
    pub(crate) fn new(width: usize, height: usize, opts: JtcOptions) -> Self {
        let fft = Fft2::new(6 * width, 2 * height);
        let n = fft.spectrum_len();
        Self {
            w: width,
            h: height,
            opts,
            fft,
            r: vec![0.0; width * height],
            t: vec![0.0; width * height],
            spec: vec![Complex32::default(); n],
            power: vec![0.0; n],
            sorted: vec![0.0; n],
            window: vec![0.0; height * 4 * width],
        }
    }

    pub(crate) fn estimate(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        let (w, h) = (self.w, self.h);
        let mr = check_frame("reference", reference, w, h)?;
        let mt = check_frame("current", current, w, h)?;
        let (mut r, mut t) = (std::mem::take(&mut self.r), std::mem::take(&mut self.t));
        prepare(reference, mr, w, h, self.opts.laplacian, &mut r);
        prepare(current, mt, w, h, self.opts.laplacian, &mut t);
        let forward = self.one_way(&r, &t);
        let backward = self.one_way(&t, &r);
        (self.r, self.t) = (r, t);
        Ok(ShiftEstimate {
            dx: 0.5 * (forward.dx - backward.dx),
            dy: 0.5 * (forward.dy - backward.dy),
            confidence: forward.confidence.min(backward.confidence),
        })
    }

    /// The joint power spectrum, filtered and binarised as configured, into `spec` (real values).
    fn process_spectrum(&mut self) {
        let (hh, hw) = (self.fft.height(), self.fft.width() / 2 + 1);
        for (p, s) in self.power.iter_mut().zip(&self.spec) {
            *p = s.norm_sqr();
        }
        let values: &[f32] = if self.opts.spectral_filter {
            // E(u, v) = 2 P(u, v) - P(u - 1, v) - P(u + 1, v), with P(-u, -v) = P(u, v) at the ends.
            let p = &self.power;
            let at = |u: isize, v: usize| -> f32 {
                if u < 0 {
                    p[(-u) as usize * hh + (hh - v) % hh]
                } else if u as usize >= hw {
                    let m = 2 * (hw - 1) - u as usize;
                    p[m * hh + (hh - v) % hh]
                } else {
                    p[u as usize * hh + v]
                }
            };
            // The end columns through `at`; the others as contiguous runs (same arithmetic).
            for u in [0, hw - 1] {
                for v in 0..hh {
                    self.sorted[u * hh + v] =
                        2.0 * at(u as isize, v) - at(u as isize - 1, v) - at(u as isize + 1, v);
                }
            }
            for u in 1..hw - 1 {
                let (lo, mid, hi) = (&p[(u - 1) * hh..], &p[u * hh..], &p[(u + 1) * hh..]);
                let out = &mut self.sorted[u * hh..(u + 1) * hh];
                for (((o, &b), &a), &c) in out.iter_mut().zip(mid).zip(lo).zip(hi) {
                    *o = 2.0 * b - a - c;
                }
            }
            &self.sorted
        } else {
            &self.power
        };
        for (s, &e) in self.spec.iter_mut().zip(values) {
            *s = Complex32::new(e, 0.0);
        }
        if self.opts.binarize {
            // The median of a 1-in-8 subsample (every 8th value of the spectrum) as threshold.
            let mut n = 0;
            for (d, c) in self.sorted.iter_mut().zip(self.spec.iter().step_by(8)) {
                *d = c.re;
                n += 1;
            }
            let sample = &mut self.sorted[..n];
            let (_, median, _) = sample.select_nth_unstable_by(n / 2, f32::total_cmp);
            let median = *median;
            for s in self.spec.iter_mut() {
                s.re = if s.re > median { 1.0 } else { -1.0 };
            }
        }
    }

    /// The shift of prepared frame `t` relative to prepared frame `r` from one joint image.
    fn one_way(&mut self, r: &[f32], t: &[f32]) -> ShiftEstimate {
        let (w, h) = (self.w, self.h);
        self.fft.forward_rows(
            h,
            |row, buf| {
                buf.fill(0.0);
                buf[..w].copy_from_slice(&r[row * w..(row + 1) * w]);
                buf[2 * w..3 * w].copy_from_slice(&t[row * w..(row + 1) * w]);
            },
            &mut self.spec,
        );
        self.process_spectrum();
        // Keep correlation rows dy in -h/2..h/2 and columns w..5w (both cross terms).
        let (hh, half) = (2 * h, h / 2);
        let window = &mut self.window;
        self.fft.inverse_rows(
            &mut self.spec,
            |row| row < half || row >= hh - half,
            |row, data| {
                let wr = if row < half {
                    row + half
                } else {
                    row + half - hh
                };
                window[wr * 4 * w..(wr + 1) * 4 * w].copy_from_slice(&data[w..5 * w]);
            },
        );
        // Cross term at column 2w + dx (window column w + dx), row dy (window row dy + h/2);
        // its mirror at column 6w - 2w - dx = 4w - dx (window column 3w - dx), row -dy.
        let plane = Plane {
            data: &self.window,
            stride: 4 * w,
            rows: h,
        };
        let (x1, y1, p1) = plane.peak(0, 2 * w, self.opts.subpixel);
        let (x2, y2, p2) = plane.peak(2 * w, 4 * w, self.opts.subpixel);
        let dx = 0.5 * ((x1 - w as f64) + (3.0 * w as f64 - x2));
        let dy = 0.5 * ((y1 - half as f64) - (y2 - half as f64));
        let confidence = plane.confidence(x1, y1, p1.min(p2), 2 * w);
        ShiftEstimate { dx, dy, confidence }
    }
}
