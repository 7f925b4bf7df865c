//! The AVX2 bicubic kernel: one block, through windows, taps and the pair kernel (sixteen-pixel
//! windows with AVX-512), border pixels through the portable kernel.

use super::bicubic_lanes::{CubicSplit8, CubicTap, cubic_window, keys_lanes, keys8};
use super::cubic_positions::CubicPositions;
use super::lanes::{Consts, pack_low_bytes};
use super::sample::SimdSample;
use crate::warp::portable::Bicubic;
use crate::warp::simd::avx512::bicubic::{bicubic_window16, cubic16_fits};
use crate::warp::types::{Kernel, SourceGeometry};
use std::arch::x86_64::*;

/// Bicubic for one block: the taps of `pos` (in `simd`), then every band; `valid` receives the
/// inside flags.
///
/// # Safety
/// AVX2; the source at least 4 x 4, every plane `g.width * g.height`; outputs as long as `pos`.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn bicubic_block<T: SimdSample, Q: CubicPositions>(
    g: &SourceGeometry,
    pos: &Q,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    valid: &mut [bool],
    cubic: (&mut [CubicTap], &mut [u32], &mut [u8]),
    nodata: T,
) {
    let n = pos.len();
    let (taps, bases, state) = (&mut cubic.0[..n], &mut cubic.1[..n], &mut cubic.2[..n]);
    let wide = g.avx512 && pos.buffered().is_some_and(cubic16_fits);
    if (T::CUBIC_WINDOWS || wide) && Q::MONOTONIC {
        // SAFETY: the contract.
        unsafe {
            bicubic_steps(
                g,
                pos,
                planes,
                outs,
                (&mut *taps, &mut *bases, &mut *state),
                nodata,
            )
        };
    } else {
        // SAFETY: the contract; the taps come from `bicubic_taps` on the same positions.
        unsafe { bicubic_taps(g, pos, taps, bases, state) };
        for (plane, o) in planes.iter().zip(outs.iter_mut()) {
            let taps = (&taps[..], &bases[..], &state[..]);
            // SAFETY: as above; n <= every slice's length.
            unsafe { bicubic_apply(g, plane, pos, taps, nodata, o, 0..n) };
        }
    }
    for (v, &s) in valid.iter_mut().zip(state.iter()) {
        *v = s != 0;
    }
}

/// Bicubic of a block step by step, on monotonic positions: each step of eight pixels
/// through a window (`cubic_window`) where one applies, else through the taps (`store_taps8`)
/// and the pair kernel; the tail through the portable kernel. `cubic` receives the states.
///
/// # Safety
/// As `bicubic_block`.
#[target_feature(enable = "avx2")]
unsafe fn bicubic_steps<T: SimdSample, Q: CubicPositions>(
    g: &SourceGeometry,
    pos: &Q,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    (taps, bases, state): (&mut [CubicTap], &mut [u32], &mut [u8]),
    nodata: T,
) {
    let n = pos.len().min(taps.len()).min(bases.len()).min(state.len());
    let k = Consts::new(g);
    let wide = if g.avx512 {
        pos.buffered().filter(|b| cubic16_fits(b))
    } else {
        None
    };
    let mut i = 0;
    while i + 8 <= n {
        if let Some(b) = wide.filter(|_| i + 16 <= n) {
            // SAFETY: `g.avx512`: the CPU has AVX-512 F, BW, VL, VBMI, VNNI; i + 16 <= n, within
            // the buffers (whole steps of eight) and every output; the planes as this contract.
            if unsafe { bicubic_window16(b, i, k.size, planes, outs) } {
                state[i..i + 16].fill(1);
                i += 16;
                continue;
            }
        }
        // SAFETY: i + 8 <= n.
        let s = unsafe { pos.cubic8(&k, i) };
        if let Some(win) = T::CUBIC_WINDOWS.then(|| cubic_window(&k, &s)).flatten() {
            let (wx, wy) = (keys_lanes(s.tx), keys_lanes(s.ty));
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: `cubic_window` checked the rows and columns; i + 8 <= n.
                unsafe {
                    T::cubic_window8(&k, &win, (&wx, &wy), plane, g.width(), &mut out[i..i + 8])
                };
            }
            state[i..i + 8].fill(1);
        } else {
            // SAFETY: i + 8 <= n, every slice's length; the taps of these pixels are written
            // before they are applied.
            unsafe {
                store_taps8(&k, &s, i, (&mut *taps, &mut *bases, &mut *state));
                for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                    let t = (&taps[..], &bases[..], &state[..]);
                    bicubic_apply(g, plane, pos, t, nodata, out, i..i + 8);
                }
            }
        }
        i += 8;
    }
    tail_states(g, pos, i, &mut state[..n]);
    for (plane, out) in planes.iter().zip(outs.iter_mut()) {
        let t = (&taps[..], &bases[..], &state[..]);
        // SAFETY: the tail's states are 0 or 2: only the portable kernel reads them.
        unsafe { bicubic_apply(g, plane, pos, t, nodata, out, i..n) };
    }
}

/// One band of bicubic from prepared taps over the pixels `range` of the block; border pixels
/// through the portable kernel.
///
/// # Safety
/// AVX2; `plane` holds `g.width * g.height` samples; taps and states from `bicubic_taps` (or
/// `store_taps8`) for the same positions `pos`; `range` within every slice's length.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn bicubic_apply<T: SimdSample, Q: CubicPositions>(
    g: &SourceGeometry,
    plane: &[T],
    pos: &Q,
    (taps, bases, state): (&[CubicTap], &[u32], &[u8]),
    nodata: T,
    out: &mut [T],
    range: std::ops::Range<usize>,
) {
    assert!(plane.len() == g.width() * g.height());
    assert!(range.end <= out.len().min(state.len()).min(taps.len()).min(bases.len()));
    let (w, p) = (g.width(), plane.as_ptr());
    let n = range.end;
    let mut k = range.start;
    while k + 2 <= n {
        // SAFETY: k + 1 < n <= every slice's length. Interior pixels (state 1): base =
        // (yi-1) w + xi-1 with 1 <= xi <= w-3, 1 <= yi <= h-3, so the four rows of four samples
        // end by (yi+2) w + xi+2 < w h = plane.len().
        unsafe {
            if *state.get_unchecked(k) == 1 && *state.get_unchecked(k + 1) == 1 {
                let pair = (taps.get_unchecked(k), taps.get_unchecked(k + 1));
                let at = (*bases.get_unchecked(k), *bases.get_unchecked(k + 1));
                let (a, b) = cubic2(p, w, pair, at);
                *out.get_unchecked_mut(k) = T::from_f32(a);
                *out.get_unchecked_mut(k + 1) = T::from_f32(b);
            } else {
                for j in k..k + 2 {
                    let v = bicubic_one(g, plane, pos, (taps, bases, state), j, nodata);
                    *out.get_unchecked_mut(j) = v;
                }
            }
        }
        k += 2;
    }
    if k < n {
        // SAFETY: k < n; as above.
        out[k] = unsafe { bicubic_one(g, plane, pos, (taps, bases, state), k, nodata) };
    }
}

/// Pixel `k` of `bicubic_apply` on its own (a pixel beside a border or outside one).
///
/// # Safety
/// As `bicubic_apply`; `k` below every slice's length.
#[target_feature(enable = "avx2")]
#[inline(never)]
#[cold]
unsafe fn bicubic_one<T: SimdSample, Q: CubicPositions>(
    g: &SourceGeometry,
    plane: &[T],
    pos: &Q,
    (taps, bases, state): (&[CubicTap], &[u32], &[u8]),
    k: usize,
    nodata: T,
) -> T {
    match state[k] {
        // SAFETY: an interior tap (the contract).
        1 => T::from_f32(unsafe { cubic1(plane.as_ptr(), g.width(), &taps[k], bases[k]) }),
        2 => {
            let mut tap = Default::default();
            let (x, y) = pos.at(k);
            Bicubic::prepare::<T>(g, x, y, &mut tap);
            Bicubic::apply(plane, g, &tap)
        }
        _ => nodata,
    }
}

/// Bicubic taps of a block: per pixel its state (0 outside, 1 interior, 2 border) and, for
/// interior pixels, the 4 x 4 neighbourhood's upper-left index and the weights.
///
/// # Safety
/// AVX2; the source at least 4 x 4.
#[target_feature(enable = "avx2")]
unsafe fn bicubic_taps<Q: CubicPositions>(
    g: &SourceGeometry,
    pos: &Q,
    taps: &mut [CubicTap],
    bases: &mut [u32],
    state: &mut [u8],
) {
    let n = pos.len().min(taps.len()).min(bases.len()).min(state.len());
    let k = Consts::new(g);
    let mut i = 0;
    while i + 8 <= n {
        // SAFETY: i + 8 <= n, every slice's length.
        unsafe {
            let s = pos.cubic8(&k, i);
            store_taps8(&k, &s, i, (&mut *taps, &mut *bases, &mut *state));
        }
        i += 8;
    }
    tail_states(g, pos, i, &mut state[..n]);
}

/// The bicubic taps of eight pixels from their split, written at `i` (`bicubic_taps`).
///
/// # Safety
/// AVX2; i + 8 <= every slice's length.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_taps8(
    k: &Consts,
    s: &CubicSplit8,
    i: usize,
    (taps, bases, state): (&mut [CubicTap], &mut [u32], &mut [u8]),
) {
    let one = _mm256_set1_epi32(1);
    let (w, h) = k.size;
    // Interior: 1 <= v <= last.
    let within = |v: __m256i, last: i32| {
        _mm256_andnot_si256(
            _mm256_or_si256(
                _mm256_cmpgt_epi32(one, v),
                _mm256_cmpgt_epi32(v, _mm256_set1_epi32(last)),
            ),
            _mm256_set1_epi32(-1),
        )
    };
    let wx = keys8(s.tx);
    let wy = keys8(s.ty);
    let interior = _mm256_and_si256(within(s.xi, w - 3), within(s.yi, h - 3));
    // 2 inside, 1 interior (interior pixels are inside: 2 - 1), 0 outside.
    let st = _mm256_add_epi32(_mm256_and_si256(s.inside, _mm256_set1_epi32(2)), interior);
    let st = pack_low_bytes(k, st);
    let base = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_sub_epi32(s.yi, one), k.width),
        _mm256_sub_epi32(s.xi, one),
    );
    debug_assert!(i + 8 <= taps.len().min(bases.len()).min(state.len()));
    // SAFETY: i + 8 <= bases.len(), state.len(), taps.len() (the contract); CubicTap is 16-byte
    // aligned with wx and wy [f32; 4] each.
    unsafe {
        _mm256_storeu_si256(bases.as_mut_ptr().add(i) as *mut __m256i, base);
        _mm_storel_epi64(state.as_mut_ptr().add(i) as *mut __m128i, st);
        let t = taps.as_mut_ptr().add(i);
        for p in 0..4 {
            let (lo, hi) = (&mut *t.add(p), &mut *t.add(p + 4));
            _mm_store_ps(lo.wx.as_mut_ptr(), _mm256_castps256_ps128(wx[p]));
            _mm_store_ps(hi.wx.as_mut_ptr(), _mm256_extractf128_ps::<1>(wx[p]));
            _mm_store_ps(lo.wy.as_mut_ptr(), _mm256_castps256_ps128(wy[p]));
            _mm_store_ps(hi.wy.as_mut_ptr(), _mm256_extractf128_ps::<1>(wy[p]));
        }
    }
}

/// The states of the pixels from `from` to the end of `state` through the portable kernel
/// (the tail of a block, fewer than eight).
fn tail_states<Q: CubicPositions>(g: &SourceGeometry, pos: &Q, from: usize, state: &mut [u8]) {
    for (p, st) in state.iter_mut().enumerate().skip(from) {
        let mut tap = Default::default();
        let (x, y) = pos.at(p);
        *st = if Bicubic::prepare::<f32>(g, x, y, &mut tap) {
            2
        } else {
            0
        };
    }
}

/// One interior bicubic pixel (`Bicubic::apply`'s order: vertical, then (h0 + h2) + (h1 + h3)).
///
/// # Safety
/// AVX2; `t` an interior tap of `bicubic_taps` for a source of width `w` whose samples start at
/// `p`: the four rows of four samples from `t.base` on are inside the plane.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn cubic1<T: SimdSample>(p: *const T, w: usize, t: &CubicTap, b: u32) -> f32 {
    let b = b as usize;
    // SAFETY: the contract.
    unsafe {
        let wy = _mm_load_ps(t.wy.as_ptr());
        let r = |j: usize| T::row4(p.add(b + j * w));
        let m0 = _mm_mul_ps(r(0), _mm_permute_ps::<0x00>(wy));
        let m1 = _mm_mul_ps(r(1), _mm_permute_ps::<0x55>(wy));
        let m2 = _mm_mul_ps(r(2), _mm_permute_ps::<0xAA>(wy));
        let m3 = _mm_mul_ps(r(3), _mm_permute_ps::<0xFF>(wy));
        let col = _mm_add_ps(_mm_add_ps(_mm_add_ps(m0, m1), m2), m3);
        let h = _mm_mul_ps(col, _mm_load_ps(t.wx.as_ptr()));
        let pairs = _mm_add_ps(h, _mm_movehl_ps(h, h));
        _mm_cvtss_f32(_mm_add_ss(pairs, _mm_movehdup_ps(pairs)))
    }
}

/// Two interior bicubic pixels at once, one per 128-bit half (same arithmetic as `cubic1`).
///
/// # Safety
/// As `cubic1` for both taps.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn cubic2<T: SimdSample>(
    p: *const T,
    w: usize,
    (a, b): (&CubicTap, &CubicTap),
    (ba, bb): (u32, u32),
) -> (f32, f32) {
    let (ba, bb) = (ba as usize, bb as usize);
    // SAFETY: the contract.
    unsafe {
        let wy = _mm256_set_m128(_mm_load_ps(b.wy.as_ptr()), _mm_load_ps(a.wy.as_ptr()));
        let wx = _mm256_set_m128(_mm_load_ps(b.wx.as_ptr()), _mm_load_ps(a.wx.as_ptr()));
        let r = |j: usize| _mm256_set_m128(T::row4(p.add(bb + j * w)), T::row4(p.add(ba + j * w)));
        let m0 = _mm256_mul_ps(r(0), _mm256_permute_ps::<0x00>(wy));
        let m1 = _mm256_mul_ps(r(1), _mm256_permute_ps::<0x55>(wy));
        let m2 = _mm256_mul_ps(r(2), _mm256_permute_ps::<0xAA>(wy));
        let m3 = _mm256_mul_ps(r(3), _mm256_permute_ps::<0xFF>(wy));
        let col = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(m0, m1), m2), m3);
        let h = _mm256_mul_ps(col, wx);
        let pairs = _mm256_add_ps(h, _mm256_permute_ps::<0b11_10_11_10>(h));
        let sum = _mm256_add_ps(pairs, _mm256_movehdup_ps(pairs));
        (
            _mm256_cvtss_f32(sum),
            _mm_cvtss_f32(_mm256_extractf128_ps::<1>(sum)),
        )
    }
}
