//! The AVX-512 bicubic steps: sixteen-pixel windows (u16, f32; u8 where its AVX2 windows do not
//! apply).

use super::rows::ends16;
use crate::warp::simd::avx2::positions::Buffered;
use crate::warp::simd::avx2::sample::SimdSample;
use std::arch::x86_64::*;

/// The split of sixteen bicubic positions (`Buffered::cubic8`'s, same operations): the floors
/// of the offsets clamped to [-1 - origin, size - origin], plus the origin, and the fractions.
pub(super) struct CubicSplit16 {
    pub(super) xi: __m512i,
    pub(super) yi: __m512i,
    pub(super) tx: __m512,
    pub(super) ty: __m512,
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
    pub(super) start: usize,
    /// Per pixel: its first tap column less `xs` (0..=28).
    pub(super) rel: __m512i,
    /// The pixels whose tap rows start one row lower (y > ymin), and two (y = ymin + 2).
    lower: [__mmask16; 2],
    /// Rows read: 4 + ymax - ymin.
    pub(super) rows: usize,
}

impl CubicWindow16 {
    /// The window of sixteen pixels split as `s` on a `size` image, where all are interior
    /// (1 <= x <= w - 3, 1 <= y <= h - 3), their columns within 29 and rows within 3
    /// (monotonic positions: the extremes are the first and last lanes).
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) fn of(s: &CubicSplit16, size: (i32, i32)) -> Option<Self> {
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
pub(crate) fn cubic16_fits(pos: &Buffered<'_>) -> bool {
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
pub(crate) unsafe fn bicubic_window16<T: SimdSample>(
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
