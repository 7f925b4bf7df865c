//! The AVX-512 nearest steps over blocks all inside.

use super::offsets::Relative16;
use super::rows::Rows16;
use crate::warp::simd::avx2::positions::Relative;
use crate::warp::simd::avx2::sample::SimdSample;
use std::arch::x86_64::*;

/// Nearest over `whole` pixels, all inside, sixteen at a time into every output; returns where
/// it stopped (fewer than sixteen left).
///
/// # Safety
/// AVX-512 F, BW, VL, VBMI and VNNI; `whole` at most every output's length; every pixel
/// inside; every plane `size.0 * size.1` samples.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
pub(crate) unsafe fn nearest_inside16<T: SimdSample>(
    rel: &Relative,
    size: (i32, i32),
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    whole: usize,
) -> usize {
    // One band takes two rows (runs across more read sample by sample: measured faster for
    // gray8), several bands the type's wide layout where a step's pixels span more than two
    // rows (on two, the two-row permute: u8 rgb8 0.786 -> 0.725 ms, rgba8 0.854 -> 0.820).
    // SAFETY: the contract.
    unsafe {
        match planes.len() {
            1 => nearest_steps16::<T, false>(rel, size, planes, outs, whole),
            _ => nearest_steps16::<T, true>(rel, size, planes, outs, whole),
        }
    }
}

/// `nearest_inside16` with the rows of `nearest_rows16` or, if `WIDE`, `nearest_rows16_wide`
/// for steps on more than two rows.
///
/// # Safety
/// As `nearest_inside16`.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
#[inline]
unsafe fn nearest_steps16<T: SimdSample, const WIDE: bool>(
    rel: &Relative,
    size: (i32, i32),
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    whole: usize,
) -> usize {
    let z = Relative16::new(&rel.block, size.0);
    let mut at = [0u32; 16];
    // The pixel numbers of the step: 0..16, then 16 more each step (exact below 2^24).
    let (mut i, mut k, step) = (0, z.lanes, _mm512_set1_ps(16.0));
    // The origin's sample index, added to the floors' (inside pixels: never negative).
    let base = _mm512_set1_epi32(z.origin[1] * size.0 + z.origin[0]);
    let span = (T::ROW_SPAN, if WIDE { T::NEAREST_ROWS_WIDE } else { 2 });
    while i + 16 <= whole {
        let [ix, iy] = z.cols_rows16(k);
        k = _mm512_add_ps(k, step);
        if let Some(rows) = Rows16::of::<1>(ix, iy, z.origin, size, span) {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                debug_assert!(i + 16 <= out.len());
                // SAFETY: `Rows16::of` checked the rows; i + 16 <= whole <= the output's length.
                unsafe {
                    let at = out.as_mut_ptr().add(i);
                    if WIDE && rows.last > 1 {
                        T::nearest_rows16_wide(&rows, plane, at)
                    } else {
                        T::nearest_rows16(&rows, plane, at)
                    }
                };
            }
            i += 16;
            continue;
        }
        let idx = _mm512_add_epi32(_mm512_add_epi32(_mm512_mullo_epi32(iy, z.width), ix), base);
        // SAFETY: `at` holds sixteen u32. Two 256-bit stores: the scalar loads below then take
        // their values forwarded from them.
        unsafe {
            _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, _mm512_castsi512_si256(idx));
            _mm256_storeu_si256(
                at.as_mut_ptr().add(8) as *mut __m256i,
                _mm512_extracti64x4_epi64::<1>(idx),
            );
        }
        for (plane, out) in planes.iter().zip(outs.iter_mut()) {
            let (src, dst) = (plane.as_ptr(), out[i..i + 16].as_mut_ptr());
            for j in 0..16 {
                // SAFETY: j < 16; inside pixels' indices are below the plane's length; dst
                // holds sixteen. Volatile: with AVX-512 on, LLVM otherwise turns the sixteen
                // loads into gathers (vgatherqps), measured 45% slower (f32, rotated map).
                unsafe {
                    let a = std::ptr::read_volatile(at.as_ptr().add(j));
                    *dst.add(j) = std::ptr::read_volatile(src.add(a as usize));
                }
            }
        }
        i += 16;
    }
    i
}
