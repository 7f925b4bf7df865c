//! A projective block's offsets at sixteen lanes (`Relative16`), and the buffered offsets
//! sixteen at a time.

use crate::warp::relative::RelativeBlock;
use std::arch::x86_64::*;

/// `Relative`'s vectors at sixteen lanes, made from its block (`RelativeBlock`).
pub(crate) struct Relative16 {
    first: [__m512; 2],
    slope: [__m512; 2],
    c: __m512,
    one: __m512,
    pub(crate) lanes: __m512,
    /// The block's integer origin (column, row), added to the floors by their users.
    pub(crate) origin: [i32; 2],
    pub(crate) width: __m512i,
}

impl Relative16 {
    #[target_feature(enable = "avx512f")]
    pub(crate) fn new(b: &RelativeBlock, width: i32) -> Self {
        Self {
            first: b.first.map(|v| _mm512_set1_ps(v)),
            slope: b.slope.map(|v| _mm512_set1_ps(v)),
            c: _mm512_set1_ps(b.c),
            one: _mm512_set1_ps(1.0),
            lanes: _mm512_setr_ps(
                0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0,
                15.0,
            ),
            origin: b.origin,
            width: _mm512_set1_epi32(width),
        }
    }

    /// The offsets of pixels `k` (their numbers in the block, as f32), as
    /// `Relative::offsets_at` (same operations, same order).
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn offsets(&self, k: __m512) -> [__m512; 2] {
        let den = _mm512_add_ps(self.one, _mm512_mul_ps(self.c, k));
        let kr = _mm512_mul_ps(k, _mm512_div_ps(self.one, den));
        [0, 1].map(|a| _mm512_add_ps(self.first[a], _mm512_mul_ps(self.slope[a], kr)))
    }

    /// The columns and rows of pixels `k` less the origin: floor(offset), as
    /// `Relative::nearest_index` (floor and conversion in one, exact for inside pixels).
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn cols_rows16(&self, k: __m512) -> [__m512i; 2] {
        self.offsets(k)
            .map(|p| _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(p))
    }
}

/// `Relative::fill_offsets` sixteen at a time: the offsets of the first pixels into `px` and
/// `py`; returns where it stopped (fewer than sixteen left).
///
/// # Safety
/// AVX-512 F.
#[target_feature(enable = "avx2,avx512f")]
pub(crate) unsafe fn fill_offsets16(
    block: &RelativeBlock,
    px: &mut [f32],
    py: &mut [f32],
) -> usize {
    let z = Relative16::new(block, 0);
    let n = px.len().min(py.len());
    let (mut i, mut k, step) = (0, z.lanes, _mm512_set1_ps(16.0));
    while i + 16 <= n {
        let [x, y] = z.offsets(k);
        k = _mm512_add_ps(k, step);
        // SAFETY: i + 16 <= n, the length of both.
        unsafe {
            _mm512_storeu_ps(px.as_mut_ptr().add(i), x);
            _mm512_storeu_ps(py.as_mut_ptr().add(i), y);
        }
        i += 16;
    }
    i
}
