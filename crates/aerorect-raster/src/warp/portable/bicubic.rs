//! The bicubic kernel (Keys, a = -0.5; portable build) and its weights.

use crate::raster::Sample;
use crate::warp::types::{Kernel, SourceGeometry};

pub(crate) struct Bicubic;

#[derive(Clone, Copy, Default)]
pub(crate) struct BicubicTap {
    /// Column indices of the four taps (edge repeated).
    cols: [u32; 4],
    /// Row start offsets of the four taps (edge repeated).
    rows: [u32; 4],
    wx: [f32; 4],
    wy: [f32; 4],
}

/// Keys' cubic convolution kernel with a = -0.5 at distance d: the definition that the per-tap
/// polynomials of `keys_weights` are tested against.
#[cfg(test)]
fn keys(d: f64) -> f64 {
    const A: f64 = -0.5;
    let d = d.abs();
    if d <= 1.0 {
        ((A + 2.0) * d - (A + 3.0)) * d * d + 1.0
    } else if d < 2.0 {
        ((A * d - 5.0 * A) * d + 8.0 * A) * d - 4.0 * A
    } else {
        0.0
    }
}

/// The four Keys (a = -0.5) weights of taps floor(x)-1 .. floor(x)+2 for t = x - floor(x):
/// keys(1 + t), keys(t), keys(1 - t), keys(2 - t), expanded (Catmull-Rom).
#[inline(always)]
pub fn keys_weights(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    ]
}

/// `keys_weights` in f32, as the kernels use them (the fraction rounded to f32 first); the
/// operations and their order are those of the AVX2 build.
#[inline(always)]
pub(crate) fn keys_weights_f32(t: f32) -> [f32; 4] {
    let (t2, half_t) = (t * t, 0.5 * t);
    let t3 = t2 * t;
    [
        (-0.5 * t3 + t2) - half_t,
        (1.5 * t3 - 2.5 * t2) + 1.0,
        (-1.5 * t3 + 2.0 * t2) + half_t,
        0.5 * t3 - 0.5 * t2,
    ]
}

impl Kernel for Bicubic {
    type Tap = BicubicTap;

    /// Branch-free: indices are clamped (NaN to the first pixel), the flag tells inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut BicubicTap) -> bool {
        let inside = g.inside(x, y);
        // Positions are clamped to [-1, n] before flooring: taps are clamped anyway.
        let xc = x.max(-1.0).min(g.width as f64);
        let yc = y.max(-1.0).min(g.height as f64);
        let (xf, yf) = (xc.floor(), yc.floor());
        let wx = keys_weights_f32((xc - xf) as f32);
        let wy = keys_weights_f32((yc - yf) as f32);
        let (xi, yi) = (xf as i32, yf as i32);
        let (wmax, hmax) = (g.width as i32 - 1, g.height as i32 - 1);
        for k in 0..4 {
            tap.cols[k] = (xi - 1 + k as i32).clamp(0, wmax) as u32;
            tap.rows[k] = (yi - 1 + k as i32).clamp(0, hmax) as u32 * g.width as u32;
            tap.wx[k] = wx[k];
            tap.wy[k] = wy[k];
        }
        inside
    }

    /// Vertical first (per column i: ((p0i wy0 + p1i wy1) + p2i wy2) + p3i wy3), then
    /// horizontal as (h0 + h2) + (h1 + h3): the order of the AVX2 build, which does the four
    /// columns as one vector.
    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], g: &SourceGeometry, t: &BicubicTap) -> T {
        // Every index is below width * height = plane.len() by construction in `prepare`.
        assert!(plane.len() == g.width * g.height);
        let mut h = [0.0f32; 4];
        for (i, h) in h.iter_mut().enumerate() {
            // SAFETY: rows[j] <= (h-1) w and cols[i] <= w - 1, so the index is < w h = len.
            let p = |j: usize| unsafe {
                plane
                    .get_unchecked(t.rows[j] as usize + t.cols[i] as usize)
                    .to_f32()
            };
            let col = p(0) * t.wy[0] + p(1) * t.wy[1] + p(2) * t.wy[2] + p(3) * t.wy[3];
            *h = col * t.wx[i];
        }
        T::from_f32((h[0] + h[2]) + (h[1] + h[3]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_weights_are_the_kernel_to_f32_precision() {
        for k in 0..=4096 {
            let t = k as f64 / 4096.0 + 1e-7;
            let (w32, w64) = (keys_weights_f32(t as f32), keys_weights(t));
            for i in 0..4 {
                let e = (f64::from(w32[i]) - w64[i]).abs();
                assert!(
                    e < 3e-7,
                    "t = {t}, tap {i}: {} vs {} ({e:e})",
                    w32[i],
                    w64[i]
                );
            }
        }
    }

    #[test]
    fn expanded_weights_equal_the_kernel_definition() {
        for k in 0..=1000 {
            let t = k as f64 / 1000.0;
            let w = keys_weights(t);
            let d = [keys(1.0 + t), keys(t), keys(1.0 - t), keys(2.0 - t)];
            for i in 0..4 {
                assert!(
                    (w[i] - d[i]).abs() < 1e-14,
                    "t = {t}, tap {i}: {} vs {}",
                    w[i],
                    d[i]
                );
            }
            assert!(
                (w.iter().sum::<f64>() - 1.0).abs() < 1e-14,
                "partition of unity"
            );
        }
    }
}
