//! An adjustment's corrections as the solver holds them, where a later solve of the same
//! frames may start ([`super::AdjustOptions::start`]), and their values in a flat list (to
//! carry between processes).

use super::blocks::{self, CameraBlock, DatumBlock, FrameBlock};

/// An adjustment's corrections to the recorded frames and cameras, as the solver holds them:
/// where a later solve of the same frames may start ([`super::AdjustOptions::start`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Corrections {
    pub(super) frames: Vec<FrameBlock>,
    pub(super) cameras: Vec<CameraBlock>,
    pub(super) datum: DatumBlock,
}

/// Values per frame, per camera and of the datum in [`Corrections::to_values`].
const FRAME_VALUES: usize = 6;
const CAMERA_VALUES: usize = 8;
const DATUM_VALUES: usize = blocks::DATUM_PARAMS.len();

impl Corrections {
    /// Every value, frames first, then cameras, then the datum (to carry between processes).
    pub fn to_values(&self) -> Vec<f64> {
        let mut out = Vec::new();
        for f in &self.frames {
            out.extend(blocks::FRAME_PARAMS.iter().map(|&q| f.get(q)));
        }
        for c in &self.cameras {
            out.extend(blocks::CAMERA_PARAMS.iter().map(|&q| c.get(q)));
        }
        out.extend(blocks::DATUM_PARAMS.iter().map(|&q| self.datum.get(q)));
        out
    }

    /// The GPS drift over the flight these corrections carry (m; zero where none was solved:
    /// see [`super::AdjustOptions::gps_drift_times`]).
    pub fn drift_m(&self) -> [f64; 3] {
        self.datum.drift.into()
    }

    /// How many values [`Self::to_values`] gives for `frames` frames and `cameras` cameras.
    pub fn value_count(frames: usize, cameras: usize) -> usize {
        frames * FRAME_VALUES + cameras * CAMERA_VALUES + DATUM_VALUES
    }

    /// How many cameras `len` values of [`Self::to_values`] for `frames` frames hold; none
    /// when no count fits.
    pub fn camera_count(len: usize, frames: usize) -> Option<usize> {
        let rest = len.checked_sub(frames * FRAME_VALUES + DATUM_VALUES)?;
        (rest % CAMERA_VALUES == 0).then_some(rest / CAMERA_VALUES)
    }

    /// The corrections of `frames` frames and `cameras` cameras from [`Self::to_values`];
    /// none when the count does not match.
    pub fn from_values(frames: usize, cameras: usize, v: &[f64]) -> Option<Self> {
        if v.len() != Self::value_count(frames, cameras) {
            return None;
        }
        let (fv, rest) = v.split_at(frames * FRAME_VALUES);
        let (cv, dv) = rest.split_at(cameras * CAMERA_VALUES);
        let mut out = Self {
            frames: vec![FrameBlock::default(); frames],
            cameras: vec![CameraBlock::default(); cameras],
            datum: DatumBlock::default(),
        };
        for (f, chunk) in out.frames.iter_mut().zip(fv.chunks_exact(FRAME_VALUES)) {
            for (&q, &x) in blocks::FRAME_PARAMS.iter().zip(chunk) {
                *f.get_mut(q) = x;
            }
        }
        for (c, chunk) in out.cameras.iter_mut().zip(cv.chunks_exact(CAMERA_VALUES)) {
            for (&q, &x) in blocks::CAMERA_PARAMS.iter().zip(chunk) {
                *c.get_mut(q) = x;
            }
        }
        for (&q, &x) in blocks::DATUM_PARAMS.iter().zip(dv) {
            *out.datum.get_mut(q) = x;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_come_back_as_the_same_corrections() {
        let mut c = Corrections {
            frames: vec![FrameBlock::default(); 3],
            cameras: vec![CameraBlock::default(); 2],
            datum: DatumBlock::default(),
        };
        c.frames[1].rotation.y = 0.25;
        c.frames[2].position.z = -1.5;
        c.cameras[1].focal_scale = 1e-3;
        c.cameras[0].boresight.x = 2e-4;
        c.datum.scale = 3e-6;
        let v = c.to_values();
        assert_eq!(v.len(), 3 * 6 + 2 * 8 + 10);
        assert_eq!(Corrections::from_values(3, 2, &v), Some(c));
        assert_eq!(Corrections::from_values(2, 2, &v), None);
        assert_eq!(Corrections::camera_count(v.len(), 3), Some(2));
        assert_eq!(Corrections::camera_count(v.len(), 4), None);
    }
}
