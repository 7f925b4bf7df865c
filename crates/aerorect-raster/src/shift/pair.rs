//! The two spectra of a frame pair, with the previous pair's current frame remembered: a track
//! (each frame against the one before) hands that frame back as the next reference, whose
//! spectrum is then reused instead of transformed again.

use super::{ShiftError, check_frame};
use rustfft::num_complex::Complex32;

#[derive(Default)]
pub(crate) struct PairSpectra {
    /// The reference's spectrum.
    pub(crate) r: Vec<Complex32>,
    /// The current frame's spectrum (the next pair's reference, when `last_valid`).
    pub(crate) t: Vec<Complex32>,
    /// The last `current` frame, whose spectrum `t` holds (when `last_valid`).
    last: Vec<f32>,
    last_valid: bool,
}

impl PairSpectra {
    pub(crate) fn new(spectrum_len: usize, width: usize, height: usize) -> Self {
        Self {
            r: vec![Complex32::default(); spectrum_len],
            t: vec![Complex32::default(); spectrum_len],
            last: vec![0.0; width * height],
            last_valid: false,
        }
    }

    /// Checks both frames and fills `r` and `t` by `transform(frame, mean, spectrum)`, the
    /// reference's taken from the previous call when the reference is that call's current
    /// frame (bit for bit). Returns the current frame's mean. A refused frame leaves no
    /// spectrum to reuse.
    pub(crate) fn update(
        &mut self,
        (reference, current): (&[f32], &[f32]),
        (width, height): (usize, usize),
        mut transform: impl FnMut(&[f32], f32, &mut [Complex32]),
    ) -> Result<f32, ShiftError> {
        let reuse = self.last_valid && reference == self.last.as_slice();
        if !reuse {
            let mr = check_frame("reference", reference, width, height)?;
            transform(reference, mr, &mut self.r);
        }
        let mt = match check_frame("current", current, width, height) {
            Ok(m) => m,
            Err(e) => {
                self.last_valid = false;
                return Err(e);
            }
        };
        if reuse {
            std::mem::swap(&mut self.r, &mut self.t);
        }
        transform(current, mt, &mut self.t);
        self.last.copy_from_slice(current);
        self.last_valid = true;
        Ok(mt)
    }
}
