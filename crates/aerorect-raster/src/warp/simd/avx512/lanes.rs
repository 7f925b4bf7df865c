//! Sixteen-lane blends and roundings shared by the AVX-512 steps and the sample types.

use crate::raster::U8_WEIGHT_BITS;
use std::arch::x86_64::*;

/// The bilinear blend of `blend` (same operations, same order) at sixteen lanes.
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) fn blend16(f: (__m512, __m512), p: [__m512; 4]) -> __m512 {
    let [p00, p01, p10, p11] = p;
    let top = _mm512_add_ps(p00, _mm512_mul_ps(f.0, _mm512_sub_ps(p01, p00)));
    let bottom = _mm512_add_ps(p10, _mm512_mul_ps(f.0, _mm512_sub_ps(p11, p10)));
    _mm512_add_ps(top, _mm512_mul_ps(f.1, _mm512_sub_ps(bottom, top)))
}

/// `weights_u8_16`, each weight w = d2 2^16 + d1 2^8 + d0 as three signed-byte digits: d0 is
/// w's low byte, d1 that of (w + 2^7) >> 8, d2 = (w + 2^15 + 2^7) >> 16 (at most 64). Digit k
/// of the four weights is `Digits16`'s vector k, weight j in byte j of each lane, as `vpdpbusd`
/// takes them.
pub(super) struct Digits16(pub(super) [__m512i; 3]);

impl Digits16 {
    #[target_feature(enable = "avx512f,avx512bw,avx512vbmi,avx512vnni")]
    #[inline]
    pub(super) fn new(f: (__m512, __m512)) -> Self {
        let w = weights_u8_16(f);
        Self([(0, 0), (0x80, 1), (0x8080, 2)].map(|(add, k)| {
            let b = w.map(|v| _mm512_add_epi32(v, _mm512_set1_epi32(add)));
            // Byte k of each lane's four weights: byte 4 l + j takes byte 4 l + k of weight j.
            let index = _mm512_add_epi8(
                _mm512_set1_epi32(0x4000_4000 + 0x0101_0101 * k),
                _mm512_set_epi32(
                    60 * 0x0101_0101,
                    56 * 0x0101_0101,
                    52 * 0x0101_0101,
                    48 * 0x0101_0101,
                    44 * 0x0101_0101,
                    40 * 0x0101_0101,
                    36 * 0x0101_0101,
                    32 * 0x0101_0101,
                    28 * 0x0101_0101,
                    24 * 0x0101_0101,
                    20 * 0x0101_0101,
                    16 * 0x0101_0101,
                    12 * 0x0101_0101,
                    8 * 0x0101_0101,
                    4 * 0x0101_0101,
                    0,
                ),
            );
            let lo = _mm512_permutex2var_epi8(b[0], index, b[1]);
            let hi = _mm512_permutex2var_epi8(b[2], index, b[3]);
            _mm512_mask_blend_epi8(0xCCCC_CCCC_CCCC_CCCC, lo, hi)
        }))
    }
}

/// `bilinear_u8` at sixteen lanes of taps `v` (bytes p00, p01, p10, p11 per lane), two ways to
/// the same integers:
/// - `SHARED` (several bands, the digits made once per step): the digits' dot products
///   (`vpdpbusd`), most significant first, shifted in between; the rounding's 2^21 rides in as
///   32 << 16;
/// - else (one band): the weights themselves, four 32-bit products summed.
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi,avx512vnni")]
#[inline]
pub(crate) fn bilinear_u8_16<const SHARED: bool>(v: __m512i, f: (__m512, __m512)) -> __m512i {
    if SHARED {
        let Digits16([d0, d1, d2]) = Digits16::new(f);
        let t = _mm512_dpbusd_epi32(_mm512_set1_epi32(1 << (U8_WEIGHT_BITS - 1 - 16)), v, d2);
        let t = _mm512_dpbusd_epi32(_mm512_slli_epi32::<8>(t), v, d1);
        let t = _mm512_dpbusd_epi32(_mm512_slli_epi32::<8>(t), v, d0);
        return _mm512_srli_epi32::<U8_WEIGHT_BITS>(t);
    }
    let w = weights_u8_16(f);
    let byte = _mm512_set1_epi32(0xFF);
    let p = [
        _mm512_and_si512(v, byte),
        _mm512_and_si512(_mm512_srli_epi32::<8>(v), byte),
        _mm512_and_si512(_mm512_srli_epi32::<16>(v), byte),
        _mm512_srli_epi32::<24>(v),
    ];
    let [a, b, c, d] = [0, 1, 2, 3].map(|j| _mm512_mullo_epi32(p[j], w[j]));
    let sum = _mm512_add_epi32(_mm512_add_epi32(a, b), _mm512_add_epi32(c, d));
    let half = _mm512_set1_epi32(1 << (U8_WEIGHT_BITS - 1));
    _mm512_srli_epi32::<U8_WEIGHT_BITS>(_mm512_add_epi32(sum, half))
}

/// `bilinear_weights_u8` at sixteen lanes (same operations, same order).
#[target_feature(enable = "avx512f")]
#[inline]
pub(super) fn weights_u8_16((fx, fy): (__m512, __m512)) -> [__m512i; 4] {
    let one = _mm512_set1_ps(1.0);
    let scale = _mm512_set1_ps((1u32 << U8_WEIGHT_BITS) as f32);
    let (bx, by) = (_mm512_sub_ps(one, fx), _mm512_sub_ps(one, fy));
    let (sbx, sfx) = (_mm512_mul_ps(bx, scale), _mm512_mul_ps(fx, scale));
    [(sbx, by), (sfx, by), (sbx, fy), (sfx, fy)].map(|(a, b)| {
        _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(
            _mm512_mul_ps(a, b),
        )
    })
}

/// Sixteen values of an integer type rounded as `from_f32` rounds in range (v + 0.5,
/// truncated); `store16` clamps and saturates them.
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) fn rounded16(v: __m512) -> __m512i {
    _mm512_cvttps_epi32(_mm512_add_ps(v, _mm512_set1_ps(0.5)))
}
