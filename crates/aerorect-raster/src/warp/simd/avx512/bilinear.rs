//! The AVX-512 bilinear steps over blocks all inside.

use super::rows::Rows16;
use crate::warp::simd::avx2::bilinear_lanes::{Taps8, window};
use crate::warp::simd::avx2::lanes::Consts;
use crate::warp::simd::avx2::positions::{Buffered, Relative};
use crate::warp::simd::avx2::sample::SimdSample;
use std::arch::x86_64::*;

/// Bilinear over `whole` pixels of buffered positions, all inside, sixteen at a time into
/// every output; returns where it stopped (fewer than sixteen left). Steps whose taps do not
/// lie within `Rows16` go as two AVX2 steps.
///
/// # Safety
/// AVX-512 F, BW, VL, VBMI and VNNI; the source at least 2 x 2; `whole` at most every output's
/// length and the buffers'; every pixel inside; every plane `k.size.0 * k.size.1` samples.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
pub(crate) unsafe fn bilinear_inside16<T: SimdSample>(
    k: &Consts,
    pos: &Buffered<'_>,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    whole: usize,
    nodata: T,
) -> usize {
    // SAFETY: the contract, passed on.
    unsafe {
        if planes.len() > 1 {
            bilinear_steps16::<T, true>(k, pos, planes, outs, whole, nodata)
        } else {
            bilinear_steps16::<T, false>(k, pos, planes, outs, whole, nodata)
        }
    }
}

/// `bilinear_inside16` with `SHARED` true where several bands share each step's weights.
///
/// # Safety
/// As `bilinear_inside16`.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
unsafe fn bilinear_steps16<T: SimdSample, const SHARED: bool>(
    k: &Consts,
    pos: &Buffered<'_>,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    whole: usize,
    nodata: T,
) -> usize {
    let split = Split16::new(pos.rel, k.size);
    let free = split.never_clamps(pos, whole);
    let mut i = 0;
    while i + 16 <= whole {
        debug_assert!(i + 16 <= pos.px.len() && i + 16 <= pos.py.len());
        // SAFETY: i + 16 <= whole <= the buffers' length.
        let (x, y) = unsafe {
            (
                _mm512_loadu_ps(pos.px.as_ptr().add(i)),
                _mm512_loadu_ps(pos.py.as_ptr().add(i)),
            )
        };
        let ((x0, fx), (y0, fy)) = if free {
            (split.axis_free(x, 0), split.axis_free(y, 1))
        } else {
            (split.axis(x, 0), split.axis(y, 1))
        };
        if let Some(rows) = Rows16::of::<2>(x0, y0, [0, 0], k.size, (T::ROW_SPAN, T::BILINEAR_ROWS))
        {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                debug_assert!(i + 16 <= out.len());
                // SAFETY: `Rows16::of` checked the rows; i + 16 <= whole <= the length.
                unsafe {
                    T::bilinear_rows16::<SHARED>(&rows, (fx, fy), plane, out.as_mut_ptr().add(i))
                };
            }
        } else {
            let taps = taps8_pair::<T>(k, (x0, fx), (y0, fy));
            for (h, t) in [i, i + 8].into_iter().zip(taps.iter()) {
                for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                    // SAFETY: as this function's contract; h + 8 <= every output's length.
                    unsafe { T::bilinear8(k, t, plane, out, h, nodata) };
                }
            }
        }
        i += 16;
    }
    i
}

/// The AVX2 taps (`Relative::bilinear_taps::<true>`) of pixels 0..8 and 8..16 of a split.
#[target_feature(enable = "avx2,avx512f")]
#[inline]
fn taps8_pair<T: SimdSample>(
    k: &Consts,
    (x0, fx): (__m512i, __m512),
    (y0, fy): (__m512i, __m512),
) -> [Taps8; 2] {
    let off = _mm512_add_epi32(_mm512_mullo_epi32(y0, _mm512_set1_epi32(k.size.0)), x0);
    let half = |v: __m512i, h: usize| match h {
        0 => _mm512_castsi512_si256(v),
        _ => _mm512_extracti64x4_epi64::<1>(v),
    };
    let half_ps = |v: __m512, h: usize| _mm256_castsi256_ps(half(_mm512_castps_si512(v), h));
    [0, 1].map(|h| {
        let (x, y) = (half(x0, h), half(y0, h));
        Taps8 {
            off: half(off, h),
            fx: half_ps(fx, h),
            fy: half_ps(fy, h),
            lanes: _mm256_set1_epi32(-1),
            mask: 0xFF,
            window: if T::WINDOWS {
                window(k, x, y, true)
            } else {
                None
            },
        }
    })
}

/// `Relative::bilinear_taps`'s split of offsets into upper-left neighbours and fractions
/// (`left_neighbour`), at sixteen lanes.
struct Split16 {
    cmin: [__m512; 2],
    cmax: [__m512; 2],
    /// `cmin` and `cmax` as numbers (the block's offsets' clamp).
    bounds: [(f32, f32); 2],
    origin: [__m512i; 2],
    /// The last upper-left column and row: width - 2, height - 2.
    imax: [__m512i; 2],
}

impl Split16 {
    #[target_feature(enable = "avx512f")]
    fn new(rel: &Relative, size: (i32, i32)) -> Self {
        let wide = |v: __m256| _mm512_castsi512_ps(_mm512_broadcast_i64x4(_mm256_castps_si256(v)));
        let first = |v: __m256| _mm256_cvtss_f32(v);
        Self {
            cmin: rel.cmin.map(wide),
            cmax: rel.cmax.map(wide),
            bounds: [0, 1].map(|a| (first(rel.cmin[a]), first(rel.cmax[a]))),
            origin: rel.origin.map(|v| _mm512_broadcast_i64x4(v)),
            imax: [_mm512_set1_epi32(size.0 - 2), _mm512_set1_epi32(size.1 - 2)],
        }
    }

    /// Whether the buffered offsets of pixels 0..`whole` all lie in [cmin, cmax) on both axes
    /// (monotonic along the block: the first and the last decide): the clamp then changes
    /// nothing, and the upper-left neighbour is at most size - 2, so the cap does not either.
    fn never_clamps(&self, pos: &Buffered<'_>, whole: usize) -> bool {
        let within = |buf: &[f32], (lo, hi): (f32, f32)| match (buf.first(), buf.get(whole - 1)) {
            (Some(&a), Some(&b)) => [a, b].iter().all(|&p| p >= lo && p < hi),
            _ => false,
        };
        whole > 0 && within(pos.px, self.bounds[0]) && within(pos.py, self.bounds[1])
    }

    /// `axis` where `never_clamps`: floor and fraction alone, the same values.
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn axis_free(&self, p: __m512, a: usize) -> (__m512i, __m512) {
        let f = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(p);
        let rel = _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(p);
        (_mm512_add_epi32(rel, self.origin[a]), _mm512_sub_ps(p, f))
    }

    /// The upper-left neighbours and fractions of offsets `p` on axis `a`: clamp, floor (with
    /// the conversion, exact here), origin added and capped, fraction against the capped one.
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn axis(&self, p: __m512, a: usize) -> (__m512i, __m512) {
        let c = _mm512_min_ps(_mm512_max_ps(p, self.cmin[a]), self.cmax[a]);
        let rel = _mm512_cvt_roundps_epi32::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(c);
        let i0 = _mm512_min_epi32(_mm512_add_epi32(rel, self.origin[a]), self.imax[a]);
        let back = _mm512_cvtepi32_ps(_mm512_sub_epi32(i0, self.origin[a]));
        (i0, _mm512_sub_ps(c, back))
    }
}
