//! Where sixteen pixels' taps lie in a few source rows (`Rows16`), for the permute steps.

use std::arch::x86_64::*;

/// The first and last lanes of sixteen, in order (the extremes where they are monotonic).
#[target_feature(enable = "avx512f")]
#[inline]
pub(crate) fn ends16(v: __m512i) -> (i32, i32) {
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
    pub(crate) last: usize,
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
