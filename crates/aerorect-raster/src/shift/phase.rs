//! Cross-correlation in the frequency domain, optionally phase-normalised (classic phase
//! correlation), with the sub-pixel peak found by Newton's method on the continuous DFT
//! correlation c(x, y) = sum_k Q_k exp(+2 pi i k.(x, y) / n): the limit of the upsampled DFT of
//! Guizar-Sicairos et al. (2008) as the upsampling factor grows without bound.

use super::fft2::Fft2;
use super::{
    ShiftError, ShiftEstimate, ShiftEstimator, check_frame, check_size, parabola_vertex, signed,
};
use rustfft::num_complex::Complex32;
use std::f64::consts::PI;

/// How the cross-power spectrum is weighted before the inverse transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Weighting {
    /// Plain cross-correlation (the maximum-likelihood choice in white noise).
    #[default]
    None,
    /// Phase correlation: every frequency weighted by 1 / |R* T|.
    Phase,
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PhaseOptions {
    pub weighting: Weighting,
    /// Multiply both frames by a Hann window before the transform (against edge effects).
    pub window: bool,
}

/// Planned for one frame size; reuse it for every pair.
pub struct PhaseCorrelator {
    w: usize,
    h: usize,
    opts: PhaseOptions,
    fft: Fft2,
    /// Hann weights per column and per row of the current frame's window (moved by the
    /// first estimate on the second pass).
    win_x: Vec<f32>,
    win_y: Vec<f32>,
    spec_r: Vec<Complex32>,
    q: Vec<Complex32>,
    /// Scratch for the inverse transform (it destroys its input).
    work: Vec<Complex32>,
    plane: Vec<f32>,
    // Newton workspace: per column u, the v-sums and their first and second v-derivatives.
    ex: Vec<(f64, f64)>,
    ey: Vec<(f64, f64)>,
    /// 2 pi k_v / h for every row v (signed frequency).
    kv: Vec<f64>,
}

impl PhaseCorrelator {
    pub fn new(width: usize, height: usize, opts: PhaseOptions) -> Result<Self, ShiftError> {
        check_size(width, height)?;
        let fft = Fft2::new(width, height);
        let n = fft.spectrum_len();
        Ok(Self {
            w: width,
            h: height,
            opts,
            fft,
            win_x: hann_table(width, 0.0),
            win_y: hann_table(height, 0.0),
            spec_r: vec![Complex32::default(); n],
            q: vec![Complex32::default(); n],
            work: vec![Complex32::default(); n],
            plane: vec![0.0; width * height],
            ex: vec![(0.0, 0.0); width / 2 + 1],
            ey: vec![(0.0, 0.0); height],
            kv: (0..height)
                .map(|v| 2.0 * PI * signed(v, height) / height as f64)
                .collect(),
        })
    }

    /// Forward transform of a mean-removed frame, windowed by the Hann window moved by
    /// `shift` (the reference uses (0, 0)).
    fn transform(&mut self, frame: &[f32], mean: f32, into_q: bool, shift: (f64, f64)) {
        let (w, use_window) = (self.w, self.opts.window);
        if use_window {
            fill_hann(&mut self.win_x, shift.0);
            fill_hann(&mut self.win_y, shift.1);
        }
        let (wx, wy) = (&self.win_x, &self.win_y);
        let fill = |r: usize, buf: &mut [f32]| {
            for (x, b) in buf.iter_mut().enumerate() {
                let v = frame[r * w + x] - mean;
                *b = if use_window { v * wx[x] * wy[r] } else { v };
            }
        };
        let out = if into_q {
            &mut self.q
        } else {
            &mut self.spec_r
        };
        self.fft.forward_rows(self.h, fill, out);
    }

    /// c, its gradient and Hessian at (x, y) (the Hermitian half spectrum counted twice).
    fn newton_terms(&mut self, x: f64, y: f64) -> [f64; 6] {
        let (w, h) = (self.w, self.h);
        for (u, e) in self.ex.iter_mut().enumerate() {
            let (s, c) = (2.0 * PI * u as f64 * x / w as f64).sin_cos();
            *e = (c, s);
        }
        for (e, k) in self.ey.iter_mut().zip(&self.kv) {
            let (s, c) = (k * y).sin_cos();
            *e = (c, s);
        }
        let mut t = [0.0f64; 6]; // c, cx, cy, cxx, cyy, cxy
        for u in 0..=w / 2 {
            let weight = if u == 0 || (w % 2 == 0 && u == w / 2) {
                1.0
            } else {
                2.0
            };
            let col = &self.q[u * h..(u + 1) * h];
            // a0 = sum_v Q e_y, a1 = sum_v Q e_y (2 pi i k_v / h), a2 = sum_v Q e_y (2 pi i k_v / h)^2
            let (mut a0, mut a1, mut a2) = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0));
            for ((qv, e), &k) in col.iter().zip(&self.ey).zip(&self.kv) {
                let (re, im) = (
                    qv.re as f64 * e.0 - qv.im as f64 * e.1,
                    qv.re as f64 * e.1 + qv.im as f64 * e.0,
                );
                a0 = (a0.0 + re, a0.1 + im);
                a1 = (a1.0 - k * im, a1.1 + k * re); // times i k
                a2 = (a2.0 - k * k * re, a2.1 - k * k * im); // times -k^2
            }
            let (c, s) = self.ex[u];
            let kx = 2.0 * PI * u as f64 / w as f64;
            let re = |a: (f64, f64)| a.0 * c - a.1 * s; // Re(e_x a)
            let im = |a: (f64, f64)| a.0 * s + a.1 * c; // Im(e_x a)
            t[0] += weight * re(a0);
            t[1] += weight * -kx * im(a0);
            t[2] += weight * re(a1);
            t[3] += weight * -kx * kx * re(a0);
            t[4] += weight * re(a2);
            t[5] += weight * -kx * im(a1);
        }
        t
    }

    /// Newton's method from (x, y) to the nearest maximum of the continuous correlation.
    fn refine(&mut self, mut x: f64, mut y: f64) -> (f64, f64, f64) {
        let mut c = 0.0;
        for _ in 0..10 {
            let [c0, cx, cy, cxx, cyy, cxy] = self.newton_terms(x, y);
            c = c0;
            let det = cxx * cyy - cxy * cxy;
            if !(cxx < 0.0 && det > 0.0) {
                break; // not at a concave point: keep the starting estimate
            }
            let dx = -(cyy * cx - cxy * cy) / det;
            let dy = -(cxx * cy - cxy * cx) / det;
            let (dx, dy) = (dx.clamp(-0.25, 0.25), dy.clamp(-0.25, 0.25));
            x += dx;
            y += dy;
            if dx.abs().max(dy.abs()) < 1e-6 {
                break;
            }
        }
        (x, y, c)
    }
}

impl PhaseCorrelator {
    /// Q = conj(R) T (weighted as configured) from the two spectra; returns sum |R|^2, sum |T|^2.
    fn cross_power(&mut self) -> (f64, f64) {
        let (w, h) = (self.w, self.h);
        let (mut er, mut et) = (0.0f64, 0.0f64);
        for (i, (q, r)) in self.q.iter_mut().zip(&self.spec_r).enumerate() {
            let col = i / h;
            let weight = if col == 0 || (w % 2 == 0 && col == w / 2) {
                1.0
            } else {
                2.0
            };
            er += weight * r.norm_sqr() as f64;
            et += weight * q.norm_sqr() as f64;
            let p = r.conj() * *q;
            *q = match self.opts.weighting {
                Weighting::None => p,
                Weighting::Phase => {
                    let m = p.norm();
                    if m > 0.0 { p / m } else { Complex32::default() }
                }
            };
        }
        (er, et)
    }

    /// The integer peak of the correlation plane, refined by a parabola per axis (signed shift).
    fn coarse_peak(&mut self) -> (f64, f64) {
        let (w, h) = (self.w, self.h);
        // Transform a copy: Q is kept for the Newton refinement.
        self.work.copy_from_slice(&self.q);
        let plane = &mut self.plane;
        self.fft.inverse_rows(
            &mut self.work,
            |_| true,
            |r, row| plane[r * w..(r + 1) * w].copy_from_slice(row),
        );
        let (mut best, mut bi) = (f32::NEG_INFINITY, 0);
        for (i, &v) in self.plane.iter().enumerate() {
            if v > best {
                (best, bi) = (v, i);
            }
        }
        let (px, py) = ((bi % w) as isize, (bi / w) as isize);
        let at = |x: isize, y: isize| {
            self.plane[y.rem_euclid(h as isize) as usize * w + x.rem_euclid(w as isize) as usize]
                as f64
        };
        let fx = parabola_vertex(at(px - 1, py), at(px, py), at(px + 1, py));
        let fy = parabola_vertex(at(px, py - 1), at(px, py), at(px, py + 1));
        (signed(px as usize, w) + fx, signed(py as usize, h) + fy)
    }
}

impl ShiftEstimator for PhaseCorrelator {
    /// With a window, two passes: the second windows the current frame with the window moved
    /// by the first estimate, which removes the window's pull towards zero shift.
    fn estimate(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        let (w, h) = (self.w, self.h);
        let mr = check_frame("reference", reference, w, h)?;
        let mt = check_frame("current", current, w, h)?;
        self.transform(reference, mr, false, (0.0, 0.0));
        self.transform(current, mt, true, (0.0, 0.0));
        let (mut er, mut et) = self.cross_power();
        let (x0, y0) = self.coarse_peak();
        let (mut x, mut y, mut c) = self.refine(x0, y0);
        if self.opts.window {
            self.transform(current, mt, true, (x, y));
            (er, et) = self.cross_power();
            (x, y, c) = self.refine(x, y);
        }
        let norm = match self.opts.weighting {
            Weighting::None => (er * et).sqrt(),
            Weighting::Phase => (w * h) as f64,
        };
        Ok(ShiftEstimate {
            dx: x,
            dy: y,
            confidence: (c / norm).clamp(0.0, 1.0),
        })
    }
}

/// Hann weights of n samples, the window moved by `shift` (zero outside [-0.5, n - 0.5)).
fn hann_table(n: usize, shift: f64) -> Vec<f32> {
    let mut t = vec![0.0; n];
    fill_hann(&mut t, shift);
    t
}

fn fill_hann(t: &mut [f32], shift: f64) {
    let n = t.len() as f64;
    for (i, v) in t.iter_mut().enumerate() {
        let p = i as f64 - shift + 0.5;
        *v = if (0.0..=n).contains(&p) {
            (0.5 - 0.5 * (2.0 * PI * p / n).cos()) as f32
        } else {
            0.0
        };
    }
}
