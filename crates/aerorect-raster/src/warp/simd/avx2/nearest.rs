//! The AVX2 nearest kernel: one block, eight pixels per step (sixteen with AVX-512 where the
//! block is all inside).

use super::lanes::{Consts, store_flags};
use super::nearest_lanes::{NearestTaps, nearest_window};
use super::positions::{Positions, inside_run};
use super::sample::SimdSample;
use crate::raster::Sample;
use crate::warp::portable::Nearest;
use crate::warp::simd::avx512::nearest::nearest_inside16;
use crate::warp::types::SourceGeometry;
use std::arch::x86_64::*;

/// Nearest for one block (`Nearest::prepare` and `apply`): `pos` the source positions,
/// `planes` the source bands, `outs` the destination bands (as long as `pos`); `valid` receives
/// the inside flags. Eight indices at a time, then one scalar load per pixel and band, straight
/// into the output (no index buffer, no insert chain); u8 with three bands or more reads byte
/// windows where they apply (`nearest_window`), whose set-up costs about what eight scalar loads
/// do.
///
/// # Safety
/// AVX2; every plane `g.width * g.height` samples.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn nearest_block<T: SimdSample, P: Positions>(
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    valid: &mut [bool],
    nodata: T,
) {
    let from = match T::WINDOWS && planes.len() >= 3 {
        // SAFETY: this function's contract.
        true => unsafe { nearest_steps::<T, P, true>(g, pos, planes, outs, valid, nodata) },
        false => unsafe { nearest_steps::<T, P, false>(g, pos, planes, outs, valid, nodata) },
    };
    pos.tail(from)
        .run::<Nearest, T>(g, planes, outs, valid, nodata);
}

/// The whole eight-pixel steps of `nearest_block`, with or without windows; returns where the
/// tail starts.
///
/// # Safety
/// As `nearest_block`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn nearest_steps<T: SimdSample, P: Positions, const WINDOWS: bool>(
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    valid: &mut [bool],
    nodata: T,
) -> usize {
    let n = pos.len().min(valid.len());
    let k = Consts::new(g);
    if let Some(whole) = inside_run(&k, pos, n) {
        valid[..whole].fill(true);
        // SAFETY: this function's contract; every pixel of the whole steps is inside.
        unsafe { nearest_inside::<T, P, WINDOWS>(&k, g, pos, planes, outs, whole) };
        return whole;
    }
    let mut at = [0u32; 8];
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: i + 8 <= n.
        let NearestTaps { idx, ix, iy, mask } = unsafe { pos.nearest8(&k, i) };
        if WINDOWS
            && mask == 0xFF
            && let Some(win) = nearest_window(&k, ix, iy, P::MONOTONIC)
        {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: `nearest_window` checked the rows; i + 8 <= n = the output's length.
                unsafe { T::nearest_window8(&win, g.width(), plane, &mut out[i..i + 8]) };
            }
            store_flags(valid, i, mask);
            i += 8;
            continue;
        }
        // SAFETY: `at` holds eight u32.
        unsafe { _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, idx) };
        for (plane, out) in planes.iter().zip(outs.iter_mut()) {
            let out = &mut out[i..i + 8];
            if mask == 0 {
                out.fill(nodata);
                continue;
            }
            // SAFETY: indices are clamped into [0, w - 1] x [0, h - 1]: below plane.len().
            unsafe { scalar_nearest8(plane, &at, mask, out, nodata) };
        }
        store_flags(valid, i, mask);
        i += 8;
    }
    i
}

/// `nearest_steps` over `whole` pixels all inside: no inside test, no nodata. Where the CPU has
/// AVX-512 (and the positions are fused), sixteen at a time (`avx512::nearest_inside16`); the
/// rest goes eight at a time (`nearest_inside_range`).
///
/// # Safety
/// As `nearest_block`; `whole` a multiple of eight, at most every output's length, and every
/// pixel of it inside the image.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn nearest_inside<T: SimdSample, P: Positions, const WINDOWS: bool>(
    k: &Consts,
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    whole: usize,
) {
    let i = match (g.avx512, pos.relative()) {
        // SAFETY: `g.avx512`: the CPU has AVX-512 F, BW, VL, VBMI, VNNI; as this function's
        // contract.
        (true, Some(rel)) => unsafe { nearest_inside16(rel, k.size, planes, outs, whole) },
        _ => 0,
    };
    // SAFETY: as this function's contract.
    unsafe { nearest_inside_range::<T, P, WINDOWS>(k, g, pos, planes, outs, i..whole) };
}

/// `nearest_inside` over the pixels `range` (whole steps), eight at a time with the AVX2 build.
/// One band reads and writes through its own two pointers (kept in registers, not reloaded per
/// step).
///
/// # Safety
/// As `nearest_inside`; `range` whole steps within `whole`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn nearest_inside_range<T: SimdSample, P: Positions, const WINDOWS: bool>(
    k: &Consts,
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    range: std::ops::Range<usize>,
) {
    let mut at = [0u32; 8];
    if let ([plane], [out]) = (planes, &mut *outs) {
        debug_assert!(range.end <= out.len());
        let (src, dst) = (plane.as_ptr(), out.as_mut_ptr());
        let mut i = range.start;
        while i < range.end {
            // SAFETY: i + 8 <= whole <= len; the pixels are inside (the contract), so every
            // index is below the plane's length; i + 8 <= the output's length.
            unsafe {
                let [idx, ..] = pos.nearest_inside8(k, i);
                _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, idx);
                for j in 0..8 {
                    // Read back through memory: left alone, LLVM extracts the lanes instead
                    // (vpextrd, two micro-ops each), measured 2% (u8) to 11% (f32) slower.
                    let a = std::ptr::read_volatile(at.as_ptr().add(j));
                    *dst.add(i + j) = *src.add(a as usize);
                }
            }
            i += 8;
        }
        return;
    }
    for i in range.step_by(8) {
        // SAFETY: i + 8 <= whole <= len; the pixels are inside (the contract).
        let [idx, ix, iy] = unsafe { pos.nearest_inside8(k, i) };
        if WINDOWS && let Some(win) = nearest_window(k, ix, iy, P::MONOTONIC) {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: `nearest_window` checked the rows; i + 8 <= whole <= the length.
                unsafe { T::nearest_window8(&win, g.width(), plane, &mut out[i..i + 8]) };
            }
            continue;
        }
        // SAFETY: `at` holds eight u32.
        unsafe { _mm256_storeu_si256(at.as_mut_ptr() as *mut __m256i, idx) };
        for (plane, out) in planes.iter().zip(outs.iter_mut()) {
            for (d, &a) in out[i..i + 8].iter_mut().zip(at.iter()) {
                debug_assert!((a as usize) < plane.len());
                // SAFETY: inside pixels' indices are below the plane's length.
                *d = unsafe { *plane.get_unchecked(a as usize) };
            }
        }
    }
}

/// Nearest at eight pixels by scalar loads (they beat a gather on single samples): the
/// samples at `at`, nodata where `mask` is clear, written to `out[..8]`.
///
/// # Safety
/// Every index in `at` below `plane.len()`; `out.len() >= 8`.
#[inline(always)]
unsafe fn scalar_nearest8<T: Sample>(
    plane: &[T],
    at: &[u32; 8],
    mask: i32,
    out: &mut [T],
    nodata: T,
) {
    for (d, &a) in out.iter_mut().zip(at.iter()) {
        debug_assert!((a as usize) < plane.len());
        // SAFETY: a < plane.len() (the contract).
        *d = unsafe { *plane.get_unchecked(a as usize) };
    }
    let mut outside = !mask & 0xFF;
    while outside != 0 {
        out[outside.trailing_zeros() as usize] = nodata;
        outside &= outside - 1;
    }
}
