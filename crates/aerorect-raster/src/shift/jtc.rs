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

use super::jtc_common::JtcOptions;
use super::jtc_cross::CrossJtc;
use super::jtc_paper::PaperJtc;
use super::{ShiftError, ShiftEstimate, ShiftEstimator, check_size};

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
