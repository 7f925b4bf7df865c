//! The paper's experiment, simulated: sub-pixel displaced copies of a real scene (by linear
//! interpolation or by a Fourier shift), white Gaussian noise at a given SNR, and the
//! Cramer-Rao lower bound of the shift error.
//!
//! SNR_dB = 10 log10(var(signal) / var(noise)), the variance of the noise-free frame over the
//! noise variance, for each frame separately.

use super::fft2::Fft2;
use crate::{Coordinates, Interp, Raster, WarpOptions, warp};
use aerorect_core::{Homography, ImageSize};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use rustfft::num_complex::Complex32;
use std::f64::consts::PI;

/// The `size` window of `scene` whose top-left pixel is (x0, y0), with its content moved by
/// (dx, dy): output (x, y) = scene(x0 + x - dx, y0 + y - dy), sampled bilinearly (dx = dy = 0
/// gives the plain crop). The window plus the shift must lie inside the scene.
pub fn shifted_linear(
    scene: &Raster<f32>,
    x0: f64,
    y0: f64,
    size: ImageSize,
    dx: f64,
    dy: f64,
) -> Vec<f32> {
    let map = Homography::translation(x0 - dx, y0 - dy);
    let opts = WarpOptions {
        interp: Interp::Bilinear,
        nodata: 0.0,
        alpha: false,
        prefilter: true,
        // A simulator's shift is the truth the estimators are scored against.
        coordinates: Coordinates::Exact,
    };
    match warp(scene, &map, size, &opts) {
        Ok(r) => r.plane(0).to_vec(),
        Err(_) => vec![0.0; size.pixels()],
    }
}

/// As [`shifted_linear`] but by a Fourier shift of the surrounding 2w x 2h window (an exact
/// sub-pixel translation of the band-limited window; wrap-around stays outside the centre).
pub fn shifted_fourier(
    scene: &Raster<f32>,
    x0: usize,
    y0: usize,
    size: ImageSize,
    dx: f64,
    dy: f64,
) -> Vec<f32> {
    let (w, h) = (size.width, size.height);
    let (bw, bh) = (2 * w, 2 * h);
    let (bx, by) = (x0.saturating_sub(w / 2), y0.saturating_sub(h / 2));
    let sw = scene.width();
    let plane = scene.plane(0);
    let mut fft = Fft2::new(bw, bh);
    let mut spec = vec![Complex32::default(); fft.spectrum_len()];
    fft.forward_rows(
        bh,
        |r, buf| buf.copy_from_slice(&plane[(by + r) * sw + bx..(by + r) * sw + bx + bw]),
        &mut spec,
    );
    for u in 0..=bw / 2 {
        for v in 0..bh {
            let fv = super::signed(v, bh);
            let a = -2.0 * PI * (u as f64 * dx / bw as f64 + fv * dy / bh as f64);
            spec[u * bh + v] *= Complex32::new(a.cos() as f32, a.sin() as f32);
        }
    }
    let mut out = vec![0.0f32; w * h];
    let (ox, oy) = (x0 - bx, y0 - by);
    let n = (bw * bh) as f32;
    fft.inverse_rows(
        &mut spec,
        |r| r >= oy && r < oy + h,
        |r, row| {
            for x in 0..w {
                out[(r - oy) * w + x] = row[ox + x] / n;
            }
        },
    );
    out
}

/// Variance of a frame.
pub fn variance(frame: &[f32]) -> f64 {
    let n = frame.len() as f64;
    let mean = frame.iter().map(|&v| v as f64).sum::<f64>() / n;
    frame
        .iter()
        .map(|&v| (v as f64 - mean).powi(2))
        .sum::<f64>()
        / n
}

/// Adds white Gaussian noise at `snr_db` (relative to the frame's own variance); returns the
/// noise variance.
pub fn add_noise<R: Rng>(frame: &mut [f32], snr_db: f64, rng: &mut R) -> f64 {
    let var = variance(frame) / 10f64.powf(snr_db / 10.0);
    if let Ok(normal) = Normal::new(0.0, var.sqrt()) {
        for v in frame.iter_mut() {
            *v += normal.sample(rng) as f32;
        }
    }
    var
}

/// Cramer-Rao lower bound on the RMS error of (dx, dy) between two copies of the noise-free
/// `frame` that each carry white noise of variance `noise_var`:
/// J = 1 / (2 s^2) sum [Ix^2, Ix Iy; Ix Iy, Iy^2], bound = sqrt(trace(J^-1)).
/// Gradients by central differences over the interior pixels.
pub fn crlb_rms(frame: &[f32], size: ImageSize, noise_var: f64) -> f64 {
    let (w, h) = (size.width, size.height);
    let (mut sxx, mut syy, mut sxy) = (0.0f64, 0.0f64, 0.0f64);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let ix = 0.5 * (frame[y * w + x + 1] as f64 - frame[y * w + x - 1] as f64);
            let iy = 0.5 * (frame[(y + 1) * w + x] as f64 - frame[(y - 1) * w + x] as f64);
            sxx += ix * ix;
            syy += iy * iy;
            sxy += ix * iy;
        }
    }
    let k = 1.0 / (2.0 * noise_var);
    let (jxx, jyy, jxy) = (k * sxx, k * syy, k * sxy);
    let det = jxx * jyy - jxy * jxy;
    ((jxx + jyy) / det).sqrt()
}
