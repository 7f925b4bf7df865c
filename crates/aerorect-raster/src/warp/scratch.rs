//! Per-task buffers of the row loops (portable and SIMD), one block long.

use super::block::BLOCK;
#[cfg(target_arch = "x86_64")]
use super::simd::avx2::scratch::SimdScratch;
use super::types::Kernel;

/// Per-task buffers, one block long, reused block after block.
pub(crate) struct Scratch<K: Kernel> {
    pub(crate) xs: Vec<f64>,
    pub(crate) ys: Vec<f64>,
    pub(crate) taps: Vec<K::Tap>,
    pub(crate) valid: Vec<bool>,
    #[cfg(target_arch = "x86_64")]
    pub(crate) simd: SimdScratch,
}

impl<K: Kernel> Scratch<K> {
    pub(crate) fn new() -> Self {
        Self {
            xs: vec![0.0; BLOCK],
            ys: vec![0.0; BLOCK],
            taps: vec![K::Tap::default(); BLOCK],
            valid: vec![false; BLOCK],
            #[cfg(target_arch = "x86_64")]
            simd: SimdScratch::new(),
        }
    }
}
