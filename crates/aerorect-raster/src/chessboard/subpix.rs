//! Sub-pixel corner refinement by OpenCV's `cornerSubPix` method: every gradient in a window
//! about a chessboard corner is orthogonal to the vector from the corner to its pixel, solved by
//! weighted least squares and iterated with the window resampled at the new estimate.

use super::image::Gray;

/// Refinement settings.
#[derive(Debug, Clone, Copy)]
pub struct Refine {
    /// The window is (2 half + 1) pixels square.
    pub half: usize,
    pub max_iterations: usize,
    /// Stop when a step moves the corner by less than this (pixels).
    pub eps_px: f64,
}

/// `start` refined in `img`; `start` itself when the estimate leaves the image or wanders more
/// than the half window away (as OpenCV does).
pub fn refine(img: Gray<'_>, start: [f64; 2], r: Refine) -> [f64; 2] {
    let h = r.half as isize;
    let size = (2 * h + 3) as usize;
    let weights: Vec<f64> = (-h..=h)
        .map(|i| {
            let x = i as f64 / h as f64;
            (-x * x).exp()
        })
        .collect();
    let mut sub = vec![0f64; size * size];
    let mut c = start;
    for _ in 0..r.max_iterations {
        // The window (with a one-pixel margin for the gradients) resampled about c.
        for (k, v) in sub.iter_mut().enumerate() {
            let (x, y) = ((k % size) as f64, (k / size) as f64);
            *v = img.bilinear(c[0] + x - (h + 1) as f64, c[1] + y - (h + 1) as f64);
        }
        let (mut a, mut b, mut cc, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (iy, wy) in weights.iter().enumerate() {
            for (ix, wx) in weights.iter().enumerate() {
                let m = wx * wy;
                let at = |dx: usize, dy: usize| sub[(iy + dy) * size + ix + dx];
                let gx = at(2, 1) - at(0, 1);
                let gy = at(1, 2) - at(1, 0);
                let (gxx, gxy, gyy) = (gx * gx * m, gx * gy * m, gy * gy * m);
                let (px, py) = (ix as f64 - h as f64, iy as f64 - h as f64);
                a += gxx;
                b += gxy;
                cc += gyy;
                b1 += gxx * px + gxy * py;
                b2 += gxy * px + gyy * py;
            }
        }
        let det = a * cc - b * b;
        if det.abs() <= f64::EPSILON * (a * cc).abs().max(f64::MIN_POSITIVE) {
            break;
        }
        let step = [(cc * b1 - b * b2) / det, (a * b2 - b * b1) / det];
        c = [c[0] + step[0], c[1] + step[1]];
        if !img.contains(c[0], c[1]) {
            break;
        }
        if step[0].hypot(step[1]) <= r.eps_px {
            break;
        }
    }
    let moved = (c[0] - start[0]).abs().max((c[1] - start[1]).abs());
    if moved > h as f64 || !img.contains(c[0], c[1]) {
        start
    } else {
        c
    }
}
