//! `SimdSample` for u16.

use super::bilinear_lanes::{Taps8, blend, rounded};
use super::lanes::Consts;
use super::sample::SimdSample;
use crate::warp::simd::avx512::lanes::{blend16, rounded16};
use crate::warp::simd::avx512::rows::Rows16;
use std::arch::x86_64::*;

impl SimdSample for u16 {
    /// One 512-bit load, widened to two f32 vectors.
    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn row32(p: *const u16) -> [__m512; 2] {
        // SAFETY: the contract.
        let v = unsafe { _mm512_loadu_si512(p as *const __m512i) };
        let wide = |h: __m256i| _mm512_cvtepi32_ps(_mm512_cvtepu16_epi32(h));
        [
            wide(_mm512_castsi512_si256(v)),
            wide(_mm512_extracti64x4_epi64::<1>(v)),
        ]
    }

    /// `store8` at sixteen lanes: (v + 0.5) truncated, saturated to [0, 65535].
    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn store16(v: __m512, out: *mut u16) {
        let q = rounded16(v);
        let words = _mm512_cvtusepi32_epi16(_mm512_max_epi32(q, _mm512_setzero_si512()));
        // SAFETY: sixteen samples writable at `out` (the contract).
        unsafe { _mm256_storeu_si256(out as *mut __m256i, words) };
    }

    const ROW_SPAN: i32 = 32;

    /// One word permute over the upper two rows brings each pixel's upper pair into its
    /// 32-bit lane, one over the lower two its lower pair.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn bilinear_rows16<const SHARED: bool>(
        rows: &Rows16,
        f: (__m512, __m512),
        plane: &[u16],
        out: *mut u16,
    ) {
        debug_assert!(rows.row_start(2) + 32 <= plane.len());
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen
        // writable at `out` (the contract).
        unsafe {
            let row = |r: usize| {
                _mm512_loadu_si512(plane.as_ptr().add(rows.row_start(r)) as *const __m512i)
            };
            let (r0, r1, r2) = (row(0), row(1), row(2));
            let base = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<5>(rows.row));
            let index = _mm512_add_epi32(
                _mm512_mullo_epi32(base, _mm512_set1_epi32(0x1_0001)),
                _mm512_set1_epi32(0x1_0000),
            );
            let top = _mm512_permutex2var_epi16(r0, index, r1);
            let low = _mm512_permutex2var_epi16(r1, index, r2);
            let word = _mm512_set1_epi32(0xFFFF);
            let p = [
                _mm512_and_si512(top, word),
                _mm512_srli_epi32::<16>(top),
                _mm512_and_si512(low, word),
                _mm512_srli_epi32::<16>(low),
            ];
            let q = rounded16(blend16(f, p.map(|v| _mm512_cvtepi32_ps(v))));
            _mm256_storeu_si256(out as *mut __m256i, _mm512_cvtepi32_epi16(q));
        }
    }

    /// Two rows of 32 samples, one word permute (`vpermi2w`).
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &Rows16, plane: &[u16], out: *mut u16) {
        debug_assert!(rows.row_start(1) + 32 <= plane.len());
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen writable
        // at `out` (the contract).
        unsafe {
            let p = plane.as_ptr();
            let (a, b) = (
                _mm512_loadu_si512(p.add(rows.row_start(0)) as *const __m512i),
                _mm512_loadu_si512(p.add(rows.row_start(1)) as *const __m512i),
            );
            let place = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<5>(rows.row));
            let index = _mm512_castsi256_si512(_mm512_cvtepi32_epi16(place));
            let v = _mm512_permutex2var_epi16(a, index, b);
            _mm256_storeu_si256(out as *mut __m256i, _mm512_castsi512_si256(v));
        }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(
        k: &Consts,
        t: &Taps8,
        plane: &[u16],
        out: &mut [u16],
        at: usize,
        nodata: u16,
    ) {
        let base = plane.as_ptr() as *const i32;
        // SAFETY: samples off, off + 1 and off + w, off + w + 1 with off <= (h-2) w + (w-2): the
        // last is (h-1) w + w - 1 < w h.
        let (top, low) = unsafe {
            (
                _mm256_i32gather_epi32::<2>(base, t.off),
                _mm256_i32gather_epi32::<2>(base, _mm256_add_epi32(t.off, k.width)),
            )
        };
        let lo16 = _mm256_set1_epi32(0xFFFF);
        let p00 = _mm256_cvtepi32_ps(_mm256_and_si256(top, lo16));
        let p01 = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(top));
        let p10 = _mm256_cvtepi32_ps(_mm256_and_si256(low, lo16));
        let p11 = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(low));
        let q = rounded(k, t, blend(t, p00, p01, p10, p11), i32::from(nodata));
        // Lanes [q0..q3 q0..q3 | q4..q7 q4..q7] as u16, then the two low quarters together.
        let packed = _mm256_permute4x64_epi64::<0b1000>(_mm256_packus_epi32(q, q));
        debug_assert!(at + 8 <= out.len());
        // SAFETY: at + 8 <= out.len() (the contract): the 16-byte store stays inside.
        unsafe {
            _mm_storeu_si128(
                out.as_mut_ptr().add(at) as *mut __m128i,
                _mm256_castsi256_si128(packed),
            )
        };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row16(p: *const u16) -> [__m256; 2] {
        // SAFETY: the contract.
        let v = unsafe { _mm256_loadu_si256(p as *const __m256i) };
        [
            _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(_mm256_castsi256_si128(v))),
            _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(_mm256_extracti128_si256::<1>(v))),
        ]
    }

    /// (v + 0.5) truncated, saturated to [0, 65535] as `as u16` saturates.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn store8(v: __m256, out: &mut [u16]) {
        let q = _mm256_cvttps_epi32(_mm256_add_ps(v, _mm256_set1_ps(0.5)));
        // Lanes [q0..q3 q0..q3 | q4..q7 q4..q7] as u16, then the two low quarters together.
        let packed = _mm256_permute4x64_epi64::<0b1000>(_mm256_packus_epi32(q, q));
        debug_assert!(out.len() >= 8);
        // SAFETY: out.len() >= 8 (the contract).
        unsafe {
            _mm_storeu_si128(
                out.as_mut_ptr() as *mut __m128i,
                _mm256_castsi256_si128(packed),
            )
        };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row4(p: *const u16) -> __m128 {
        // SAFETY: four u16 from p are readable (the contract).
        let v = unsafe { _mm_loadl_epi64(p as *const __m128i) };
        _mm_cvtepi32_ps(_mm_cvtepu16_epi32(v))
    }
}
