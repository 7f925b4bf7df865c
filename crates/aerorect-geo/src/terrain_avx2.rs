//! [`super::HeightGrid::heights_along`]'s loop four heights at a time (AVX2), bit for bit the
//! scalar loop's: the same IEEE operations in the same order, no fused multiply-add. The
//! scalar loop is bound by its instruction count, not by a division or a lookup: about 8 ns
//! a height, an eighth of the snowpeak mosaic's CPU time over its tie surface. Gathering the
//! nodes took most of this loop's time (`terrain/heights-along` in the geo crate's `ortho`
//! bench: 14.6 ns a height gathered, 4.1 broadcast where four heights share a cell).

use std::arch::x86_64::*;

/// The two rows of nodes a row of heights lies between, and where it lies.
pub(super) struct RowNodes<'a> {
    /// The node row above and the one below (equal lengths, the grid's width).
    pub(super) top: &'a [f32],
    pub(super) bottom: &'a [f32],
    /// The row's fraction of the way from `top` to `bottom`.
    pub(super) fy: f64,
    /// The grid's first node column's x, and the node spacing.
    pub(super) x0: f64,
    pub(super) spacing: f64,
}

/// Replaces the leading multiple of four of `xs` by their heights (as the scalar loop of
/// [`super::HeightGrid::heights_along`]); returns how many it replaced.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn heights(nodes: &RowNodes<'_>, xs: &mut [f64]) -> usize {
    let w = nodes.top.len();
    // Node indices are gathered as i32; a grid this wide is left to the scalar loop.
    if w == 0 || nodes.bottom.len() != w || i32::try_from(w).is_err() {
        return 0;
    }
    let wm1 = _mm256_set1_pd((w - 1) as f64);
    let zero = _mm256_setzero_pd();
    let one = _mm256_set1_pd(1.0);
    let x0 = _mm256_set1_pd(nodes.x0);
    let spacing = _mm256_set1_pd(nodes.spacing);
    let fy = _mm256_set1_pd(nodes.fy);
    // `nodes_around`: i0 = floor(col) within 0..=w - 2 (0 for one node), i1 = i0 + 1 within w - 1.
    let last_first = _mm_set1_epi32(w.saturating_sub(2) as i32);
    let last = _mm_set1_epi32((w - 1) as i32);
    let one_i = _mm_set1_epi32(1);
    let infinity = _mm256_set1_pd(f64::INFINITY);
    let nan = _mm256_set1_pd(f64::NAN);
    let magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
    let lerp = |a: __m256d, b: __m256d, t: __m256d| {
        _mm256_add_pd(_mm256_mul_pd(a, _mm256_sub_pd(one, t)), _mm256_mul_pd(b, t))
    };
    let chunks = xs.chunks_exact_mut(4);
    let done = chunks.len() * 4;
    for chunk in chunks {
        // SAFETY: `chunk` holds 4 f64 (an unaligned load and store).
        let x = unsafe { _mm256_loadu_pd(chunk.as_ptr()) };
        let col = _mm256_div_pd(_mm256_sub_pd(x, x0), spacing);
        // f64::clamp(0, w - 1): max and min give their second operand for a NaN, so a NaN
        // stays NaN; -0.0 stays -0.0 as in the scalar clamp.
        let col = _mm256_min_pd(wm1, _mm256_max_pd(zero, col));
        let valid = _mm256_cmp_pd::<_CMP_ORD_Q>(col, col);
        let col = _mm256_blendv_pd(zero, col, valid);
        let first = _mm256_cvttpd_epi32(_mm256_floor_pd(col));
        let i0 = _mm_min_epi32(first, last_first);
        let i1 = _mm_min_epi32(_mm_add_epi32(i0, one_i), last);
        let fx = _mm256_sub_pd(col, _mm256_cvtepi32_pd(i0));
        // SAFETY: 0 <= i0, i1 <= w - 1 and both rows hold w values.
        let [t0, t1, b0, b1] = unsafe { corners(nodes, i0, i1) };
        let v = lerp(lerp(t0, t1, fx), lerp(b0, b1, fx), fy);
        let finite = _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_and_pd(v, magnitude), infinity);
        let v = _mm256_blendv_pd(nan, v, _mm256_and_pd(valid, finite));
        // SAFETY: as the load.
        unsafe { _mm256_storeu_pd(chunk.as_mut_ptr(), v) };
    }
    done
}

/// The four nodes around four heights (top and bottom rows, at node columns `i0` and `i1`),
/// widened to f64. The lanes of a row of heights lie mostly in one cell (a DEM's node spans
/// many output pixels): there the nodes are loaded once and broadcast, where gathering them
/// took most of the loop's time on AMD's cores (gathers are microcoded there).
///
/// # Safety
/// The CPU must have AVX2; every lane of `i0` and `i1` must index both rows.
#[target_feature(enable = "avx2")]
unsafe fn corners(nodes: &RowNodes<'_>, i0: __m128i, i1: __m128i) -> [__m256d; 4] {
    let first = _mm_shuffle_epi32::<0>(i0);
    if _mm_movemask_epi8(_mm_cmpeq_epi32(i0, first)) == 0xffff {
        // Every lane's i0 (and so its i1) is lane 0's.
        let (c0, c1) = (
            _mm_cvtsi128_si32(i0) as usize,
            _mm_cvtsi128_si32(i1) as usize,
        );
        let at = |row: &[f32], c: usize| _mm256_set1_pd(f64::from(row[c]));
        return [
            at(nodes.top, c0),
            at(nodes.top, c1),
            at(nodes.bottom, c0),
            at(nodes.bottom, c1),
        ];
    }
    [
        (nodes.top, i0),
        (nodes.top, i1),
        (nodes.bottom, i0),
        (nodes.bottom, i1),
    ]
    // SAFETY: the caller's: every lane indexes the row.
    .map(|(row, i)| unsafe { _mm256_cvtps_pd(_mm_i32gather_ps::<4>(row.as_ptr(), i)) })
}
