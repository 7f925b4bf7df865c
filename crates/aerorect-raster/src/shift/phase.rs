//! Cross-correlation in the frequency domain, optionally phase-normalised (classic phase
//! correlation), with the sub-pixel peak found by Newton's method on the continuous DFT
//! correlation c(x, y) = sum_k Q_k exp(+2 pi i k.(x, y) / n): the limit of the upsampled DFT of
//! Guizar-Sicairos et al. (2008) as the upsampling factor grows without bound.

use super::fft2::Fft2;
use super::pair::PairSpectra;
use super::phase_kernels::{Spectra, cross_power_fast, fill_hann, hann_table, newton_sums_fast};
use super::{ShiftError, ShiftEstimate, ShiftEstimator, check_size, parabola_vertex, signed};
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
    /// Standard deviation in px of a Gaussian that smooths the correlation surface (the
    /// cross-power spectrum weighted by exp(-smooth^2 |k|^2 / 2), k in rad/px); 0: none.
    /// Only the low frequencies' phase measures a translation well: resampling (any
    /// interpolation kernel's phase is not linear in k), aliasing and noise corrupt the high
    /// ones, and the peak of the unsmoothed surface is pulled towards whole pixels (the
    /// low-pass filter of Foroosh, Zerubia & Berthod 2002, IEEE TIP 11(3)).
    pub smooth: f64,
}

impl PhaseOptions {
    /// Phase correlation as `motion-sim` and `track` use it: Hann window, correlation surface
    /// smoothed by 1.5 px (chosen on `bench/shift_vs_peers.py`'s frames).
    pub fn phase() -> Self {
        Self {
            weighting: Weighting::Phase,
            window: true,
            smooth: 1.5,
        }
    }

    /// Cross-correlation as `motion-sim` and `track` use it: Hann window, surface smoothed by
    /// 1 px (its |R| |T| weights already favour the low frequencies).
    pub fn xcorr() -> Self {
        Self {
            weighting: Weighting::None,
            window: true,
            smooth: 1.0,
        }
    }
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
    /// The frames' spectra with the unmoved window; the current one is kept for the next pair
    /// (a track's next reference, which is then not transformed again).
    pair: PairSpectra,
    /// The current frame's spectrum with the moved window (the second pass).
    spec_m: Vec<Complex32>,
    /// The weighted cross-power spectrum for the inverse transform (which destroys it).
    work: Vec<Complex32>,
    plane: Vec<f32>,
    /// Newton workspace: Q's real and imaginary parts (same layout), per row v the phase
    /// factor cos, sin of k_v y, and k_v, k_v^2 (k_v = 2 pi signed(v) / h); per column u the
    /// phase factor of k_u x.
    q_re: Vec<f32>,
    q_im: Vec<f32>,
    ey_c: Vec<f32>,
    ey_s: Vec<f32>,
    k1: Vec<f32>,
    k2: Vec<f32>,
    ex: Vec<(f64, f64)>,
    /// 2 pi k_v / h for every row v (signed frequency).
    kv: Vec<f64>,
    /// The smoothing Gaussian's factors per column u and per row v, and its sum over the
    /// whole spectrum (the phase correlation peak of a frame against itself).
    gx: Vec<f32>,
    gy: Vec<f32>,
    g_sum: f64,
}

impl PhaseCorrelator {
    pub fn new(width: usize, height: usize, opts: PhaseOptions) -> Result<Self, ShiftError> {
        check_size(width, height)?;
        let fft = Fft2::new(width, height);
        let n = fft.spectrum_len();
        let kv: Vec<f64> = (0..height)
            .map(|v| 2.0 * PI * signed(v, height) / height as f64)
            .collect();
        let gauss = |k: f64| (-0.5 * (opts.smooth * k).powi(2)).exp();
        let gx: Vec<f32> = (0..=width / 2)
            .map(|u| gauss(2.0 * PI * u as f64 / width as f64) as f32)
            .collect();
        let gy: Vec<f32> = kv.iter().map(|&k| gauss(k) as f32).collect();
        let g_sum = (0..width)
            .map(|u| gauss(2.0 * PI * signed(u, width) / width as f64))
            .sum::<f64>()
            * gy.iter().map(|&g| g as f64).sum::<f64>();
        Ok(Self {
            w: width,
            h: height,
            opts,
            fft,
            win_x: hann_table(width, 0.0),
            win_y: hann_table(height, 0.0),
            pair: PairSpectra::new(n, width, height),
            spec_m: vec![Complex32::default(); n],
            work: vec![Complex32::default(); n],
            plane: vec![0.0; width * height],
            q_re: vec![0.0; n],
            q_im: vec![0.0; n],
            ey_c: vec![0.0; height],
            ey_s: vec![0.0; height],
            k1: kv.iter().map(|&k| k as f32).collect(),
            k2: kv.iter().map(|&k| (k * k) as f32).collect(),
            ex: vec![(0.0, 0.0); width / 2 + 1],
            kv,
            gx,
            gy,
            g_sum,
        })
    }

    /// Forward transform of a mean-removed frame into `out`, windowed by the Hann window moved
    /// by `shift` (the reference uses (0, 0)).
    fn transform(&mut self, frame: &[f32], mean: f32, shift: (f64, f64), out: &mut [Complex32]) {
        let (w, use_window) = (self.w, self.opts.window);
        if use_window {
            fill_hann(&mut self.win_x, shift.0);
            fill_hann(&mut self.win_y, shift.1);
        }
        let (wx, wy) = (&self.win_x, &self.win_y);
        let fill = |r: usize, buf: &mut [f32]| {
            let row = &frame[r * w..(r + 1) * w];
            if use_window {
                let g = wy[r];
                for ((b, &v), &x) in buf.iter_mut().zip(row).zip(wx.iter()) {
                    *b = (v - mean) * x * g;
                }
            } else {
                for (b, &v) in buf.iter_mut().zip(row) {
                    *b = v - mean;
                }
            }
        };
        self.fft.forward_rows(self.h, fill, out);
    }

    /// c, its gradient and Hessian at (x, y) (the Hermitian half spectrum counted twice). The
    /// sums along each column are in f32 (eight lanes), the columns' in f64.
    fn newton_terms(&mut self, x: f64, y: f64) -> [f64; 6] {
        let (w, h) = (self.w, self.h);
        for (u, e) in self.ex.iter_mut().enumerate() {
            let (s, c) = (2.0 * PI * u as f64 * x / w as f64).sin_cos();
            *e = (c, s);
        }
        for ((c, s), k) in self.ey_c.iter_mut().zip(self.ey_s.iter_mut()).zip(&self.kv) {
            let (sn, cs) = (k * y).sin_cos();
            (*c, *s) = (cs as f32, sn as f32);
        }
        let rows = [&self.ey_c[..], &self.ey_s, &self.k1, &self.k2];
        let (q_re, q_im, ex) = (&self.q_re[..], &self.q_im[..], &self.ex[..]);
        newton_sums_fast((q_re, q_im), rows, ex, w, h)
    }

    /// Newton's method from (x, y) to the nearest maximum of the continuous correlation, until
    /// a step is below `tol` px.
    fn refine(&mut self, mut x: f64, mut y: f64, tol: f64) -> (f64, f64, f64) {
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
            if dx.abs().max(dy.abs()) < tol {
                break;
            }
        }
        (x, y, c)
    }
}

impl PhaseCorrelator {
    /// Q = conj(R) T (weighted as configured) from the reference's spectrum and the current
    /// frame's (`pair.t`, or with `moved` the moved-window one in `spec_m`): into `q_re`, `q_im`
    /// (Newton's) and `work` (the coarse peak's inverse transform), smoothed; returns
    /// sum G |R|^2, sum G |T|^2 (G the smoothing Gaussian).
    fn cross_power(&mut self, moved: bool) -> (f64, f64) {
        let t = if moved { &self.spec_m } else { &self.pair.t };
        let spectra = Spectra {
            r: &self.pair.r,
            t,
            gx: &self.gx,
            gy: &self.gy,
            w: self.w,
        };
        let out = (&mut self.work[..], &mut self.q_re[..], &mut self.q_im[..]);
        match self.opts.weighting {
            Weighting::Phase => cross_power_fast::<true>(&spectra, out),
            Weighting::None => cross_power_fast::<false>(&spectra, out),
        }
    }

    /// The integer peak of the correlation plane, refined by a parabola per axis (signed shift).
    fn coarse_peak(&mut self) -> (f64, f64) {
        let (w, h) = (self.w, self.h);
        // `work` holds Q (a copy: Newton reads `q_re`, `q_im`).
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
        let mut pair = std::mem::take(&mut self.pair);
        let checked = pair.update((reference, current), (w, h), |f, m, out| {
            self.transform(f, m, (0.0, 0.0), out)
        });
        self.pair = pair;
        let mt = checked?;
        let (mut er, mut et) = self.cross_power(false);
        let (x0, y0) = self.coarse_peak();
        // With the window, the first estimate only places the moved window: a last step under
        // 1e-2 px will do (Newton's convergence is quadratic: it leaves about 1e-6 px here).
        let first_tol = if self.opts.window { 1e-2 } else { 1e-6 };
        let (mut x, mut y, mut c) = self.refine(x0, y0, first_tol);
        if self.opts.window {
            let mut spec = std::mem::take(&mut self.spec_m);
            self.transform(current, mt, (x, y), &mut spec);
            self.spec_m = spec;
            (er, et) = self.cross_power(true);
            (x, y, c) = self.refine(x, y, 1e-6);
        }
        let norm = match self.opts.weighting {
            Weighting::None => (er * et).sqrt(),
            Weighting::Phase => self.g_sum,
        };
        Ok(ShiftEstimate {
            dx: x,
            dy: y,
            confidence: (c / norm).clamp(0.0, 1.0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shift::sim::{add_noise, shifted_linear};
    use aerorect_core::ImageSize;
    use rand::SeedableRng;

    /// A track (each frame against the previous one, whose spectrum is reused) gives exactly
    /// what a fresh estimator gives for each pair, for every option; a refused frame leaves no
    /// stale spectrum behind.
    #[test]
    fn reusing_the_previous_spectrum_changes_nothing() {
        let (w, h) = (64, 48);
        let size = ImageSize::new(400, 400);
        let texture = aerorect_testkit::textured_scene::<f32>(size, 1, 1.0, 9);
        let scene = crate::Raster::from_planes(size, vec![texture.plane(0).to_vec()]).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let frames: Vec<Vec<f32>> = [(0.0, 0.0), (1.3, -0.7), (2.1, -1.2), (0.4, 0.9)]
            .iter()
            .map(|&(dx, dy)| {
                let mut f = shifted_linear(&scene, 80.0, 90.0, ImageSize::new(w, h), dx, dy);
                add_noise(&mut f, 10.0, &mut rng);
                f
            })
            .collect();
        for weighting in [Weighting::None, Weighting::Phase] {
            for window in [false, true] {
                let opts = PhaseOptions {
                    weighting,
                    window,
                    smooth: 1.0,
                };
                let mut track = PhaseCorrelator::new(w, h, opts).unwrap();
                for pair in frames.windows(2) {
                    let reused = track.estimate(&pair[0], &pair[1]).unwrap();
                    let mut fresh = PhaseCorrelator::new(w, h, opts).unwrap();
                    assert_eq!(reused, fresh.estimate(&pair[0], &pair[1]).unwrap());
                }
                assert!(track.estimate(&frames[3], &vec![2.0; w * h]).is_err());
                let again = track.estimate(&frames[1], &frames[2]).unwrap();
                let mut fresh = PhaseCorrelator::new(w, h, opts).unwrap();
                assert_eq!(again, fresh.estimate(&frames[1], &frames[2]).unwrap());
            }
        }
    }
}
