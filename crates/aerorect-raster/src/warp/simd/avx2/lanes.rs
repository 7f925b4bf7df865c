//! The constants of one source image for the eight-pixel steps, and the lane helpers every
//! AVX2 kernel shares (position loads, mask narrowing, lane extremes, byte packing, inside
//! flags).

use crate::warp::types::SourceGeometry;
use std::arch::x86_64::*;

/// Constants of one source image for the eight-pixel steps.
pub(crate) struct Consts {
    lim_x: __m256d,
    lim_y: __m256d,
    neg_half: __m256d,
    pub(crate) zero: __m256d,
    pub(crate) max_x: __m256d,
    pub(crate) max_y: __m256d,
    pub(crate) i0max_x: __m128i,
    pub(crate) i0max_y: __m128i,
    pub(crate) width: __m256i,
    pub(crate) w_minus_2: __m256i,
    pub(crate) half: __m256,
    pick: __m256i,
    /// The source width and height.
    pub(crate) size: (i32, i32),
}

impl Consts {
    #[target_feature(enable = "avx2")]
    pub(crate) fn new(g: &SourceGeometry) -> Self {
        let (w, h) = (g.width(), g.height());
        Self {
            lim_x: _mm256_set1_pd(w as f64 - 0.5),
            lim_y: _mm256_set1_pd(h as f64 - 0.5),
            neg_half: _mm256_set1_pd(-0.5),
            zero: _mm256_setzero_pd(),
            max_x: _mm256_set1_pd((w - 1) as f64),
            max_y: _mm256_set1_pd((h - 1) as f64),
            i0max_x: _mm_set1_epi32(w as i32 - 2),
            i0max_y: _mm_set1_epi32(h as i32 - 2),
            width: _mm256_set1_epi32(w as i32),
            w_minus_2: _mm256_set1_epi32(w as i32 - 2),
            half: _mm256_set1_ps(0.5),
            // Picks byte 0 of each 32-bit lane into the low 4 bytes of each 128-bit half.
            pick: _mm256_setr_epi8(
                0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, 0, 4, 8, 12, -1, -1,
                -1, -1, -1, -1, -1, -1, -1, -1, -1, -1,
            ),
            size: (w as i32, h as i32),
        }
    }

    /// Inside the pixel footprints (`SourceGeometry::inside`), as a 64-bit lane mask.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn inside(&self, x: __m256d, y: __m256d) -> __m256d {
        let a = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(x, self.neg_half),
            _mm256_cmp_pd::<_CMP_LT_OQ>(x, self.lim_x),
        );
        let b = _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(y, self.neg_half),
            _mm256_cmp_pd::<_CMP_LT_OQ>(y, self.lim_y),
        );
        _mm256_and_pd(a, b)
    }
}

/// Four source positions of `xs`, `ys` from `i` on.
///
/// # Safety
/// AVX2; `i + 4 <= xs.len(), ys.len()`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) unsafe fn load4(xs: &[f64], ys: &[f64], i: usize) -> (__m256d, __m256d) {
    debug_assert!(i + 4 <= xs.len() && i + 4 <= ys.len());
    // SAFETY: i + 4 <= len (the contract).
    unsafe {
        (
            _mm256_loadu_pd(xs.as_ptr().add(i)),
            _mm256_loadu_pd(ys.as_ptr().add(i)),
        )
    }
}

/// Eight 64-bit lane masks (two halves) as eight 32-bit lane masks.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn narrow_mask(lo: __m256d, hi: __m256d) -> __m256i {
    let even = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    _mm256_set_m128i(
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(hi), even)),
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(lo), even)),
    )
}

/// The minimum and maximum of eight i32 lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn min_max8(v: __m256i) -> (i32, i32) {
    let swap = _mm256_permute2x128_si256::<1>(v, v);
    let (mut lo, mut hi) = (_mm256_min_epi32(v, swap), _mm256_max_epi32(v, swap));
    lo = _mm256_min_epi32(lo, _mm256_shuffle_epi32::<0b01_00_11_10>(lo));
    hi = _mm256_max_epi32(hi, _mm256_shuffle_epi32::<0b01_00_11_10>(hi));
    lo = _mm256_min_epi32(lo, _mm256_shuffle_epi32::<0b10_11_00_01>(lo));
    hi = _mm256_max_epi32(hi, _mm256_shuffle_epi32::<0b10_11_00_01>(hi));
    (_mm256_cvtsi256_si32(lo), _mm256_cvtsi256_si32(hi))
}

/// The minimum and maximum of eight i32 lanes that are monotonic (in either direction): the
/// first and the last lane.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn ends8(v: __m256i) -> (i32, i32) {
    let (a, b) = (_mm256_cvtsi256_si32(v), _mm256_extract_epi32::<7>(v));
    (a.min(b), a.max(b))
}

/// The minimum and maximum of eight i32 lanes: `ends8` where they are known to be monotonic,
/// else `min_max8`.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn extent8(v: __m256i, monotonic: bool) -> (i32, i32) {
    match monotonic {
        true => ends8(v),
        false => min_max8(v),
    }
}

/// The low byte of each 32-bit lane, packed into the low eight bytes.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn pack_low_bytes(k: &Consts, v: __m256i) -> __m128i {
    let bytes = _mm256_shuffle_epi8(v, k.pick);
    _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
        bytes,
        _mm256_setr_epi32(0, 4, 1, 1, 1, 1, 1, 1),
    ))
}

/// Per 8-bit mask, the eight inside flags as the bytes of a `[bool; 8]` (bit b -> byte b).
const FLAG_BYTES: [u64; 256] = {
    let mut t = [0u64; 256];
    let mut m = 0;
    while m < 256 {
        let mut b = 0;
        while b < 8 {
            t[m] |= ((m as u64 >> b) & 1) << (8 * b);
            b += 1;
        }
        m += 1;
    }
    t
};

/// Writes the eight inside flags of `mask` to `valid[i..i + 8]` with one store.
#[inline(always)]
pub(crate) fn store_flags(valid: &mut [bool], i: usize, mask: i32) {
    let flags = &mut valid[i..i + 8];
    // SAFETY: `flags` is 8 bools; every byte written is 0 or 1, a valid bool.
    unsafe { (flags.as_mut_ptr() as *mut u64).write_unaligned(FLAG_BYTES[(mask & 0xFF) as usize]) };
}
