//! The nearest taps of eight pixels and their u8 byte windows, shared by the AVX2 nearest
//! kernel, the positions and the sample types.

use super::lanes::{Consts, extent8, pack_low_bytes};
use std::arch::x86_64::*;

/// The nearest taps of eight pixels.
pub(crate) struct NearestTaps {
    /// Sample indices, inside the image (any inside index where the pixel is outside).
    pub(crate) idx: __m256i,
    /// Columns and rows of the samples (exact where the pixel is inside).
    pub(crate) ix: __m256i,
    pub(crate) iy: __m256i,
    /// Inside bits.
    pub(crate) mask: i32,
}

/// Eight u8 nearest samples read as a byte shuffle of one or two 16-byte row loads instead of
/// eight scalar loads (the `Window` layout): where all eight are inside, their columns lie
/// within 16 bytes and their rows differ by at most one.
pub(crate) struct NearestWindow {
    /// Offset of the first byte of the first row.
    pub(crate) start: usize,
    /// Bytes 0..8: each pixel's column minus the first column (a `pshufb` control).
    pub(crate) ctrl: __m128i,
    /// Bytes 0..8: 0xFF where the pixel is on the first row.
    pub(crate) first: __m128i,
    /// Rows read: 1 when all eight rows are equal, else 2.
    pub(crate) rows: usize,
}

/// The byte window of eight nearest samples at columns `ix`, rows `iy` (all inside).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn nearest_window(
    k: &Consts,
    ix: __m256i,
    iy: __m256i,
    monotonic: bool,
) -> Option<NearestWindow> {
    let (xmin, xmax) = extent8(ix, monotonic);
    let (ymin, ymax) = extent8(iy, monotonic);
    if xmax - xmin > 15 || ymax - ymin > 1 || xmin + 16 > k.size.0 {
        return None;
    }
    Some(NearestWindow {
        start: (ymin * k.size.0 + xmin) as usize,
        ctrl: pack_low_bytes(k, _mm256_sub_epi32(ix, _mm256_set1_epi32(xmin))),
        first: pack_low_bytes(k, _mm256_cmpeq_epi32(iy, _mm256_set1_epi32(ymin))),
        rows: if ymax == ymin { 1 } else { 2 },
    })
}
