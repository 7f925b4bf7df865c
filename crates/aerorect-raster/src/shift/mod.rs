//! Sub-pixel shift between two frames of the same size, planned once and reused frame after
//! frame (no allocation per call).
//!
//! Convention: `estimate(reference, current)` returns (dx, dy) such that a feature at (x, y) in
//! the reference is at (x + dx, y + dy) in the current frame.
//!
//! - [`JointTransformCorrelator`]: the joint transform correlator of Li & Yang (2015).
//! - [`PhaseCorrelator`]: (phase-)correlation with the peak of the continuous, infinitely
//!   upsampled DFT correlation found by Newton's method.

mod fft2;
mod jtc;
mod jtc_common;
mod jtc_cross;
#[cfg(test)]
mod jtc_oracle;
mod jtc_paper;
mod jtc_paper_joint;
mod jtc_paper_threshold;
mod pair;
mod phase;
mod phase_kernels;
pub mod sim;

pub use jtc::JointTransformCorrelator;
pub use jtc_common::{JtcOptions, SubPixel};
pub use phase::{PhaseCorrelator, PhaseOptions, Weighting};

use thiserror::Error;

/// A measured shift.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ShiftEstimate {
    pub dx: f64,
    pub dy: f64,
    /// In [0, 1]: how clearly the correlation peak stands out (see each estimator).
    pub confidence: f64,
}

#[derive(Debug, Error, Clone, PartialEq)]
pub enum ShiftError {
    #[error(
        "the {frame} frame has {got} samples, the estimator is planned for {width} x {height} = {want}"
    )]
    SizeMismatch {
        frame: &'static str,
        got: usize,
        want: usize,
        width: usize,
        height: usize,
    },
    #[error("the {frame} frame has a non-finite sample ({value}) at pixel {index}")]
    NonFinite {
        frame: &'static str,
        index: usize,
        value: f32,
    },
    #[error("the {frame} frame is constant: it has no texture to correlate")]
    Constant { frame: &'static str },
    #[error("frames of {width} x {height} are too small (at least 8 x 8)")]
    TooSmall { width: usize, height: usize },
}

/// A shift estimator planned for one frame size.
pub trait ShiftEstimator {
    fn estimate(&mut self, reference: &[f32], current: &[f32])
    -> Result<ShiftEstimate, ShiftError>;
}

pub(crate) fn check_size(width: usize, height: usize) -> Result<(), ShiftError> {
    if width < 8 || height < 8 {
        return Err(ShiftError::TooSmall { width, height });
    }
    Ok(())
}

/// Checks a frame and returns its mean.
pub(crate) fn check_frame(
    frame: &'static str,
    data: &[f32],
    width: usize,
    height: usize,
) -> Result<f32, ShiftError> {
    let want = width * height;
    if data.len() != want {
        return Err(ShiftError::SizeMismatch {
            frame,
            got: data.len(),
            want,
            width,
            height,
        });
    }
    // One pass in blocks of 1024 samples, eight f32 lanes each: the sum (blocks added in f64),
    // the smallest and largest sample; a non-finite sample makes the sum non-finite and is then
    // looked for.
    const L: usize = 8;
    let (mut total, mut min, mut max) = (0.0f64, data[0], data[0]);
    for block in data.chunks(1024) {
        let (mut sum, mut lo, mut hi) = ([0.0f32; L], [block[0]; L], [block[0]; L]);
        let chunks = block.chunks_exact(L);
        let tail = chunks.remainder();
        for c in chunks {
            for l in 0..L {
                sum[l] += c[l];
                lo[l] = if c[l] < lo[l] { c[l] } else { lo[l] };
                hi[l] = if c[l] > hi[l] { c[l] } else { hi[l] };
            }
        }
        total += sum.iter().map(|&v| v as f64).sum::<f64>()
            + tail.iter().map(|&v| v as f64).sum::<f64>();
        for &v in lo.iter().chain(&hi).chain(tail) {
            (min, max) = (min.min(v), max.max(v));
        }
    }
    if !total.is_finite()
        && let Some((index, &value)) = data.iter().enumerate().find(|(_, v)| !v.is_finite())
    {
        return Err(ShiftError::NonFinite {
            frame,
            index,
            value,
        });
    }
    if min == max {
        return Err(ShiftError::Constant { frame });
    }
    total /= want as f64;
    Ok(total as f32)
}

/// Signed offset of index `i` on a circle of `n`: i for i < n/2, i - n above.
pub(crate) fn signed(i: usize, n: usize) -> f64 {
    if i < n.div_ceil(2) {
        i as f64
    } else {
        i as f64 - n as f64
    }
}

/// Vertex of the parabola through (-1, a), (0, b), (1, c), clamped to [-0.5, 0.5].
pub(crate) fn parabola_vertex(a: f64, b: f64, c: f64) -> f64 {
    let d = a - 2.0 * b + c;
    if d < 0.0 {
        (0.5 * (a - c) / d).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}
