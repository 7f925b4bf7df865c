//! `SimdSample` for u8: byte windows and shuffles where they apply, integer bilinear weights.

use super::bicubic_lanes::{CubicWindow, cubic_sum8};
use super::bilinear_lanes::{Taps8, Window, bilinear_u8_8};
use super::lanes::{Consts, pack_low_bytes};
use super::nearest_lanes::NearestWindow;
use super::sample::SimdSample;
use crate::warp::simd::avx512::lanes::{bilinear_u8_16, rounded16};
use crate::warp::simd::avx512::rows::Rows16;
use std::arch::x86_64::*;

/// The 32 bytes from each of `rows`' four row starts as a byte permute's two tables: rows 0
/// and 1, rows 2 and 3 (byte 32 r + c is column c of row r).
///
/// # Safety
/// AVX-512 F; 32 bytes from each row start inside `plane` (`Rows16::of` with four rows).
#[target_feature(enable = "avx2,avx512f")]
#[inline]
unsafe fn byte_tables4(rows: &Rows16, plane: &[u8]) -> [__m512i; 2] {
    debug_assert!(rows.row_start(3) + 32 <= plane.len());
    // SAFETY: the contract.
    let row = |r: usize| unsafe {
        _mm256_loadu_si256(plane.as_ptr().add(rows.row_start(r)) as *const __m256i)
    };
    [0, 2].map(|r| _mm512_inserti64x4::<1>(_mm512_castsi256_si512(row(r)), row(r + 1)))
}

impl SimdSample for u8 {
    /// One 256-bit load, widened to two f32 vectors.
    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn row32(p: *const u8) -> [__m512; 2] {
        // SAFETY: the contract.
        let v = unsafe { _mm256_loadu_si256(p as *const __m256i) };
        let wide = |h: __m128i| _mm512_cvtepi32_ps(_mm512_cvtepu8_epi32(h));
        [
            wide(_mm256_castsi256_si128(v)),
            wide(_mm256_extracti128_si256::<1>(v)),
        ]
    }

    /// `store8` at sixteen lanes: (v + 0.5) truncated, saturated to [0, 255].
    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn store16(v: __m512, out: *mut u8) {
        let q = rounded16(v);
        let bytes = _mm512_cvtusepi32_epi8(_mm512_max_epi32(q, _mm512_setzero_si512()));
        // SAFETY: sixteen samples writable at `out` (the contract).
        unsafe { _mm_storeu_si128(out as *mut __m128i, bytes) };
    }

    const WINDOWS: bool = true;

    const ROW_SPAN: i32 = 32;

    /// Four rows of 32 bytes fill the permute's two tables (`nearest_rows16_wide`, used
    /// where several bands share the positions): pixels on four rows.
    const NEAREST_ROWS_WIDE: i32 = 4;

    /// Four rows of 32 bytes fill the permute's two tables: pixels on three rows.
    const BILINEAR_ROWS: i32 = 4;

    /// The four rows' 32 bytes as one 128-byte table; one byte permute brings each pixel's
    /// four taps into its 32-bit lane (bytes: upper pair, lower pair), as `window_pairs` does.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn bilinear_rows16<const SHARED: bool>(
        rows: &Rows16,
        f: (__m512, __m512),
        plane: &[u8],
        out: *mut u8,
    ) {
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen
        // writable at `out` (the contract).
        unsafe {
            let [a, b] = byte_tables4(rows, plane);
            let base = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<5>(rows.row));
            let index = _mm512_add_epi32(
                _mm512_mullo_epi32(base, _mm512_set1_epi32(0x0101_0101)),
                _mm512_set1_epi32(0x2120_0100),
            );
            let v = _mm512_permutex2var_epi8(a, index, b);
            let q = bilinear_u8_16::<SHARED>(v, f);
            _mm_storeu_si128(out as *mut __m128i, _mm512_cvtepi32_epi8(q));
        }
    }

    /// Two rows of 32 samples, one byte permute (`vpermi2b`) over the two 256-bit loads.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &Rows16, plane: &[u8], out: *mut u8) {
        debug_assert!(rows.row_start(1) + 32 <= plane.len());
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen writable
        // at `out` (the contract).
        unsafe {
            let row = |r: usize| {
                _mm256_loadu_si256(plane.as_ptr().add(rows.row_start(r)) as *const __m256i)
            };
            let (a, b) = (
                _mm512_castsi256_si512(row(0)),
                _mm512_castsi256_si512(row(1)),
            );
            let place = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<6>(rows.row));
            let index = _mm512_castsi128_si512(_mm512_cvtepi32_epi8(place));
            let v = _mm512_permutex2var_epi8(a, index, b);
            _mm_storeu_si128(out as *mut __m128i, _mm512_castsi512_si128(v));
        }
    }

    /// Four rows of 32 samples, two per table of one byte permute (`vpermi2b`).
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16_wide(rows: &Rows16, plane: &[u8], out: *mut u8) {
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen writable
        // at `out` (the contract).
        unsafe {
            let [a, b] = byte_tables4(rows, plane);
            let place = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<5>(rows.row));
            let index = _mm512_castsi128_si512(_mm512_cvtepi32_epi8(place));
            let v = _mm512_permutex2var_epi8(a, index, b);
            _mm_storeu_si128(out as *mut __m128i, _mm512_castsi512_si128(v));
        }
    }

    /// The taps are byte shuffles of 16-byte row loads, two tap columns per shuffle; rounded
    /// and saturated as `u8::from_f32`.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cubic_window8(
        k: &Consts,
        win: &CubicWindow,
        w: (&[__m256; 4], &[__m256; 4]),
        plane: &[u8],
        width: usize,
        out: &mut [u8],
    ) {
        debug_assert!(win.start + (win.rows - 1) * width + 16 <= plane.len() && out.len() >= 8);
        let rel = pack_low_bytes(k, win.rel);
        let plus = |c: i8| _mm_add_epi8(rel, _mm_set1_epi8(c));
        let ctrl = [
            _mm_unpacklo_epi64(rel, plus(1)),
            _mm_unpacklo_epi64(plus(2), plus(3)),
        ];
        let lower = pack_low_bytes(k, win.lower);
        let lower = _mm_unpacklo_epi64(lower, lower);
        // Branch-free: with four rows, the fifth is the fourth again (and `lower` all clear).
        // SAFETY: the contract.
        let row = |j: usize, ctrl: __m128i| unsafe {
            let v = _mm_loadu_si128(
                plane.as_ptr().add(win.start + j.min(win.rows - 1) * width) as *const __m128i
            );
            _mm_shuffle_epi8(v, ctrl)
        };
        let f32s = |v: __m128i| _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v));
        let split = |upper: __m128i, below: __m128i| {
            let v = _mm_blendv_epi8(upper, below, lower);
            [f32s(v), f32s(_mm_srli_si128::<8>(v))]
        };
        let v = cubic_sum8(w, |j, p| row(j, ctrl[p]), split);
        // SAFETY: out.len() >= 8 (the contract).
        unsafe { Self::store8(v, out) };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row16(p: *const u8) -> [__m256; 2] {
        // SAFETY: the contract.
        let v = unsafe { _mm_loadu_si128(p as *const __m128i) };
        [
            _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(v)),
            _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_srli_si128::<8>(v))),
        ]
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn store8(v: __m256, out: &mut [u8]) {
        let q = _mm256_cvttps_epi32(_mm256_add_ps(v, _mm256_set1_ps(0.5)));
        // Saturating packs (as `as u8` saturates; the second pack reads signed words, so they
        // are capped at 255 first): lanes 0..4 lead the low half, 4..8 the high one.
        let q16 = _mm256_min_epu16(_mm256_packus_epi32(q, q), _mm256_set1_epi16(255));
        let q8 = _mm256_packus_epi16(q16, q16);
        let bytes = _mm_unpacklo_epi32(
            _mm256_castsi256_si128(q8),
            _mm256_extracti128_si256::<1>(q8),
        );
        debug_assert!(out.len() >= 8);
        // SAFETY: out.len() >= 8 (the contract).
        unsafe { _mm_storel_epi64(out.as_mut_ptr() as *mut __m128i, bytes) };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(
        k: &Consts,
        t: &Taps8,
        plane: &[u8],
        out: &mut [u8],
        at: usize,
        nodata: u8,
    ) {
        let (top, low) = match &t.window {
            // SAFETY: `window` checked that `rows` rows of 16 bytes from `start` are inside.
            Some(win) => unsafe { window_pairs(win, plane, k.size.0 as usize) },
            None => {
                let base = plane.as_ptr() as *const i32;
                // SAFETY: off <= (h-2) w + (w-2), so the 4 bytes at off end by (h-1) w + 2 <= w h;
                // the lower pair is read at off + w - 2 >= 0 and ends by (h-2) w + (w-2) + w + 2.
                unsafe {
                    (
                        _mm256_i32gather_epi32::<1>(base, t.off),
                        _mm256_i32gather_epi32::<1>(base, _mm256_add_epi32(t.off, k.w_minus_2)),
                    )
                }
            }
        };
        // The upper pair is bytes 0 and 1 of `top`, the lower pair bytes 2 and 3 of `low`.
        let byte = _mm256_set1_epi32(0xFF);
        let p = [
            _mm256_and_si256(top, byte),
            _mm256_and_si256(_mm256_srli_epi32::<8>(top), byte),
            _mm256_and_si256(_mm256_srli_epi32::<16>(low), byte),
            _mm256_srli_epi32::<24>(low),
        ];
        let v = bilinear_u8_8(p, (t.fx, t.fy));
        let q = _mm256_blendv_epi8(_mm256_set1_epi32(i32::from(nodata)), v, t.lanes);
        let packed = pack_low_bytes(k, q);
        debug_assert!(at + 8 <= out.len());
        // SAFETY: at + 8 <= out.len() (the contract): the 8-byte store stays inside.
        unsafe { _mm_storel_epi64(out.as_mut_ptr().add(at) as *mut __m128i, packed) };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row4(p: *const u8) -> __m128 {
        // SAFETY: four bytes from p are readable (the contract).
        let v = unsafe { (p as *const i32).read_unaligned() };
        _mm_cvtepi32_ps(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(v)))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn nearest_window8(win: &NearestWindow, width: usize, plane: &[u8], out: &mut [u8]) {
        debug_assert!(win.start + (win.rows - 1) * width + 16 <= plane.len() && out.len() >= 8);
        // SAFETY: the contract: `rows` rows of 16 bytes from `start` are inside the plane.
        let row = |r: usize| unsafe {
            _mm_loadu_si128(plane.as_ptr().add(win.start + r * width) as *const __m128i)
        };
        // Branch-free: with one row, the "second" is the first again (and `first` all set).
        let v = _mm_shuffle_epi8(row(0), win.ctrl);
        let v = _mm_blendv_epi8(_mm_shuffle_epi8(row(win.rows - 1), win.ctrl), v, win.first);
        // SAFETY: out.len() >= 8 (the contract).
        unsafe { _mm_storel_epi64(out.as_mut_ptr() as *mut __m128i, v) };
    }
}

/// The upper pairs (bytes 0, 1 of each lane) and lower pairs (bytes 2, 3) of a window's taps,
/// as the gathers of `bilinear8` would bring them.
///
/// # Safety
/// AVX2; `win.rows` rows of 16 bytes from `win.start` (row stride `width`) are inside `plane`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn window_pairs(win: &Window, plane: &[u8], width: usize) -> (__m256i, __m256i) {
    // SAFETY: the contract.
    let row = |r: usize| unsafe {
        let p = plane.as_ptr().add(win.start + r * width) as *const __m128i;
        _mm256_broadcastsi128_si256(_mm_loadu_si128(p))
    };
    let (r0, r1) = (row(0), row(1));
    if win.rows == 2 {
        return (
            _mm256_shuffle_epi8(r0, win.top),
            _mm256_shuffle_epi8(r1, win.low),
        );
    }
    let r2 = row(2);
    let top = _mm256_blendv_epi8(
        _mm256_shuffle_epi8(r1, win.top),
        _mm256_shuffle_epi8(r0, win.top),
        win.first,
    );
    let low = _mm256_blendv_epi8(
        _mm256_shuffle_epi8(r2, win.low),
        _mm256_shuffle_epi8(r1, win.low),
        win.first,
    );
    (top, low)
}
