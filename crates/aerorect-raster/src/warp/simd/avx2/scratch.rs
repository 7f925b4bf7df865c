//! Per-task buffers of the AVX2 kernels, one block long.

use super::bicubic_lanes::CubicTap;
use crate::warp::block::BLOCK;

/// Per-task buffers for the AVX2 builds, one block long.
pub(crate) struct SimdScratch {
    pub(crate) cubic: Vec<CubicTap>,
    pub(crate) base: Vec<u32>,
    /// Per pixel: 0 outside, 1 interior (all 16 taps inside), 2 on the border (taps clamped).
    pub(crate) state: Vec<u8>,
    /// Fast offsets of a block (`Buffered`).
    pub(crate) px: Vec<f32>,
    pub(crate) py: Vec<f32>,
}

impl SimdScratch {
    pub(crate) fn new() -> Self {
        Self {
            px: vec![0.0; BLOCK],
            py: vec![0.0; BLOCK],
            cubic: vec![CubicTap::default(); BLOCK],
            base: vec![0; BLOCK],
            state: vec![0; BLOCK],
        }
    }
}
