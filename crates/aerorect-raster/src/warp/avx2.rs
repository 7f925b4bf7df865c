//! AVX2 builds of the kernels, eight (or four) destination pixels per step.
//!
//! Every routine here does the same arithmetic, operation for operation, as the portable kernel
//! in `kernel.rs` (f64 positions, f32 blend, no FMA), so the two builds agree bit for bit (a test
//! checks it). Positions come as f64 (`Exact`) or, for a projective block, as f32 offsets from an
//! integer origin (`Relative`, `Buffered`: `relative.rs`), which the portable build sees as
//! origin + offset in f64. Loads are laid out per kernel:
//! - nearest: the tap index is computed eight at a time, then one scalar load per pixel and band
//!   (scalar loads beat a gather for single samples); u8 with three bands or more reads byte
//!   windows of one or two rows where the eight samples lie within 16 columns. Blocks all inside
//!   go sixteen at a time with AVX-512 where the CPU has it (`avx512`): one 512-bit position
//!   step, and per band one two-table permute of two source rows;
//! - bilinear: one gather brings the upper neighbour pair (2 adjacent samples) of eight pixels and
//!   one the lower pair (u8, u16: 32-bit lanes; f32: 64-bit lanes, four pixels per gather).
//!   Blocks all inside go sixteen at a time with AVX-512 where the CPU has it: the taps as
//!   permutes of three source rows, the blend at sixteen lanes;
//! - bicubic: per pixel, four row loads of four adjacent samples, blended vertically as one 4-lane
//!   vector and then horizontally; taps that cross the border go through the portable kernel.

use super::kernel::{BLOCK, Bicubic, Bilinear, Kernel, Nearest, SourceGeometry};
use super::relative::RelativeBlock;
use crate::raster::{Sample, U8_WEIGHT_BITS};
use std::arch::x86_64::*;

mod avx512;

/// Per-task buffers for the AVX2 builds, one block long.
pub(crate) struct SimdScratch {
    pub(crate) cubic: Vec<CubicTap>,
    pub(crate) base: Vec<u32>,
    /// Per pixel: 0 outside, 1 interior (all 16 taps inside), 2 on the border (taps clamped).
    pub(crate) state: Vec<u8>,
    /// Fast offsets of a block (`Buffered`).
    pub(crate) px: Vec<f32>,
    pub(crate) py: Vec<f32>,
}

impl SimdScratch {
    pub(crate) fn new() -> Self {
        Self {
            px: vec![0.0; BLOCK],
            py: vec![0.0; BLOCK],
            cubic: vec![CubicTap::default(); BLOCK],
            base: vec![0; BLOCK],
            state: vec![0; BLOCK],
        }
    }
}

/// The weights of one interior bicubic pixel (`keys_weights_f32`); the upper-left index of its
/// 4 x 4 neighbourhood is kept apart (`SimdScratch::base`).
#[derive(Clone, Copy, Default)]
#[repr(C, align(16))]
pub(crate) struct CubicTap {
    wx: [f32; 4],
    wy: [f32; 4],
}

/// Constants of one source image for the eight-pixel steps.
pub(crate) struct Consts {
    lim_x: __m256d,
    lim_y: __m256d,
    neg_half: __m256d,
    zero: __m256d,
    max_x: __m256d,
    max_y: __m256d,
    i0max_x: __m128i,
    i0max_y: __m128i,
    width: __m256i,
    w_minus_2: __m256i,
    half: __m256,
    pick: __m256i,
    /// The source width and height.
    size: (i32, i32),
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
    fn inside(&self, x: __m256d, y: __m256d) -> __m256d {
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
unsafe fn load4(xs: &[f64], ys: &[f64], i: usize) -> (__m256d, __m256d) {
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
fn narrow_mask(lo: __m256d, hi: __m256d) -> __m256i {
    let even = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
    _mm256_set_m128i(
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(hi), even)),
        _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(lo), even)),
    )
}

/// Bilinear split of four positions (`left_neighbour`): clamp to [0, vmax] (NaN to 0, as
/// `max_pd` returns its second operand for NaN), truncate, cap the index at n - 2.
#[target_feature(enable = "avx2")]
#[inline]
fn split(k: &Consts, v: __m256d, vmax: __m256d, imax: __m128i) -> (__m128i, __m128) {
    let c = _mm256_min_pd(_mm256_max_pd(v, k.zero), vmax);
    let i0 = _mm_min_epi32(_mm256_cvttpd_epi32(c), imax);
    let f = _mm256_cvtpd_ps(_mm256_sub_pd(c, _mm256_cvtepi32_pd(i0)));
    (i0, f)
}

/// The bilinear taps of eight pixels: upper-left offsets, fractions, inside lanes and mask bits.
pub(crate) struct Taps8 {
    off: __m256i,
    fx: __m256,
    fy: __m256,
    lanes: __m256i,
    mask: i32,
    /// For u8: the eight pixels' neighbours inside 16 bytes of two or three source rows.
    window: Option<Window>,
}

/// Eight u8 bilinear taps read as byte shuffles of 16-byte row loads instead of gathers: the
/// layout of pillow-simd and IPP for nearly horizontal rows. It applies when the eight upper
/// neighbour rows differ by at most one and their columns by at most 14.
pub(crate) struct Window {
    /// Offset of the first byte of the first row.
    start: usize,
    /// Per 32-bit lane: bytes (x0, x0 + 1) of the row to bytes 0, 1 (upper pair) ...
    top: __m256i,
    /// ... and to bytes 2, 3 (lower pair).
    low: __m256i,
    /// Lanes whose upper row is the first row (all when `rows == 2`).
    first: __m256i,
    /// Rows read: 2 when all eight upper rows are equal, else 3.
    rows: usize,
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
fn ends8(v: __m256i) -> (i32, i32) {
    let (a, b) = (_mm256_cvtsi256_si32(v), _mm256_extract_epi32::<7>(v));
    (a.min(b), a.max(b))
}

/// The minimum and maximum of eight i32 lanes: `ends8` where they are known to be monotonic,
/// else `min_max8`.
#[target_feature(enable = "avx2")]
#[inline]
fn extent8(v: __m256i, monotonic: bool) -> (i32, i32) {
    match monotonic {
        true => ends8(v),
        false => min_max8(v),
    }
}

/// The byte window of eight u8 taps with upper-left neighbours (x0, y0), when there is one.
#[target_feature(enable = "avx2")]
#[inline]
fn window(k: &Consts, x0: __m256i, y0: __m256i, monotonic: bool) -> Option<Window> {
    let (xmin, xmax) = extent8(x0, monotonic);
    let (ymin, ymax) = extent8(y0, monotonic);
    let rows = if ymax == ymin { 2 } else { 3 };
    let (w, h) = k.size;
    // The 16 bytes from xmin of `rows` rows from ymin must be inside the image.
    if xmax - xmin > 14 || ymax - ymin > 1 || xmin + 16 > w || ymin + rows > h {
        return None;
    }
    let rel = _mm256_sub_epi32(x0, _mm256_set1_epi32(xmin));
    let pair = _mm256_or_si256(
        rel,
        _mm256_slli_epi32::<8>(_mm256_add_epi32(rel, _mm256_set1_epi32(1))),
    );
    Some(Window {
        start: (ymin * w + xmin) as usize,
        top: _mm256_or_si256(pair, _mm256_set1_epi32(0x8080_0000_u32 as i32)),
        low: _mm256_or_si256(_mm256_slli_epi32::<16>(pair), _mm256_set1_epi32(0x8080)),
        first: _mm256_cmpeq_epi32(y0, _mm256_set1_epi32(ymin)),
        rows: rows as usize,
    })
}

/// Eight u8 nearest samples read as a byte shuffle of one or two 16-byte row loads instead of
/// eight scalar loads (the `Window` layout): where all eight are inside, their columns lie
/// within 16 bytes and their rows differ by at most one.
pub(crate) struct NearestWindow {
    /// Offset of the first byte of the first row.
    start: usize,
    /// Bytes 0..8: each pixel's column minus the first column (a `pshufb` control).
    ctrl: __m128i,
    /// Bytes 0..8: 0xFF where the pixel is on the first row.
    first: __m128i,
    /// Rows read: 1 when all eight rows are equal, else 2.
    rows: usize,
}

/// The low byte of each 32-bit lane, packed into the low eight bytes.
#[target_feature(enable = "avx2")]
#[inline]
fn pack_low_bytes(k: &Consts, v: __m256i) -> __m128i {
    let bytes = _mm256_shuffle_epi8(v, k.pick);
    _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
        bytes,
        _mm256_setr_epi32(0, 4, 1, 1, 1, 1, 1, 1),
    ))
}

/// The byte window of eight nearest samples at columns `ix`, rows `iy` (all inside).
#[target_feature(enable = "avx2")]
#[inline]
fn nearest_window(k: &Consts, ix: __m256i, iy: __m256i, monotonic: bool) -> Option<NearestWindow> {
    let (xmin, xmax) = extent8(ix, monotonic);
    let (ymin, ymax) = extent8(iy, monotonic);
    if xmax - xmin > 15 || ymax - ymin > 1 || xmin + 16 > k.size.0 {
        return None;
    }
    Some(NearestWindow {
        start: (ymin * k.size.0 + xmin) as usize,
        ctrl: pack_low_bytes(k, _mm256_sub_epi32(ix, _mm256_set1_epi32(xmin))),
        first: pack_low_bytes(k, _mm256_cmpeq_epi32(iy, _mm256_set1_epi32(ymin))),
        rows: if ymax == ymin { 1 } else { 2 },
    })
}

/// # Safety
/// AVX2; `i + 8 <= xs.len(), ys.len()`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn bilinear_taps8(k: &Consts, xs: &[f64], ys: &[f64], i: usize, with_window: bool) -> Taps8 {
    // SAFETY: i + 8 <= len (the contract).
    let ((x_lo, y_lo), (x_hi, y_hi)) = unsafe { (load4(xs, ys, i), load4(xs, ys, i + 4)) };
    let (in_lo, in_hi) = (k.inside(x_lo, y_lo), k.inside(x_hi, y_hi));
    let mask = _mm256_movemask_pd(in_lo) | (_mm256_movemask_pd(in_hi) << 4);
    let (x0_lo, fx_lo) = split(k, x_lo, k.max_x, k.i0max_x);
    let (x0_hi, fx_hi) = split(k, x_hi, k.max_x, k.i0max_x);
    let (y0_lo, fy_lo) = split(k, y_lo, k.max_y, k.i0max_y);
    let (y0_hi, fy_hi) = split(k, y_hi, k.max_y, k.i0max_y);
    let x0 = _mm256_set_m128i(x0_hi, x0_lo);
    let y0 = _mm256_set_m128i(y0_hi, y0_lo);
    Taps8 {
        off: _mm256_add_epi32(_mm256_mullo_epi32(y0, k.width), x0),
        fx: _mm256_set_m128(fx_hi, fx_lo),
        fy: _mm256_set_m128(fy_hi, fy_lo),
        lanes: narrow_mask(in_lo, in_hi),
        mask,
        window: if with_window {
            window(k, x0, y0, false)
        } else {
            None
        },
    }
}

/// The bilinear blend, in the order of `Bilinear::apply` (no FMA).
#[target_feature(enable = "avx2")]
#[inline]
fn blend(t: &Taps8, p00: __m256, p01: __m256, p10: __m256, p11: __m256) -> __m256 {
    let top = _mm256_add_ps(p00, _mm256_mul_ps(t.fx, _mm256_sub_ps(p01, p00)));
    let bottom = _mm256_add_ps(p10, _mm256_mul_ps(t.fx, _mm256_sub_ps(p11, p10)));
    _mm256_add_ps(top, _mm256_mul_ps(t.fy, _mm256_sub_ps(bottom, top)))
}

/// Eight blended values of an integer type rounded as `Sample::from_f32` rounds (v + 0.5,
/// truncated) in 32-bit lanes, `nodata` where the pixel is outside.
#[target_feature(enable = "avx2")]
#[inline]
fn rounded(k: &Consts, t: &Taps8, v: __m256, nodata: i32) -> __m256i {
    let q = _mm256_cvttps_epi32(_mm256_add_ps(v, k.half));
    _mm256_blendv_epi8(_mm256_set1_epi32(nodata), q, t.lanes)
}

/// `bilinear_weights_u8` at eight lanes (same operations, same order).
#[target_feature(enable = "avx2")]
#[inline]
fn bilinear_weights_u8_8((fx, fy): (__m256, __m256)) -> [__m256i; 4] {
    let one = _mm256_set1_ps(1.0);
    let scale = _mm256_set1_ps((1u32 << U8_WEIGHT_BITS) as f32);
    let (bx, by) = (_mm256_sub_ps(one, fx), _mm256_sub_ps(one, fy));
    let (sbx, sfx) = (_mm256_mul_ps(bx, scale), _mm256_mul_ps(fx, scale));
    [(sbx, by), (sfx, by), (sbx, fy), (sfx, fy)]
        .map(|(a, b)| _mm256_cvtps_epi32(_mm256_mul_ps(a, b)))
}

/// `bilinear_u8` at eight lanes, taps as 32-bit lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn bilinear_u8_8(p: [__m256i; 4], f: (__m256, __m256)) -> __m256i {
    let w = bilinear_weights_u8_8(f);
    let [a, b, c, d] = [0, 1, 2, 3].map(|j| _mm256_mullo_epi32(p[j], w[j]));
    let sum = _mm256_add_epi32(_mm256_add_epi32(a, b), _mm256_add_epi32(c, d));
    let half = _mm256_set1_epi32(1 << (U8_WEIGHT_BITS - 1));
    _mm256_srli_epi32::<{ U8_WEIGHT_BITS as i32 }>(_mm256_add_epi32(sum, half))
}

/// A sample type with an AVX2 bilinear step and a four-sample row load.
pub(crate) trait SimdSample: Sample {
    /// Whether `bilinear8` reads byte windows (`Window`) where they apply.
    const WINDOWS: bool = false;

    /// Bilinear at eight pixels of `plane`, written to `out[at..at + 8]` (nodata outside).
    ///
    /// # Safety
    /// AVX2; source at least 2 x 2 with a full plane (`g.width * g.height` samples); taps from
    /// `bilinear_taps8`; `at + 8 <= out.len()`.
    unsafe fn bilinear8(
        k: &Consts,
        t: &Taps8,
        plane: &[Self],
        out: &mut [Self],
        at: usize,
        nodata: Self,
    );

    /// Four adjacent samples from `p` on, as f32.
    ///
    /// # Safety
    /// AVX2; the four samples from `p` on are readable.
    unsafe fn row4(p: *const Self) -> __m128;

    /// Whether bicubic reads windows (`cubic_window`) where they apply: not for f32, whose
    /// pair kernel loads its four-sample rows as they are (measured 3.5 against 4.2 ms).
    const CUBIC_WINDOWS: bool = true;

    /// Sixteen samples from `p` as two f32 vectors (columns 0..8, 8..16).
    ///
    /// # Safety
    /// AVX2; the sixteen samples from `p` on are readable.
    unsafe fn row16(p: *const Self) -> [__m256; 2];

    /// Bicubic of a window's eight pixels (`cubic_window`) with per-tap weight vectors `w`
    /// (`keys_lanes`), written to `out[..8]` as `from_f32` writes them; here through
    /// `cubic_window8_wide` and `store8`, byte shuffles for u8.
    ///
    /// # Safety
    /// AVX2; `win.rows` rows of 16 samples from `win.start` (stride `width`) inside `plane`;
    /// `out.len() >= 8`.
    unsafe fn cubic_window8(
        k: &Consts,
        win: &CubicWindow,
        w: (&[__m256; 4], &[__m256; 4]),
        plane: &[Self],
        width: usize,
        out: &mut [Self],
    ) {
        let _ = k;
        // SAFETY: the contract.
        unsafe { Self::store8(cubic_window8_wide(win, w, plane, width), out) };
    }

    /// Eight values written to `out[..8]` as `from_f32` writes them (for |v| < 2^31: beyond,
    /// the integer types' truncation overflows to 0 where `as` saturates).
    ///
    /// # Safety
    /// AVX2; `out.len() >= 8`.
    unsafe fn store8(v: __m256, out: &mut [Self]);

    /// Thirty-two samples from `p` as two f32 vectors (columns 0..16, 16..32), for bicubic's
    /// sixteen-pixel windows (`avx512::bicubic_window16`).
    ///
    /// # Safety
    /// AVX-512 F; the 32 samples from `p` on are readable.
    unsafe fn row32(p: *const Self) -> [__m512; 2];

    /// Sixteen values written to `out[..16]` as `from_f32` writes them (`store8`'s).
    ///
    /// # Safety
    /// AVX-512 F; sixteen samples writable at `out`.
    unsafe fn store16(v: __m512, out: *mut Self);

    /// The columns of each source row `nearest_rows16` takes (a 512-bit vector's samples, or
    /// two vectors' for f32).
    const ROW_SPAN: i32;

    /// The source rows `nearest_rows16_wide` takes: two, as `nearest_rows16`, unless the type
    /// has a wider layout.
    const NEAREST_ROWS_WIDE: i32 = 2;

    /// The source rows `bilinear_rows16` takes: three (pixels on two rows and the row below).
    const BILINEAR_ROWS: i32 = 3;

    /// Nearest at sixteen pixels placed by `rows` (two source rows of `ROW_SPAN` samples), by
    /// an AVX-512 two-table permute, into `out[..16]`.
    ///
    /// # Safety
    /// AVX-512 F, BW, VL, VBMI and VNNI; `rows` from `Rows16::of` with `ROW_SPAN` and one tap
    /// on an image the size of `plane`; sixteen samples writable at `out`.
    unsafe fn nearest_rows16(rows: &avx512::Rows16, plane: &[Self], out: *mut Self);

    /// `nearest_rows16` for `rows` of `NEAREST_ROWS_WIDE` rows.
    ///
    /// # Safety
    /// As `nearest_rows16`, with `NEAREST_ROWS_WIDE` rows.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16_wide(rows: &avx512::Rows16, plane: &[Self], out: *mut Self) {
        // SAFETY: the contract (two rows unless the type overrides both).
        unsafe { Self::nearest_rows16(rows, plane, out) }
    }

    /// Bilinear at sixteen pixels placed by `rows` with fractions `f` (x, y), from AVX-512
    /// permutes of the rows, written to `out[..16]` as `Sample::bilinear` writes them;
    /// `SHARED` where several bands share the step (u8 then makes its weights' digits once).
    ///
    /// # Safety
    /// AVX-512 F, BW, VL, VBMI and VNNI; `rows` from `Rows16::of` with `ROW_SPAN` and two taps
    /// on an image the size of `plane`; sixteen samples writable at `out`.
    unsafe fn bilinear_rows16<const SHARED: bool>(
        rows: &avx512::Rows16,
        f: (__m512, __m512),
        plane: &[Self],
        out: *mut Self,
    );

    /// The eight nearest samples of a window (`nearest_window`) into `out[..8]`; the
    /// portable reading here, a shuffle for u8 (the only type with `WINDOWS`).
    ///
    /// # Safety
    /// AVX2; `win.rows` rows of 16 samples from `win.start` (row stride `width`) are inside
    /// `plane`; `out.len() >= 8`.
    unsafe fn nearest_window8(win: &NearestWindow, width: usize, plane: &[Self], out: &mut [Self]) {
        // SAFETY: both are 16 plain bytes.
        let (ctrl, first): ([u8; 16], [u8; 16]) = unsafe {
            (
                std::mem::transmute::<__m128i, [u8; 16]>(win.ctrl),
                std::mem::transmute::<__m128i, [u8; 16]>(win.first),
            )
        };
        for (j, d) in out.iter_mut().take(8).enumerate() {
            let row = usize::from(first[j] == 0);
            *d = plane[win.start + row * width + usize::from(ctrl[j])];
        }
    }
}

/// The 32 bytes from each of `rows`' four row starts as a byte permute's two tables: rows 0
/// and 1, rows 2 and 3 (byte 32 r + c is column c of row r).
///
/// # Safety
/// AVX-512 F; 32 bytes from each row start inside `plane` (`Rows16::of` with four rows).
#[target_feature(enable = "avx2,avx512f")]
#[inline]
unsafe fn byte_tables4(rows: &avx512::Rows16, plane: &[u8]) -> [__m512i; 2] {
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
        let q = avx512::rounded16(v);
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
        rows: &avx512::Rows16,
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
            let q = avx512::bilinear_u8_16::<SHARED>(v, f);
            _mm_storeu_si128(out as *mut __m128i, _mm512_cvtepi32_epi8(q));
        }
    }

    /// Two rows of 32 samples, one byte permute (`vpermi2b`) over the two 256-bit loads.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &avx512::Rows16, plane: &[u8], out: *mut u8) {
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
    unsafe fn nearest_rows16_wide(rows: &avx512::Rows16, plane: &[u8], out: *mut u8) {
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
        let q = avx512::rounded16(v);
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
        rows: &avx512::Rows16,
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
            let q = avx512::rounded16(avx512::blend16(f, p.map(|v| _mm512_cvtepi32_ps(v))));
            _mm256_storeu_si256(out as *mut __m256i, _mm512_cvtepi32_epi16(q));
        }
    }

    /// Two rows of 32 samples, one word permute (`vpermi2w`).
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &avx512::Rows16, plane: &[u16], out: *mut u16) {
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
        rows: &avx512::Rows16,
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
            _mm512_storeu_ps(out, avx512::blend16(f, p));
        }
    }

    /// Where the columns lie within 16: one permute over 16 samples of each row; else two
    /// rows of 32 (two vectors each), one permute per row, blended by row.
    #[target_feature(enable = "avx2,avx512f,avx512bw,avx512vl,avx512vbmi,avx512vnni")]
    #[inline]
    unsafe fn nearest_rows16(rows: &avx512::Rows16, plane: &[f32], out: *mut f32) {
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

/// Bilinear for one block: `pos` the source positions, `planes` the source bands, `outs` the
/// destination bands (as long as `pos`); `valid` receives the inside flags.
///
/// # Safety
/// AVX2; the source at least 2 x 2 (`g.width, g.height >= 2`), every plane `g.width * g.height`.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn bilinear_block<T: SimdSample, P: Positions>(
    g: &SourceGeometry,
    pos: &P,
    planes: &[&[T]],
    outs: &mut [&mut [T]],
    valid: &mut [bool],
    nodata: T,
) {
    let n = pos.len().min(valid.len());
    let k = Consts::new(g);
    let mut i = 0;
    if let Some(whole) = inside_run(&k, pos, n) {
        valid[..whole].fill(true);
        if let (true, Some(buffered)) = (g.avx512, pos.buffered()) {
            // SAFETY: `g.avx512`: the CPU has AVX-512 F, BW, VL, VBMI, VNNI; as this function's
            // contract; every pixel of the whole steps is inside.
            i = unsafe { avx512::bilinear_inside16(&k, buffered, planes, outs, whole, nodata) };
        }
        while i < whole {
            // SAFETY: i + 8 <= whole <= n; every pixel of the whole steps is inside.
            let t = unsafe { pos.bilinear_inside8(&k, i, T::WINDOWS) };
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: as this function's contract; i + 8 <= n = every output's length.
                unsafe { T::bilinear8(&k, &t, plane, out, i, nodata) };
            }
            i += 8;
        }
    }
    while i + 8 <= n {
        // SAFETY: i + 8 <= n.
        let t = unsafe { pos.bilinear8(&k, i, T::WINDOWS) };
        if t.mask == 0 {
            // All eight outside (common around an ortho's footprint): no loads.
            for out in outs.iter_mut() {
                out[i..i + 8].fill(nodata);
            }
        } else {
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                // SAFETY: as this function's contract; i + 8 <= n = every output's length.
                unsafe { T::bilinear8(&k, &t, plane, out, i, nodata) };
            }
        }
        store_flags(valid, i, t.mask);
        i += 8;
    }
    pos.tail(i)
        .run::<Bilinear, T>(g, planes, outs, valid, nodata);
}

/// The source positions of one block, eight at a time as kernel taps.
pub(crate) trait Positions {
    /// Whether the sample columns and rows are monotonic along the block (true of a projective
    /// block's positions, `RelativeBlock::new`): the extremes of eight consecutive pixels are
    /// then the first and the last, and the pixels inside the image form one run.
    const MONOTONIC: bool;

    fn len(&self) -> usize;

    /// The nearest kernel's taps of pixels i..i + 8.
    ///
    /// # Safety
    /// AVX2; i + 8 <= len.
    unsafe fn nearest8(&self, k: &Consts, i: usize) -> NearestTaps;

    /// The sample indices, columns and rows of pixels i..i + 8, all known to be inside (no
    /// inside test, no clamp).
    ///
    /// # Safety
    /// AVX2; i + 8 <= len; the eight pixels are inside the image.
    unsafe fn nearest_inside8(&self, k: &Consts, i: usize) -> [__m256i; 3] {
        // SAFETY: the contract.
        let t = unsafe { self.nearest8(k, i) };
        [t.idx, t.ix, t.iy]
    }

    /// The bilinear taps of pixels i..i + 8.
    ///
    /// # Safety
    /// AVX2; i + 8 <= len.
    unsafe fn bilinear8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8;

    /// `bilinear8` for eight pixels known to be inside (no inside test).
    ///
    /// # Safety
    /// AVX2; i + 8 <= len; the eight pixels are inside the image.
    unsafe fn bilinear_inside8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        // SAFETY: the contract.
        unsafe { self.bilinear8(k, i, with_window) }
    }

    /// The pixels from `from` on (fewer than eight), as f64 positions.
    fn tail(&self, from: usize) -> Tail;

    /// The fused fast positions, where these are they.
    fn relative(&self) -> Option<&Relative> {
        None
    }

    /// The buffered fast positions, where these are they.
    fn buffered(&self) -> Option<&Buffered<'_>> {
        None
    }
}

/// The nearest taps of eight pixels.
pub(crate) struct NearestTaps {
    /// Sample indices, inside the image (any inside index where the pixel is outside).
    idx: __m256i,
    /// Columns and rows of the samples (exact where the pixel is inside).
    ix: __m256i,
    iy: __m256i,
    /// Inside bits.
    mask: i32,
}

/// Positions given in f64 (`Coordinates::Exact`, or a block the fast ones do not cover).
pub(crate) struct Exact<'a> {
    pub(crate) xs: &'a [f64],
    pub(crate) ys: &'a [f64],
}

impl Positions for Exact<'_> {
    const MONOTONIC: bool = false;

    fn len(&self) -> usize {
        self.xs.len().min(self.ys.len())
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn nearest8(&self, k: &Consts, i: usize) -> NearestTaps {
        let half = _mm256_set1_pd(0.5);
        let round = |v: __m256d, vmax: __m256d| {
            _mm256_cvttpd_epi32(_mm256_min_pd(
                _mm256_max_pd(_mm256_add_pd(v, half), k.zero),
                vmax,
            ))
        };
        // SAFETY: i + 8 <= len (the contract).
        let ((x_lo, y_lo), (x_hi, y_hi)) =
            unsafe { (load4(self.xs, self.ys, i), load4(self.xs, self.ys, i + 4)) };
        let mask = _mm256_movemask_pd(k.inside(x_lo, y_lo))
            | (_mm256_movemask_pd(k.inside(x_hi, y_hi)) << 4);
        let ix = _mm256_set_m128i(round(x_hi, k.max_x), round(x_lo, k.max_x));
        let iy = _mm256_set_m128i(round(y_hi, k.max_y), round(y_lo, k.max_y));
        let idx = _mm256_add_epi32(_mm256_mullo_epi32(iy, k.width), ix);
        NearestTaps { idx, ix, iy, mask }
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        // SAFETY: the contract.
        unsafe { bilinear_taps8(k, self.xs, self.ys, i, with_window) }
    }

    fn tail(&self, from: usize) -> Tail {
        let mut tail = Tail::new(from, self.len());
        let n = tail.n;
        tail.xs[..n].copy_from_slice(&self.xs[from..from + n]);
        tail.ys[..n].copy_from_slice(&self.ys[from..from + n]);
        tail
    }
}

/// Fast positions (`relative::RelativeBlock`): f32 offsets from the block's integer origin,
/// compared against the image's limits moved by the origin. Every operation is that of
/// `RelativeBlock::offset` and of the portable kernels on `origin + offset`, so the builds agree
/// bit for bit.
pub(crate) struct Relative {
    block: RelativeBlock,
    n: usize,
    first: [__m256; 2],
    slope: [__m256; 2],
    c: __m256,
    one: __m256,
    lanes: __m256,
    /// Inside: shift - 0.5 - origin <= offset < size + shift - 0.5 - origin, per axis (size:
    /// the source's width or height).
    lo: [__m256; 2],
    hi: [__m256; 2],
    /// Clamped positions: [-origin, size - 1 - origin], per axis.
    cmin: [__m256; 2],
    cmax: [__m256; 2],
    origin: [__m256i; 2],
    /// Whether the CPU has the AVX-512 steps (`SourceGeometry::avx512`).
    avx512: bool,
}

impl Relative {
    /// The vectors of `block`'s `n` pixels on the source of `g`.
    #[target_feature(enable = "avx2")]
    pub(crate) fn new(g: &SourceGeometry, block: &RelativeBlock, n: usize) -> Self {
        let size = [g.width() as f32, g.height() as f32];
        let o = block.origin.map(|v| v as f32);
        // Inside: -0.5 <= x < n - 0.5, with x = origin + offset - shift.
        let edge = block.shift as f32 - 0.5;
        let per_axis = |f: &dyn Fn(usize) -> f32| [_mm256_set1_ps(f(0)), _mm256_set1_ps(f(1))];
        Self {
            block: *block,
            n,
            first: per_axis(&|a| block.first[a]),
            slope: per_axis(&|a| block.slope[a]),
            c: _mm256_set1_ps(block.c),
            one: _mm256_set1_ps(1.0),
            lanes: _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0),
            lo: per_axis(&|a| edge - o[a]),
            hi: per_axis(&|a| size[a] + edge - o[a]),
            cmin: per_axis(&|a| -o[a]),
            cmax: per_axis(&|a| size[a] - 1.0 - o[a]),
            origin: block.origin.map(|v| _mm256_set1_epi32(v)),
            avx512: g.avx512,
        }
    }

    /// The offsets of pixels i..i + 8 (`RelativeBlock::offset`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn offsets8(&self, i: usize) -> [__m256; 2] {
        self.offsets_at(_mm256_add_ps(_mm256_set1_ps(i as f32), self.lanes))
    }

    /// The offsets of the pixels numbered `k` (whole numbers, exact in f32 below 2^24).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn offsets_at(&self, k: __m256) -> [__m256; 2] {
        let den = _mm256_add_ps(self.one, _mm256_mul_ps(self.c, k));
        let kr = _mm256_mul_ps(k, _mm256_div_ps(self.one, den));
        [0, 1].map(|a| _mm256_add_ps(self.first[a], _mm256_mul_ps(self.slope[a], kr)))
    }

    /// The offsets of the first `px.len()` pixels (a multiple of eight), ahead of a kernel
    /// whose loads should not wait on the division (`Buffered`).
    #[target_feature(enable = "avx2")]
    pub(crate) fn fill_offsets(&self, px: &mut [f32], py: &mut [f32]) {
        let n = px.len().min(py.len());
        let mut i = 0;
        if self.avx512 {
            // SAFETY: `avx512`: the CPU has AVX-512 F.
            i = unsafe { avx512::fill_offsets16(self, px, py) };
        }
        // A running k: converting i each step measured slower (as in `avx512`).
        let (mut k, step) = (
            _mm256_add_ps(self.lanes, _mm256_set1_ps(i as f32)),
            _mm256_set1_ps(8.0),
        );
        while i + 8 <= n {
            let p = self.offsets_at(k);
            k = _mm256_add_ps(k, step);
            // SAFETY: i + 8 <= n, the length of both.
            unsafe {
                _mm256_storeu_ps(px.as_mut_ptr().add(i), p[0]);
                _mm256_storeu_ps(py.as_mut_ptr().add(i), p[1]);
            }
            i += 8;
        }
    }

    /// The lanes of offsets `p` inside the image.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn inside8(&self, p: &[__m256; 2]) -> __m256 {
        let inside = |a: usize| {
            _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(p[a], self.lo[a]),
                _mm256_cmp_ps::<_CMP_LT_OQ>(p[a], self.hi[a]),
            )
        };
        _mm256_and_ps(inside(0), inside(1))
    }

    /// With the nearest kernel's shift (`Nearest::FAST_SHIFT`), floor(x + 0.5) is
    /// origin + floor(offset), and x is inside where 0 <= origin + offset < n: `lo` and `hi`
    /// are -origin and n - origin here. Lanes outside get index 0 (their output is nodata).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn nearest_taps(&self, k: &Consts, p: [__m256; 2]) -> NearestTaps {
        let inside = self.inside8(&p);
        let [idx, ix, iy] = self.nearest_index(k, p);
        NearestTaps {
            idx: _mm256_and_si256(idx, _mm256_castps_si256(inside)),
            ix,
            iy,
            mask: _mm256_movemask_ps(inside),
        }
    }

    /// The sample indices, columns and rows of offsets `p` (origin + floor(offset), unclamped).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn nearest_index(&self, k: &Consts, p: [__m256; 2]) -> [__m256i; 3] {
        let index = |a: usize| {
            let f = _mm256_cvttps_epi32(_mm256_floor_ps(p[a]));
            _mm256_add_epi32(f, self.origin[a])
        };
        let (ix, iy) = (index(0), index(1));
        [
            _mm256_add_epi32(_mm256_mullo_epi32(iy, k.width), ix),
            ix,
            iy,
        ]
    }

    /// `left_neighbour` on origin + offset: the clamp, floor and fraction in f32 are exact.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn bilinear_taps<const INSIDE: bool>(
        &self,
        k: &Consts,
        p: [__m256; 2],
        with_window: bool,
    ) -> Taps8 {
        let inside = match INSIDE {
            true => _mm256_castsi256_ps(_mm256_set1_epi32(-1)),
            false => self.inside8(&p),
        };
        let split = |a: usize, imax: i32| {
            let c = _mm256_min_ps(_mm256_max_ps(p[a], self.cmin[a]), self.cmax[a]);
            let rel = _mm256_cvttps_epi32(_mm256_floor_ps(c));
            let i0 = _mm256_min_epi32(
                _mm256_add_epi32(rel, self.origin[a]),
                _mm256_set1_epi32(imax),
            );
            let f = _mm256_sub_ps(c, _mm256_cvtepi32_ps(_mm256_sub_epi32(i0, self.origin[a])));
            (i0, f)
        };
        let (x0, fx) = split(0, k.size.0 - 2);
        let (y0, fy) = split(1, k.size.1 - 2);
        Taps8 {
            off: _mm256_add_epi32(_mm256_mullo_epi32(y0, k.width), x0),
            fx,
            fy,
            lanes: _mm256_castps_si256(inside),
            mask: _mm256_movemask_ps(inside),
            window: if with_window {
                window(k, x0, y0, true)
            } else {
                None
            },
        }
    }
}

/// Fused: each step computes its eight offsets (best for nearest, whose loads are cheap).
impl Positions for Relative {
    fn relative(&self) -> Option<&Relative> {
        Some(self)
    }

    /// x(k) - x(0) = k a / (1 + c k) is monotonic in k (while 1 + c k > 0), and so are its
    /// floor and its clamp.
    const MONOTONIC: bool = true;

    fn len(&self) -> usize {
        self.n
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn nearest8(&self, k: &Consts, i: usize) -> NearestTaps {
        self.nearest_taps(k, self.offsets8(i))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn nearest_inside8(&self, k: &Consts, i: usize) -> [__m256i; 3] {
        self.nearest_index(k, self.offsets8(i))
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        self.bilinear_taps::<false>(k, self.offsets8(i), with_window)
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear_inside8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        self.bilinear_taps::<true>(k, self.offsets8(i), with_window)
    }

    fn tail(&self, from: usize) -> Tail {
        let mut tail = Tail::new(from, self.n);
        let n = tail.n;
        self.block.fill(from, &mut tail.xs[..n], &mut tail.ys[..n]);
        tail
    }
}

/// Offsets computed ahead (`Relative::fill_offsets`) and read back eight at a time: best for
/// bilinear, whose gathers then do not wait on the division.
pub(crate) struct Buffered<'a> {
    pub(crate) rel: &'a Relative,
    /// At least `rel.len()` rounded down to a multiple of eight (every whole step).
    pub(crate) px: &'a [f32],
    pub(crate) py: &'a [f32],
}

impl Buffered<'_> {
    /// # Safety
    /// AVX2; i + 8 <= px.len(), py.len().
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn load8(&self, i: usize) -> [__m256; 2] {
        debug_assert!(i + 8 <= self.px.len() && i + 8 <= self.py.len());
        // SAFETY: the contract.
        unsafe {
            [
                _mm256_loadu_ps(self.px.as_ptr().add(i)),
                _mm256_loadu_ps(self.py.as_ptr().add(i)),
            ]
        }
    }
}

impl Positions for Buffered<'_> {
    fn buffered(&self) -> Option<&Buffered<'_>> {
        Some(self)
    }

    const MONOTONIC: bool = true;

    fn len(&self) -> usize {
        self.rel.n
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn nearest8(&self, k: &Consts, i: usize) -> NearestTaps {
        // SAFETY: i + 8 <= len, so within the buffers.
        self.rel.nearest_taps(k, unsafe { self.load8(i) })
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        // SAFETY: i + 8 <= len, so within the buffers.
        self.rel
            .bilinear_taps::<false>(k, unsafe { self.load8(i) }, with_window)
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn bilinear_inside8(&self, k: &Consts, i: usize, with_window: bool) -> Taps8 {
        // SAFETY: i + 8 <= len, so within the buffers.
        self.rel
            .bilinear_taps::<true>(k, unsafe { self.load8(i) }, with_window)
    }

    fn tail(&self, from: usize) -> Tail {
        self.rel.tail(from)
    }
}

/// The last pixels of a block (fewer than a step), through the portable kernel: the same
/// arithmetic, so the builds still agree to the bit.
pub(crate) struct Tail {
    from: usize,
    n: usize,
    xs: [f64; 8],
    ys: [f64; 8],
}

impl Tail {
    fn new(from: usize, len: usize) -> Self {
        Self {
            from,
            n: len.saturating_sub(from).min(8),
            xs: [0.0; 8],
            ys: [0.0; 8],
        }
    }

    fn run<K: Kernel, T: Sample>(
        &self,
        g: &SourceGeometry,
        planes: &[&[T]],
        outs: &mut [&mut [T]],
        valid: &mut [bool],
        nodata: T,
    ) {
        for j in 0..self.n {
            let at = self.from + j;
            let mut tap = K::Tap::default();
            valid[at] = K::prepare::<T>(g, self.xs[j], self.ys[j], &mut tap);
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                out[at] = if valid[at] {
                    K::apply(plane, g, &tap)
                } else {
                    nodata
                };
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
fn store_flags(valid: &mut [bool], i: usize, mask: i32) {
    let flags = &mut valid[i..i + 8];
    // SAFETY: `flags` is 8 bools; every byte written is 0 or 1, a valid bool.
    unsafe { (flags.as_mut_ptr() as *mut u64).write_unaligned(FLAG_BYTES[(mask & 0xFF) as usize]) };
}

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

/// The whole steps' length (`n` rounded down to eight) where every pixel of them is inside (by
/// the kernel's own rule: the positions carry its shift): with monotonic positions the inside
/// pixels form one run, so its first and last pixels decide.
#[target_feature(enable = "avx2")]
#[inline]
fn inside_run<P: Positions>(k: &Consts, pos: &P, n: usize) -> Option<usize> {
    let whole = n / 8 * 8;
    if !P::MONOTONIC || whole == 0 || whole > pos.len() {
        return None;
    }
    // SAFETY: 8 <= whole <= len.
    let (first, last) = unsafe { (pos.nearest8(k, 0).mask, pos.nearest8(k, whole - 8).mask) };
    (first & 1 != 0 && last & 0x80 != 0).then_some(whole)
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
        (true, Some(rel)) => unsafe { avx512::nearest_inside16(rel, k.size, planes, outs, whole) },
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

/// The four Keys weights of eight fractions, as `keys_weights_f32` (same operations and order),
/// transposed to per-pixel vectors: `[pixel 0 | pixel 4], [1 | 5], [2 | 6], [3 | 7]`.
#[target_feature(enable = "avx2")]
#[inline]
fn keys8(t: __m256) -> [__m256; 4] {
    let [w0, w1, w2, w3] = keys_lanes(t);
    let (a, b) = (_mm256_unpacklo_ps(w0, w1), _mm256_unpackhi_ps(w0, w1));
    let (c, d) = (_mm256_unpacklo_ps(w2, w3), _mm256_unpackhi_ps(w2, w3));
    [
        _mm256_shuffle_ps::<0x44>(a, c),
        _mm256_shuffle_ps::<0xEE>(a, c),
        _mm256_shuffle_ps::<0x44>(b, d),
        _mm256_shuffle_ps::<0xEE>(b, d),
    ]
}

/// The four Keys weights of eight fractions as `keys_weights_f32` (same operations and order),
/// one vector per tap: `[w0 of pixels 0..8], [w1 ..], [w2 ..], [w3 ..]`.
#[target_feature(enable = "avx2")]
#[inline]
fn keys_lanes(t: __m256) -> [__m256; 4] {
    let c = _mm256_set1_ps;
    let t2 = _mm256_mul_ps(t, t);
    let t3 = _mm256_mul_ps(t2, t);
    let half_t = _mm256_mul_ps(c(0.5), t);
    let w0 = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(c(-0.5), t3), t2), half_t);
    let w1 = _mm256_add_ps(
        _mm256_sub_ps(_mm256_mul_ps(c(1.5), t3), _mm256_mul_ps(c(2.5), t2)),
        c(1.0),
    );
    let w2 = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(c(-1.5), t3), _mm256_mul_ps(c(2.0), t2)),
        half_t,
    );
    let w3 = _mm256_sub_ps(_mm256_mul_ps(c(0.5), t3), _mm256_mul_ps(c(0.5), t2));
    [w0, w1, w2, w3]
}

/// Bicubic split of four positions (`Bicubic::prepare`): clamp to [-1, n] (NaN to -1), floor;
/// the integer part and the fraction (f64, then rounded to f32).
#[target_feature(enable = "avx2")]
#[inline]
fn cubic_split(v: __m256d, hi: __m256d) -> (__m128i, __m128) {
    let c = _mm256_min_pd(_mm256_max_pd(v, _mm256_set1_pd(-1.0)), hi);
    let f = _mm256_floor_pd(c);
    (_mm256_cvttpd_epi32(f), _mm256_cvtpd_ps(_mm256_sub_pd(c, f)))
}

/// The split of eight bicubic positions (`Bicubic::prepare`): inside lanes, the floors of the
/// positions clamped to [-1, n] and their fractions.
pub(crate) struct CubicSplit8 {
    inside: __m256i,
    xi: __m256i,
    yi: __m256i,
    tx: __m256,
    ty: __m256,
}

/// The positions a bicubic block reads: eight at a time as splits, and one pixel's f64 position
/// for the portable kernel (border pixels and the tail).
pub(crate) trait CubicPositions: Positions {
    /// The f64 position of pixel `j < len`.
    fn at(&self, j: usize) -> (f64, f64);

    /// The split of pixels i..i + 8.
    ///
    /// # Safety
    /// AVX2; i + 8 <= len.
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8;
}

impl CubicPositions for Exact<'_> {
    fn at(&self, j: usize) -> (f64, f64) {
        (self.xs[j], self.ys[j])
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8 {
        let (hi_x, hi_y) = (
            _mm256_set1_pd(f64::from(k.size.0)),
            _mm256_set1_pd(f64::from(k.size.1)),
        );
        // SAFETY: i + 8 <= len (the contract).
        let ((x_lo, y_lo), (x_hi, y_hi)) =
            unsafe { (load4(self.xs, self.ys, i), load4(self.xs, self.ys, i + 4)) };
        let (xi_lo, tx_lo) = cubic_split(x_lo, hi_x);
        let (xi_hi, tx_hi) = cubic_split(x_hi, hi_x);
        let (yi_lo, ty_lo) = cubic_split(y_lo, hi_y);
        let (yi_hi, ty_hi) = cubic_split(y_hi, hi_y);
        CubicSplit8 {
            inside: narrow_mask(k.inside(x_lo, y_lo), k.inside(x_hi, y_hi)),
            xi: _mm256_set_m128i(xi_hi, xi_lo),
            yi: _mm256_set_m128i(yi_hi, yi_lo),
            tx: _mm256_set_m128(tx_hi, tx_lo),
            ty: _mm256_set_m128(ty_hi, ty_lo),
        }
    }
}

/// Fast positions: the split of origin + offset done on the f32 offset. The clamp to
/// [-1 - origin, n - origin] and the floor are exact in f32, and offset - floor(offset) is one
/// rounding of the exact fraction, as `Bicubic::prepare`'s f64 difference cast to f32 is: both
/// builds get the same taps.
impl CubicPositions for Buffered<'_> {
    fn at(&self, j: usize) -> (f64, f64) {
        let (mut x, mut y) = ([0.0], [0.0]);
        self.rel.block.fill(j, &mut x, &mut y);
        (x[0], y[0])
    }

    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn cubic8(&self, k: &Consts, i: usize) -> CubicSplit8 {
        // SAFETY: i + 8 <= len, so within the buffers.
        let p = unsafe { self.load8(i) };
        let inside = self.rel.inside8(&p);
        let split = |a: usize, size: i32| {
            let o = self.rel.block.origin[a];
            let lo = _mm256_set1_ps((-1 - o) as f32);
            let hi = _mm256_set1_ps((size - o) as f32);
            let c = _mm256_min_ps(_mm256_max_ps(p[a], lo), hi);
            let f = _mm256_floor_ps(c);
            let i = _mm256_add_epi32(_mm256_cvttps_epi32(f), self.rel.origin[a]);
            (i, _mm256_sub_ps(c, f))
        };
        let ((xi, tx), (yi, ty)) = (split(0, k.size.0), split(1, k.size.1));
        CubicSplit8 {
            inside: _mm256_castps_si256(inside),
            xi,
            yi,
            tx,
            ty,
        }
    }
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

/// Eight interior bicubic pixels whose 4 x 4 neighbourhoods lie within 16 samples of four or
/// five source rows: each row is loaded once and the taps are picked from it by shuffles (the
/// `Window` layout of bilinear, for 4 x 4 taps).
pub(crate) struct CubicWindow {
    /// Index of the first sample of the first row (column xmin - 1 of row ymin - 1).
    start: usize,
    /// Per pixel: its first tap column from the window's first (x - xmin, 0..=12).
    rel: __m256i,
    /// All ones where the pixel's tap rows start one row lower (y = ymin + 1).
    lower: __m256i,
    /// Rows read: 4 when the eight pixels' rows are equal, else 5.
    rows: usize,
}

/// The window of eight pixels split as `s`, when all are interior and it fits (monotonic
/// positions: the extremes are the first and last lanes).
#[target_feature(enable = "avx2")]
#[inline]
fn cubic_window(k: &Consts, s: &CubicSplit8) -> Option<CubicWindow> {
    let (w, h) = k.size;
    let (xmin, xmax) = ends8(s.xi);
    let (ymin, ymax) = ends8(s.yi);
    // Interior (1 <= x <= w - 3, 1 <= y <= h - 3); 16 samples from xmin - 1 hold the columns
    // xmin - 1 ..= xmax + 2 and end inside the row.
    if xmin < 1 || xmax > w - 3 || ymin < 1 || ymax > h - 3 {
        return None;
    }
    if xmax - xmin > 12 || ymax - ymin > 1 || xmin + 15 > w {
        return None;
    }
    Some(CubicWindow {
        start: ((ymin - 1) * w + xmin - 1) as usize,
        rel: _mm256_sub_epi32(s.xi, _mm256_set1_epi32(xmin)),
        lower: _mm256_cmpgt_epi32(s.yi, _mm256_set1_epi32(ymin)),
        rows: (4 + ymax - ymin) as usize,
    })
}

/// The vertical-then-horizontal bicubic sum of eight pixels (`Bicubic::apply`'s order). One pair
/// of tap columns (`p`: columns 2p, 2p + 1) at a time, so that few registers are live:
/// `row(j, p)` reads the pair from the window's row j, `split(upper, lower)` gives the pair's
/// two columns of each pixel, from its upper or its lower row (`CubicWindow::lower`).
#[target_feature(enable = "avx2")]
#[inline]
fn cubic_sum8<R: Copy>(
    (wx, wy): (&[__m256; 4], &[__m256; 4]),
    row: impl Fn(usize, usize) -> R,
    split: impl Fn(R, R) -> [__m256; 2],
) -> __m256 {
    let pair = |p: usize| {
        let (mut a, mut b) = (_mm256_setzero_ps(), _mm256_setzero_ps());
        let mut upper = row(0, p);
        for (r, &wr) in wy.iter().enumerate() {
            let below = row(r + 1, p);
            let [ta, tb] = split(upper, below);
            let (ma, mb) = (_mm256_mul_ps(ta, wr), _mm256_mul_ps(tb, wr));
            (a, b) = match r {
                0 => (ma, mb),
                _ => (_mm256_add_ps(a, ma), _mm256_add_ps(b, mb)),
            };
            upper = below;
        }
        (_mm256_mul_ps(a, wx[2 * p]), _mm256_mul_ps(b, wx[2 * p + 1]))
    };
    let (h0, h1) = pair(0);
    let (h2, h3) = pair(1);
    _mm256_add_ps(_mm256_add_ps(h0, h2), _mm256_add_ps(h1, h3))
}

/// Bicubic of a window's eight pixels for u16 and f32 (`SimdSample::cubic_window8`): each row's
/// 16 samples as two f32 vectors (`SimdSample::row16`), the taps picked by lane permutes.
///
/// # Safety
/// AVX2; `win.rows` rows of 16 samples from `win.start` (stride `width`) inside `plane`.
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn cubic_window8_wide<T: SimdSample>(
    win: &CubicWindow,
    w: (&[__m256; 4], &[__m256; 4]),
    plane: &[T],
    width: usize,
) -> __m256 {
    debug_assert!(win.start + (win.rows - 1) * width + 16 <= plane.len());
    // Branch-free: with four rows, the fifth is the fourth again (and `lower` all clear).
    // SAFETY: the contract.
    let rows: [[__m256; 2]; 5] = std::array::from_fn(|j| unsafe {
        T::row16(plane.as_ptr().add(win.start + j.min(win.rows - 1) * width))
    });
    let lower = _mm256_castsi256_ps(win.lower);
    // Lane permutes read the low three bits; bit 3 chooses the second vector.
    let cols: [__m256i; 4] =
        std::array::from_fn(|c| _mm256_add_epi32(win.rel, _mm256_set1_epi32(c as i32)));
    let take = |r: &[__m256; 2], i: __m256i| {
        _mm256_blendv_ps(
            _mm256_permutevar8x32_ps(r[0], i),
            _mm256_permutevar8x32_ps(r[1], i),
            _mm256_castsi256_ps(_mm256_slli_epi32::<28>(i)),
        )
    };
    let pair = |j: usize, p: usize| [take(&rows[j], cols[2 * p]), take(&rows[j], cols[2 * p + 1])];
    let split = |upper: [__m256; 2], below: [__m256; 2]| {
        [0, 1].map(|c| _mm256_blendv_ps(upper[c], below[c], lower))
    };
    cubic_sum8(w, pair, split)
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
        pos.buffered().filter(|b| avx512::cubic16_fits(b))
    } else {
        None
    };
    let mut i = 0;
    while i + 8 <= n {
        if let Some(b) = wide.filter(|_| i + 16 <= n) {
            // SAFETY: `g.avx512`: the CPU has AVX-512 F, BW, VL, VBMI, VNNI; i + 16 <= n, within
            // the buffers (whole steps of eight) and every output; the planes as this contract.
            if unsafe { avx512::bicubic_window16(b, i, k.size, planes, outs) } {
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
    let wide = g.avx512 && pos.buffered().is_some_and(avx512::cubic16_fits);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `row16` reads sixteen samples as their f32 values, and `store8` writes eight values as
    /// `Sample::from_f32` does (rounding and saturating for the integer types), for every type.
    fn rows_and_stores_match_the_scalar_definitions<T: SimdSample>(samples: [T; 16]) {
        if !crate::cpu::avx2() {
            return;
        }
        let values = [-3.7f32, -0.4, 0.49, 0.5, 254.5, 255.6, 65535.4, 70000.0];
        // SAFETY: AVX2 is there; sixteen samples are readable, eight writable.
        let (row, out) = unsafe {
            let row = T::row16(samples.as_ptr());
            let mut out = [T::default(); 8];
            T::store8(_mm256_loadu_ps(values.as_ptr()), &mut out);
            (std::mem::transmute::<[__m256; 2], [f32; 16]>(row), out)
        };
        for (j, (r, s)) in row.iter().zip(samples).enumerate() {
            assert_eq!(*r, s.to_f32(), "{}: sample {j}", T::NAME);
        }
        for (j, (o, v)) in out.iter().zip(values).enumerate() {
            assert!(*o == T::from_f32(v), "{}: value {v} (lane {j})", T::NAME);
        }
    }

    #[test]
    fn simd_rows_and_stores_match_the_scalar_definitions() {
        rows_and_stores_match_the_scalar_definitions::<u8>(std::array::from_fn(|i| {
            (i * 17 + 3) as u8
        }));
        rows_and_stores_match_the_scalar_definitions::<u16>(std::array::from_fn(|i| {
            (i * 4099 + 7) as u16
        }));
        rows_and_stores_match_the_scalar_definitions::<f32>(std::array::from_fn(|i| {
            i as f32 * -1.25 + 0.1
        }));
    }
}
