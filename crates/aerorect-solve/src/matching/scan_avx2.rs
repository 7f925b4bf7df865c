//! [`super::scan::scan_row`] eight train rows at a time (AVX2): the distances, each lane's two
//! smallest and the columns' best queries in one pass over the row's products, where the
//! portable code makes three (the distances stored, then read twice). The compiler kept the
//! portable search's lanes in memory, a masked store per lane and step: the scans took more
//! CPU than the matrix product (snowpeak's features round: 1.3 s against 0.8 s).
//! The same IEEE operations as [`super::scan::Row::distance`] (no fused multiply-add), and the
//! same choices: every lane keeps its first strictly smaller values, every column its first
//! strictly closer query.

use super::scan::{Columns, Row};
use std::arch::x86_64::*;

/// Each lane's smallest and second-smallest distance with its train row (`usize::MAX`: none).
pub(super) type Lanes = [(f32, usize); 16];

/// The leading multiple of eight of `row`'s train rows: every lane's two smallest distances,
/// and the columns `old` updated with query `row.i` into `new`; returns the lanes and how many
/// rows were scanned. The columns are written to other arrays than they are read from: a
/// blend of what was loaded from the same address, stored back, the compiler made a masked
/// store (slow on AMD's cores: most of the scan's time).
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn scan(row: &Row<'_>, (old, new): (&Columns, &mut Columns)) -> (Lanes, usize) {
    const NONE: (f32, usize) = (f32::INFINITY, usize::MAX);
    let n = row.products.len();
    let fits = |c: &Columns| c.distance.len() == n && c.query.len() == n;
    if row.tn.len() != n || !fits(old) || !fits(new) {
        return ([NONE; 16], 0);
    }
    let m = n - n % 8;
    let (qn, two) = (_mm256_set1_ps(row.qn), _mm256_set1_ps(2.0));
    let zero = _mm256_setzero_ps();
    let query = _mm256_castsi256_ps(_mm256_set1_epi32(row.i as i32));
    let (mut b1, mut b2) = (_mm256_set1_ps(f32::INFINITY), _mm256_set1_ps(f32::INFINITY));
    let unset = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    let (mut i1, mut i2) = (unset, unset);
    let mut j = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    let eight = _mm256_set1_epi32(8);
    let (p, t) = (row.products.as_ptr(), row.tn.as_ptr());
    let (od, oq) = (old.distance.as_ptr(), old.query.as_ptr().cast::<f32>());
    let (nd, nq) = (
        new.distance.as_mut_ptr(),
        new.query.as_mut_ptr().cast::<f32>(),
    );
    for c in (0..m).step_by(8) {
        // SAFETY: c + 8 <= m <= n, the length of all six slices.
        unsafe {
            let sum = _mm256_add_ps(qn, _mm256_loadu_ps(t.add(c)));
            let d = _mm256_sub_ps(sum, _mm256_mul_ps(two, _mm256_loadu_ps(p.add(c))));
            // f32::max(d, 0.0): 0 where d is below (or NaN).
            let d = _mm256_max_ps(d, zero);
            let jf = _mm256_castsi256_ps(j);
            let below1 = _mm256_cmp_ps::<_CMP_LT_OQ>(d, b1);
            let below2 = _mm256_cmp_ps::<_CMP_LT_OQ>(d, b2);
            b2 = _mm256_blendv_ps(_mm256_blendv_ps(b2, d, below2), b1, below1);
            i2 = _mm256_blendv_ps(_mm256_blendv_ps(i2, jf, below2), i1, below1);
            b1 = _mm256_blendv_ps(b1, d, below1);
            i1 = _mm256_blendv_ps(i1, jf, below1);
            let best = _mm256_loadu_ps(od.add(c));
            let closer = _mm256_cmp_ps::<_CMP_LT_OQ>(d, best);
            _mm256_storeu_ps(nd.add(c), _mm256_blendv_ps(best, d, closer));
            let q = _mm256_loadu_ps(oq.add(c));
            _mm256_storeu_ps(nq.add(c), _mm256_blendv_ps(q, query, closer));
            j = _mm256_add_epi32(j, eight);
        }
    }
    let mut out = [NONE; 16];
    let (mut v, mut k) = ([0f32; 8], [0u32; 8]);
    for (slot, (b, i)) in [(0, (b1, i1)), (8, (b2, i2))] {
        // SAFETY: eight lanes into arrays of eight.
        unsafe {
            _mm256_storeu_ps(v.as_mut_ptr(), b);
            _mm256_storeu_ps(k.as_mut_ptr().cast::<f32>(), i);
        }
        for lane in 0..8 {
            let j = if k[lane] == u32::MAX {
                usize::MAX
            } else {
                k[lane] as usize
            };
            out[slot + lane] = (v[lane], j);
        }
    }
    (out, m)
}
