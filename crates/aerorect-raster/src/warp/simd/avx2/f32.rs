//! `SimdSample` for f32.

use super::bilinear_lanes::{Taps8, blend};
use super::lanes::Consts;
use super::sample::SimdSample;
use crate::warp::simd::avx512::lanes::blend16;
use crate::warp::simd::avx512::rows::Rows16;
use std::arch::x86_64::*;

impl SimdSample for f32 {
    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn row32(p: *const f32) -> [__m512; 2] {
        // SAFETY: the contract.
        unsafe { [_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16))] }
    }

    #[target_feature(enable = "avx2,avx512f")]
    #[inline]
    unsafe fn store16(v: __m512, out: *mut f32) {
        // SAFETY: sixteen samples writable at `out` (the contract).
        unsafe { _mm512_storeu_ps(out, v) };
    }

    const ROW_SPAN: i32 = 32;

    /// Per row two 16-sample vectors, one permute per row and tap column; the upper and
    /// lower taps then blended by each pixel's upper row.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn bilinear_rows16<const SHARED: bool>(
        rows: &Rows16,
        f: (__m512, __m512),
        plane: &[f32],
        out: *mut f32,
    ) {
        debug_assert!(rows.row_start(2) + 32 <= plane.len());
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen
        // writable at `out` (the contract).
        unsafe {
            let row = |r: usize| {
                let q = plane.as_ptr().add(rows.row_start(r));
                (_mm512_loadu_ps(q), _mm512_loadu_ps(q.add(16)))
            };
            let col1 = _mm512_add_epi32(rows.col, _mm512_set1_epi32(1));
            let pick = |r: (__m512, __m512), c: __m512i| _mm512_permutex2var_ps(r.0, c, r.1);
            let (r0, r1, r2) = (row(0), row(1), row(2));
            let (b0, b1) = (pick(r1, rows.col), pick(r1, col1));
            let second = _mm512_cmpgt_epi32_mask(rows.row, _mm512_setzero_si512());
            let p = [
                _mm512_mask_blend_ps(second, pick(r0, rows.col), b0),
                _mm512_mask_blend_ps(second, pick(r0, col1), b1),
                _mm512_mask_blend_ps(second, b0, pick(r2, rows.col)),
                _mm512_mask_blend_ps(second, b1, pick(r2, col1)),
            ];
            _mm512_storeu_ps(out, blend16(f, p));
        }
    }

    /// Where the columns lie within 16: one permute over 16 samples of each row; else two
    /// rows of 32 (two vectors each), one permute per row, blended by row.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &Rows16, plane: &[f32], out: *mut f32) {
        debug_assert!(rows.row_start(1) + 32 <= plane.len());
        // SAFETY: `Rows16::of`: 32 samples from each row start in the plane; sixteen writable
        // at `out` (the contract).
        unsafe {
            let p = plane.as_ptr();
            let load = |r: usize, c: usize| _mm512_loadu_ps(p.add(rows.row_start(r) + c));
            let v = match rows.cols <= 16 {
                true => {
                    let place = _mm512_add_epi32(rows.col, _mm512_slli_epi32::<4>(rows.row));
                    _mm512_permutex2var_ps(load(0, 0), place, load(1, 0))
                }
                false => {
                    let row = |r: usize| _mm512_permutex2var_ps(load(r, 0), rows.col, load(r, 16));
                    let second = _mm512_cmpgt_epi32_mask(rows.row, _mm512_setzero_si512());
                    _mm512_mask_blend_ps(second, row(0), row(1))
                }
            };
            _mm512_storeu_ps(out, v);
        }
    }

    const CUBIC_WINDOWS: bool = false;

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(
        k: &Consts,
        t: &Taps8,
        plane: &[f32],
        out: &mut [f32],
        at: usize,
        nodata: f32,
    ) {
        let base = plane.as_ptr() as *const f64;
        let below = _mm256_add_epi32(t.off, k.width);
        let (off_lo, off_hi) = (
            _mm256_castsi256_si128(t.off),
            _mm256_extracti128_si256::<1>(t.off),
        );
        let (below_lo, below_hi) = (
            _mm256_castsi256_si128(below),
            _mm256_extracti128_si256::<1>(below),
        );
        // SAFETY: as for u16: pairs off, off + 1 and off + w, off + w + 1 end below w h.
        let (t_lo, t_hi, b_lo, b_hi) = unsafe {
            (
                _mm256_i32gather_pd::<4>(base, off_lo),
                _mm256_i32gather_pd::<4>(base, off_hi),
                _mm256_i32gather_pd::<4>(base, below_lo),
                _mm256_i32gather_pd::<4>(base, below_hi),
            )
        };
        // Pairs (a0 a1 b0 b1 | c0 c1 d0 d1), (e.. f.. | g.. h..) -> evens and odds in pixel order.
        let deal = |lo: __m256d, hi: __m256d| {
            let (lo, hi) = (_mm256_castpd_ps(lo), _mm256_castpd_ps(hi));
            let order =
                |v: __m256| _mm256_castpd_ps(_mm256_permute4x64_pd::<0xD8>(_mm256_castps_pd(v)));
            (
                order(_mm256_shuffle_ps::<0x88>(lo, hi)),
                order(_mm256_shuffle_ps::<0xDD>(lo, hi)),
            )
        };
        let (p00, p01) = deal(t_lo, t_hi);
        let (p10, p11) = deal(b_lo, b_hi);
        let v = blend(t, p00, p01, p10, p11);
        let v = _mm256_blendv_ps(_mm256_set1_ps(nodata), v, _mm256_castsi256_ps(t.lanes));
        debug_assert!(at + 8 <= out.len());
        // SAFETY: at + 8 <= out.len() (the contract).
        unsafe { _mm256_storeu_ps(out.as_mut_ptr().add(at), v) };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row16(p: *const f32) -> [__m256; 2] {
        // SAFETY: the contract.
        unsafe { [_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8))] }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn store8(v: __m256, out: &mut [f32]) {
        debug_assert!(out.len() >= 8);
        // SAFETY: out.len() >= 8 (the contract).
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn row4(p: *const f32) -> __m128 {
        // SAFETY: four f32 from p are readable (the contract).
        unsafe { _mm_loadu_ps(p) }
    }
}
