//! The source positions of one block as the AVX2 kernels read them: exact f64 positions
//! (`Exact`) or a projective block's f32 offsets from an integer origin, fused (`Relative`) or
//! computed ahead (`Buffered`).

use super::bilinear_lanes::{Taps8, bilinear_taps8, window};
use super::lanes::{Consts, load4};
use super::nearest_lanes::NearestTaps;
use super::tail::Tail;
use crate::warp::relative::RelativeBlock;
use crate::warp::simd::avx512::offsets::fill_offsets16;
use crate::warp::types::SourceGeometry;
use std::arch::x86_64::*;

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

/// The whole steps' length (`n` rounded down to eight) where every pixel of them is inside (by
/// the kernel's own rule: the positions carry its shift): with monotonic positions the inside
/// pixels form one run, so its first and last pixels decide.
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn inside_run<P: Positions>(k: &Consts, pos: &P, n: usize) -> Option<usize> {
    let whole = n / 8 * 8;
    if !P::MONOTONIC || whole == 0 || whole > pos.len() {
        return None;
    }
    // SAFETY: 8 <= whole <= len.
    let (first, last) = unsafe { (pos.nearest8(k, 0).mask, pos.nearest8(k, whole - 8).mask) };
    (first & 1 != 0 && last & 0x80 != 0).then_some(whole)
}

/// Fast positions (`relative::RelativeBlock`): f32 offsets from the block's integer origin,
/// compared against the image's limits moved by the origin. Every operation is that of
/// `RelativeBlock::offset` and of the portable kernels on `origin + offset`, so the builds agree
/// bit for bit.
pub(crate) struct Relative {
    pub(crate) block: RelativeBlock,
    pub(crate) n: usize,
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
    pub(crate) cmin: [__m256; 2],
    pub(crate) cmax: [__m256; 2],
    pub(crate) origin: [__m256i; 2],
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
            i = unsafe { fill_offsets16(&self.block, px, py) };
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
    pub(crate) fn inside8(&self, p: &[__m256; 2]) -> __m256 {
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
    pub(crate) unsafe fn load8(&self, i: usize) -> [__m256; 2] {
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
