//! AVX-512 (F, BW, VL, VBMI, VNNI) steps over blocks whose pixels are all inside, sixteen pixels
//! per 512-bit vector, each the arithmetic of its AVX2 counterpart in the same order:
//! - nearest: the positions of `Relative::offsets8` (`Relative16`), and per band the sixteen
//!   samples as a two-table permute of two source rows (u8 with several bands: four) where
//!   they lie within them (`Rows16`, `SimdSample::nearest_rows16`), else one scalar load each;
//! - bilinear: the split of `Relative::bilinear_taps` on buffered offsets (`Split16`), and per
//!   band the four taps as permutes of three (u8: four) source rows where they lie within them
//!   (`Rows16` again, `SimdSample::bilinear_rows16`), blended at sixteen lanes (u8 in integers,
//!   `bilinear_u8_16`: with several bands, byte dot products on weight digits made once per
//!   step); else two AVX2
//!   steps on the same taps. Where no offset of the block is clamped, the split is a floor and
//!   a fraction alone (`Split16::axis_free`);
//! - bicubic (u16, f32): the split of `Buffered::cubic8` (`CubicSplit16`), the Keys weights
//!   (`keys16`), and per band each tap column as a two-table permute of each of up to six
//!   source rows of 32 samples (`CubicWindow16`), summed in `cubic_sum8`'s order;
//! - the buffered offsets themselves, sixteen at a time (`fill_offsets16`).

use super::{Buffered, Consts, Relative, SimdSample, Taps8, window};
use crate::raster::U8_WEIGHT_BITS;
use std::arch::x86_64::*;

/// `Relative`'s vectors at sixteen lanes.
pub(super) struct Relative16 {
    first: [__m512; 2],
    slope: [__m512; 2],
    c: __m512,
    one: __m512,
    lanes: __m512,
    /// The block's integer origin (column, row), added to the floors by their users.
    pub(super) origin: [i32; 2],
    width: __m512i,
}

impl Relative16 {
    #[target_feature(enable = "avx512f")]
    pub(super) fn new(rel: &Relative, width: i32) -> Self {
        let b = &rel.block;
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
    pub(super) fn cols_rows16(&self, k: __m512) -> [__m512i; 2] {
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
pub(super) unsafe fn fill_offsets16(rel: &Relative, px: &mut [f32], py: &mut [f32]) -> usize {
    let z = Relative16::new(rel, 0);
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

/// The first and last lanes of sixteen, in order (the extremes where they are monotonic).
#[target_feature(enable = "avx512f")]
#[inline]
fn ends16(v: __m512i) -> (i32, i32) {
    let a = _mm_cvtsi128_si32(_mm512_castsi512_si128(v));
    let b = _mm_extract_epi32::<3>(_mm512_extracti32x4_epi32::<3>(v));
    (a.min(b), a.max(b))
}

/// Where sixteen pixels' taps lie in source rows of `span` samples from column `xs` on: a
/// pixel takes `TAPS` adjacent samples (1 nearest, 2 bilinear) from its row and, for bilinear,
/// from the row below; its row is `ymin` or one of the next.
pub(crate) struct Rows16 {
    /// The offset of the sample at column `xs` of row `ymin` ...
    start: usize,
    /// ... the row stride, and the last row read (from `ymin` on).
    width: usize,
    last: usize,
    /// Per pixel: its (first) column minus `xs`, so that its taps lie in [0, span) ...
    pub(crate) col: __m512i,
    /// ... and its row minus `ymin`, so that its taps lie in rows [0, `rows`).
    pub(crate) row: __m512i,
    /// The columns read: the largest `col` + `TAPS`.
    pub(crate) cols: i32,
}

impl Rows16 {
    /// The rows of sixteen pixels at monotonic (first) columns `origin[0] + x` and rows
    /// `origin[1] + y`, all of whose taps are inside a `size` image, if their taps lie within
    /// `span` columns and `rows` rows (at most 4).
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(crate) fn of<const TAPS: i32>(
        x: __m512i,
        y: __m512i,
        origin: [i32; 2],
        size: (i32, i32),
        (span, rows): (i32, i32),
    ) -> Option<Self> {
        debug_assert!(rows <= 4);
        let w = size.0;
        let at = |v, o: i32| {
            let (lo, hi) = ends16(v);
            (lo + o, hi + o)
        };
        let ((xmin, xmax), (ymin, ymax)) = (at(x, origin[0]), at(y, origin[1]));
        // The first column: xmin, or less where `span` samples from xmin pass the row's end.
        let xs = xmin.min(w - span);
        let last = ymax - ymin + TAPS - 1;
        if xs < 0 || xmax + TAPS - xs > span || last >= rows {
            return None;
        }
        Some(Self {
            start: (ymin * w + xs) as usize,
            width: w as usize,
            last: last as usize,
            col: _mm512_sub_epi32(x, _mm512_set1_epi32(xs - origin[0])),
            row: _mm512_sub_epi32(y, _mm512_set1_epi32(ymin - origin[1])),
            cols: xmax + TAPS - xs,
        })
    }

    /// The offset of row `r` from `ymin` on, the last row read where `r` passes it.
    #[inline]
    pub(crate) fn row_start(&self, r: usize) -> usize {
        self.start + r.min(self.last) * self.width
    }
}

/// Nearest over `whole` pixels, all inside, sixteen at a time into every output; returns where
/// it stopped (fewer than sixteen left).
///
/// # Safety
/// AVX-512 F, BW, VL, VBMI and VNNI; `whole` at most every output's length; every pixel
/// inside; every plane `size.0 * size.1` samples.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
pub(super) unsafe fn nearest_inside16<T: SimdSample>(
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
    let z = Relative16::new(rel, size.0);
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

/// Bilinear over `whole` pixels of buffered positions, all inside, sixteen at a time into
/// every output; returns where it stopped (fewer than sixteen left). Steps whose taps do not
/// lie within `Rows16` go as two AVX2 steps.
///
/// # Safety
/// AVX-512 F, BW, VL, VBMI and VNNI; the source at least 2 x 2; `whole` at most every output's
/// length and the buffers'; every pixel inside; every plane `k.size.0 * k.size.1` samples.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
pub(super) unsafe fn bilinear_inside16<T: SimdSample>(
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
struct Digits16([__m512i; 3]);

impl Digits16 {
    #[target_feature(enable = "avx512f,avx512bw,avx512vbmi,avx512vnni")]
    #[inline]
    fn new(f: (__m512, __m512)) -> Self {
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
fn weights_u8_16((fx, fy): (__m512, __m512)) -> [__m512i; 4] {
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

/// The split of sixteen bicubic positions (`Buffered::cubic8`'s, same operations): the floors
/// of the offsets clamped to [-1 - origin, size - origin], plus the origin, and the fractions.
struct CubicSplit16 {
    xi: __m512i,
    yi: __m512i,
    tx: __m512,
    ty: __m512,
}

impl CubicSplit16 {
    /// The split of buffered pixels i..i + 16.
    ///
    /// # Safety
    /// AVX-512 F; i + 16 <= both buffers' length.
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn at(pos: &Buffered<'_>, i: usize, size: (i32, i32)) -> Self {
        debug_assert!(i + 16 <= pos.px.len() && i + 16 <= pos.py.len());
        let split = |buf: &[f32], a: usize, n: i32| {
            // SAFETY: i + 16 <= the buffer's length (the contract).
            let p = unsafe { _mm512_loadu_ps(buf.as_ptr().add(i)) };
            let o = pos.rel.block.origin[a];
            let lo = _mm512_set1_ps((-1 - o) as f32);
            let hi = _mm512_set1_ps((n - o) as f32);
            let c = _mm512_min_ps(_mm512_max_ps(p, lo), hi);
            let f = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(c);
            let i = _mm512_add_epi32(_mm512_cvttps_epi32(f), _mm512_set1_epi32(o));
            (i, _mm512_sub_ps(c, f))
        };
        let ((xi, tx), (yi, ty)) = (split(pos.px, 0, size.0), split(pos.py, 1, size.1));
        Self { xi, yi, tx, ty }
    }
}

/// `keys_lanes` (the Keys weights, same operations and order) at sixteen lanes.
#[target_feature(enable = "avx512f")]
#[inline]
fn keys16(t: __m512) -> [__m512; 4] {
    let c = _mm512_set1_ps;
    let t2 = _mm512_mul_ps(t, t);
    let t3 = _mm512_mul_ps(t2, t);
    let half_t = _mm512_mul_ps(c(0.5), t);
    let w0 = _mm512_sub_ps(_mm512_add_ps(_mm512_mul_ps(c(-0.5), t3), t2), half_t);
    let w1 = _mm512_add_ps(
        _mm512_sub_ps(_mm512_mul_ps(c(1.5), t3), _mm512_mul_ps(c(2.5), t2)),
        c(1.0),
    );
    let w2 = _mm512_add_ps(
        _mm512_add_ps(_mm512_mul_ps(c(-1.5), t3), _mm512_mul_ps(c(2.0), t2)),
        half_t,
    );
    let w3 = _mm512_sub_ps(_mm512_mul_ps(c(0.5), t3), _mm512_mul_ps(c(0.5), t2));
    [w0, w1, w2, w3]
}

/// Sixteen interior bicubic pixels whose 4 x 4 taps lie within 32 columns of four to six
/// source rows (`CubicWindow` at sixteen lanes, rows of 32, a third pixel row).
pub(crate) struct CubicWindow16 {
    /// The offset of the window's first sample (column `xs`, row ymin - 1).
    start: usize,
    /// Per pixel: its first tap column less `xs` (0..=28).
    rel: __m512i,
    /// The pixels whose tap rows start one row lower (y > ymin), and two (y = ymin + 2).
    lower: [__mmask16; 2],
    /// Rows read: 4 + ymax - ymin.
    rows: usize,
}

impl CubicWindow16 {
    /// The window of sixteen pixels split as `s` on a `size` image, where all are interior
    /// (1 <= x <= w - 3, 1 <= y <= h - 3), their columns within 29 and rows within 3
    /// (monotonic positions: the extremes are the first and last lanes).
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn of(s: &CubicSplit16, size: (i32, i32)) -> Option<Self> {
        let (w, h) = size;
        let ((xmin, xmax), (ymin, ymax)) = (ends16(s.xi), ends16(s.yi));
        if xmin < 1 || xmax > w - 3 || ymin < 1 || ymax > h - 3 {
            return None;
        }
        // The first column: the first tap's, or less where 32 from it pass the row's end.
        let xs = (xmin - 1).min(w - 32);
        if xmax - xmin > 28 || ymax - ymin > 2 || xs < 0 {
            return None;
        }
        Some(Self {
            start: ((ymin - 1) * w + xs) as usize,
            rel: _mm512_sub_epi32(s.xi, _mm512_set1_epi32(xs + 1)),
            lower: [1, 2].map(|d| _mm512_cmpgt_epi32_mask(s.yi, _mm512_set1_epi32(ymin + d - 1))),
            rows: (4 + ymax - ymin) as usize,
        })
    }

    /// Bicubic of the window's sixteen pixels in one plane with weights `w` (x, y; `keys16`):
    /// every tap of a column is a two-table permute of its row, the upper or the lower row
    /// chosen per pixel, and the sums are `cubic_sum8`'s in its order.
    ///
    /// # Safety
    /// AVX-512 F; `plane` is the `width`-wide image the window was made for.
    #[target_feature(enable = "avx2,avx512f,avx512bw")]
    #[inline]
    unsafe fn apply<T: SimdSample>(
        &self,
        (wx, wy): (&[__m512; 4], &[__m512; 4]),
        plane: &[T],
        width: usize,
    ) -> __m512 {
        debug_assert!(self.start + (self.rows - 1) * width + 32 <= plane.len());
        // Branch-free: rows past the last read are the last again (their `lower` clear).
        // SAFETY: `of` kept the rows and 32 columns from `xs` inside the image.
        let rows: [[__m512; 2]; 6] = std::array::from_fn(|j| unsafe {
            T::row32(
                plane
                    .as_ptr()
                    .add(self.start + j.min(self.rows - 1) * width),
            )
        });
        let cols: [__m512i; 4] =
            std::array::from_fn(|c| _mm512_add_epi32(self.rel, _mm512_set1_epi32(c as i32)));
        let take = |r: usize, c: usize| _mm512_permutex2var_ps(rows[r][0], cols[c], rows[r][1]);
        let tap = |r: usize, c: usize| {
            let near = _mm512_mask_blend_ps(self.lower[0], take(r, c), take(r + 1, c));
            _mm512_mask_blend_ps(self.lower[1], near, take(r + 2, c))
        };
        let pair = |p: usize| {
            let (mut a, mut b) = (
                _mm512_mul_ps(tap(0, 2 * p), wy[0]),
                _mm512_mul_ps(tap(0, 2 * p + 1), wy[0]),
            );
            for (r, &wr) in wy.iter().enumerate().skip(1) {
                a = _mm512_add_ps(a, _mm512_mul_ps(tap(r, 2 * p), wr));
                b = _mm512_add_ps(b, _mm512_mul_ps(tap(r, 2 * p + 1), wr));
            }
            (_mm512_mul_ps(a, wx[2 * p]), _mm512_mul_ps(b, wx[2 * p + 1]))
        };
        let (h0, h1) = pair(0);
        let (h2, h3) = pair(1);
        _mm512_add_ps(_mm512_add_ps(h0, h2), _mm512_add_ps(h1, h3))
    }
}

/// Whether sixteen consecutive pixels of the block can form a `CubicWindow16`: their positions
/// move by at most 28 columns and 2 rows. Offsets are `slope * k / (1 + c k)`, whose step is
/// largest where 1 + c k is least; where the bound fails (a steeply rotated map) every step
/// would fall back, and the block keeps its eight-pixel paths.
pub(super) fn cubic16_fits(pos: &Buffered<'_>) -> bool {
    let b = &pos.rel.block;
    let den = 1.0f32.min(1.0 + b.c * pos.rel.n as f32);
    if den <= 0.0 {
        return false;
    }
    let moved = |a: usize| 15.0 * b.slope[a].abs() / (den * den);
    moved(0) <= 28.0 && moved(1) <= 2.0
}

/// Bicubic of buffered pixels i..i + 16 into every output, where they form a `CubicWindow16`;
/// false (nothing written) where they do not.
///
/// # Safety
/// AVX-512 F, BW, VL, VBMI and VNNI; i + 16 <= the buffers' and every output's length; every plane
/// `size.0 * size.1` samples.
#[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
pub(super) unsafe fn bicubic_window16<T: SimdSample>(
    pos: &Buffered<'_>,
    i: usize,
    size: (i32, i32),
    planes: &[&[T]],
    outs: &mut [&mut [T]],
) -> bool {
    // SAFETY: i + 16 <= the buffers' length (the contract).
    let s = unsafe { CubicSplit16::at(pos, i, size) };
    let Some(win) = CubicWindow16::of(&s, size) else {
        return false;
    };
    let (wx, wy) = (keys16(s.tx), keys16(s.ty));
    for (plane, out) in planes.iter().zip(outs.iter_mut()) {
        debug_assert!(i + 16 <= out.len());
        // SAFETY: the window is inside the plane; i + 16 <= the output's length.
        unsafe {
            let v = win.apply((&wx, &wy), plane, size.0 as usize);
            T::store16(v, out.as_mut_ptr().add(i));
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(f: impl Fn(i32) -> i32) -> __m512i {
        let v: [i32; 16] = std::array::from_fn(|j| f(j as i32));
        // SAFETY: sixteen i32 are one 512-bit vector.
        unsafe { std::mem::transmute::<[i32; 16], __m512i>(v) }
    }

    /// The sixteen-lane u8 weights are `bilinear_weights_u8`'s, and their byte digits add back
    /// up to them (d2 2^16 + d1 2^8 + d0, d0 and d1 signed), at fractions including 0, 1/2 and
    /// 1; the blend of taps (0, 1, 255, 128) by digits and by products is `bilinear_u8`'s.
    #[test]
    fn u8_weights_and_their_digits_are_the_scalar_ones() {
        if !crate::cpu::avx512_vbmi_vnni() {
            eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
            return;
        }
        let fracs = |s: u32| -> [f32; 16] {
            std::array::from_fn(|j| match (j as u32 + s) % 7 {
                0 => 0.0,
                1 => 1.0,
                2 => 0.5,
                k => {
                    let h = (j as u32).wrapping_mul(2_654_435_761) ^ (s * 97 + k);
                    (h % 1_000_003) as f32 / 1_000_003.0
                }
            })
        };
        let bytes = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [u8; 64]>(v) };
        let words = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [i32; 16]>(v) };
        let taps = [0u8, 1, 255, 128];
        for s in 0..50 {
            let (fx, fy) = (fracs(s), fracs(s + 3));
            // SAFETY: the CPU has AVX-512 F, BW, VBMI and VNNI (checked above).
            let (w, d, by_digits, by_products) = unsafe {
                let f = (_mm512_loadu_ps(fx.as_ptr()), _mm512_loadu_ps(fy.as_ptr()));
                let v = _mm512_set1_epi32(i32::from_le_bytes(taps));
                (
                    weights_u8_16(f).map(words),
                    Digits16::new(f).0.map(bytes),
                    words(bilinear_u8_16::<true>(v, f)),
                    words(bilinear_u8_16::<false>(v, f)),
                )
            };
            for l in 0..16 {
                let scalar = crate::raster::bilinear_weights_u8((fx[l], fy[l]));
                for (j, &want) in scalar.iter().enumerate() {
                    assert_eq!(w[j][l], want, "lane {l} weight {j}");
                    let digit = |k: usize| i32::from(d[k][4 * l + j] as i8);
                    let back = (digit(2) << 16) + (digit(1) << 8) + digit(0);
                    assert_eq!(back, want, "lane {l} weight {j}: digits");
                    assert!((0..=64).contains(&digit(2)), "lane {l} weight {j}");
                }
                let want = i32::from(crate::raster::bilinear_u8(taps, (fx[l], fy[l])));
                assert_eq!((by_digits[l], by_products[l]), (want, want), "lane {l}");
            }
        }
    }

    /// The window stays inside its rows and the image: it starts early where 32 columns from
    /// the first would pass the row's end, covers every column, and refuses three rows or a
    /// span of 32 columns or more.
    #[test]
    fn rows_stay_inside_the_image() {
        if !crate::cpu::avx512_vbmi_vnni() {
            eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
            return;
        }
        let size = (40, 10);
        // SAFETY: the CPU has AVX-512 (checked above).
        let of = |ix, iy| unsafe { Rows16::of::<1>(ix, iy, [0, 0], size, (32, 2)) };
        let rows = of(lanes(|j| 20 + j), lanes(|j| 5 + j / 8)).expect("two rows, 16 columns");
        assert_eq!(
            (rows.row_start(0), rows.row_start(1)),
            (5 * 40 + 8, 6 * 40 + 8)
        );
        assert_eq!(rows.row_start(2), rows.row_start(1), "no third row read");
        assert_eq!(rows.cols, 20 + 15 - 8 + 1);
        let one_row = of(lanes(|j| 2 * j), lanes(|_| 9)).expect("one row, 31 columns");
        assert_eq!(
            (one_row.row_start(0), one_row.row_start(1)),
            (9 * 40, 9 * 40)
        );
        assert_eq!(one_row.cols, 31);
        assert!(of(lanes(|j| j * 3), lanes(|_| 0)).is_none(), "46 columns");
        assert!(of(lanes(|j| j), lanes(|j| j / 6)).is_none(), "three rows");
        // Bilinear's u8 windows: pixels on three rows and the row below fill four.
        // SAFETY: as above.
        let four = |ix, iy| unsafe { Rows16::of::<2>(ix, iy, [0, 0], size, (32, 4)) };
        let rows = four(lanes(|j| 3 + j), lanes(|j| 2 + j / 6)).expect("three pixel rows");
        let starts = [0, 1, 2, 3].map(|r| rows.row_start(r));
        assert_eq!(starts, [2 * 40 + 3, 3 * 40 + 3, 4 * 40 + 3, 5 * 40 + 3]);
        assert_eq!(rows.cols, 3 + 15 + 2 - 3);
        let last = four(lanes(|j| 3 + j), lanes(|j| 7 + j / 8)).expect("the last two rows");
        assert_eq!(
            last.row_start(3),
            last.row_start(2),
            "no row past the image"
        );
        assert!(
            four(lanes(|j| j), lanes(|j| j / 4)).is_none(),
            "four pixel rows"
        );
    }

    /// The bicubic window reads 32 samples of each row from its start, all inside the image
    /// (it starts early near the right edge), with every pixel's four tap columns in [0, 32);
    /// it refuses pixels off the interior, four pixel rows or more than 29 columns.
    #[test]
    fn cubic_windows_stay_inside_the_image() {
        if !crate::cpu::avx512_vbmi_vnni() {
            eprintln!("SKIP: no AVX-512 VBMI and VNNI on this CPU");
            return;
        }
        let size = (40, 10);
        let split = |xi, yi| CubicSplit16 {
            xi,
            yi,
            tx: unsafe { _mm512_setzero_ps() },
            ty: unsafe { _mm512_setzero_ps() },
        };
        // SAFETY: the CPU has AVX-512 (checked above).
        let of = |xi, yi| unsafe { CubicWindow16::of(&split(xi, yi), size) };
        let cols = |v: __m512i| unsafe { std::mem::transmute::<__m512i, [i32; 16]>(v) };
        for (xi, yi, rows) in [
            (lanes(|j| 20 + j), lanes(|j| 5 + j / 8), 5),
            (lanes(|j| 22 + j), lanes(|_| 7), 4),
            (lanes(|j| 1 + j), lanes(|j| 1 + j / 6), 6),
            (lanes(|j| 9 + 2 * j * 14 / 15), lanes(|_| 3), 4),
        ] {
            let win = of(xi, yi).expect("a window");
            assert_eq!(win.rows, rows);
            assert!(
                win.start + (win.rows - 1) * 40 + 32 <= 400,
                "inside the plane"
            );
            let (xs, first) = (win.start % 40, cols(xi));
            assert!(xs + 32 <= 40, "inside its rows");
            for (c, r) in first.iter().zip(cols(win.rel)) {
                assert_eq!(r, c - 1 - xs as i32, "tap columns from xs");
                assert!((0..=28).contains(&r));
            }
        }
        assert!(
            of(lanes(|j| j), lanes(|_| 3)).is_none(),
            "column 0 is not interior"
        );
        assert!(
            of(lanes(|j| 22 + j), lanes(|_| 8)).is_none(),
            "row 8 is not interior"
        );
        assert!(
            of(lanes(|j| 2 + j), lanes(|j| 1 + j / 4)).is_none(),
            "four pixel rows"
        );
        assert!(
            of(lanes(|j| 1 + 2 * j), lanes(|_| 3)).is_none(),
            "31 columns"
        );
    }
}
