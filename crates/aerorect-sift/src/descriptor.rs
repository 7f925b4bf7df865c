//! 128-dimensional descriptor: a 4x4 grid of 8-bin gradient histograms,
//! accumulated with trilinear interpolation.
//!
//! # Numerics
//!
//! Two details carry the bit-exactness. The scatter is sequential in the
//! reference's sample order, because float addition is not associative. And the
//! normalisation tail computes `nrm2` with a **four-lane FMA accumulation
//! followed by a pairwise reduction**, not a scalar sum — see [`nrm2`].

use super::hal::{exp_batch, grow_to, mag_ang_batch};
use super::scatter::scatter;

use super::orient::OrientedKeypoint;

/// Grid width (`SIFT_DESCR_WIDTH`).
pub const DESCR_WIDTH: usize = 4;
/// Orientation bins per cell (`SIFT_DESCR_HIST_BINS`).
pub const DESCR_HIST_BINS: usize = 8;
/// Descriptor length.
pub const DESCR_LEN: usize = DESCR_WIDTH * DESCR_WIDTH * DESCR_HIST_BINS;
/// Patch scale factor (`SIFT_DESCR_SCL_FCTR`).
pub const DESCR_SCL_FCTR: f32 = 3.0;
/// Post-normalisation clamp (`SIFT_DESCR_MAG_THR`).
pub const DESCR_MAG_THR: f32 = 0.2;
/// Quantisation factor (`SIFT_INT_DESCR_FCTR`).
pub const INT_DESCR_FCTR: f32 = 512.0;

/// Narrow `[lo, hi]` to the `j` satisfying `-1 < j * coef + off < limit`.
///
/// Both descriptor bin coordinates are affine in `j` (`r_rot = j * sin_t +
/// i * cos_t`, and likewise for `c_rot`), so each bound is a half-plane and the
/// accepted `j` of a row form one contiguous run. `coef == 0` makes the
/// constraint independent of `j`: it either holds for the whole row or kills it.
#[inline]
fn clip_j(coef: f32, off: f32, limit: f32, lo: &mut f32, hi: &mut f32) {
    if coef > 0.0 {
        *lo = lo.max((-1.0 - off) / coef);
        *hi = hi.min((limit - off) / coef);
    } else if coef < 0.0 {
        *lo = lo.max((limit - off) / coef);
        *hi = hi.min((-1.0 - off) / coef);
    } else if !(off > -1.0 && off < limit) {
        // Empty row.
        *lo = 1.0;
        *hi = 0.0;
    }
}

/// The reference accumulates over four SIMD lanes with FMA, then reduces
/// pairwise: `((l0+l1) + (l2+l3))`. A plain scalar sum gives a different value.
fn nrm2(v: &[f32]) -> f32 {
    let (mut a0, mut a1, mut a2, mut a3) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let mut k = 0usize;
    while k + 4 <= v.len() {
        a0 = v[k].mul_add(v[k], a0);
        a1 = v[k + 1].mul_add(v[k + 1], a1);
        a2 = v[k + 2].mul_add(v[k + 2], a2);
        a3 = v[k + 3].mul_add(v[k + 3], a3);
        k += 4;
    }
    let mut s = (a0 + a1) + (a2 + a3);
    while k < v.len() {
        s += v[k] * v[k];
        k += 1;
    }
    s
}

/// Per-thread scratch for [`compute_descriptor`].
///
/// The reference batches each HAL primitive over the **whole patch** —
/// `fastAtan2`, `magnitude32f` and `exp32f` each run as one long loop — instead
/// of evaluating four samples at a time between scatters. That turns out to
/// matter a lot: four-at-a-time measured 39 ns per accepted sample against the
/// reference's 22 ns, because the three transcendental emulations and the
/// histogram scatter all compete for registers inside one loop body. These
/// buffers make the same split possible here. One per rayon worker, reused
/// across keypoints, since a patch is a few thousand floats and allocating per
/// keypoint would dominate.
#[derive(Default)]
pub struct DescriptorScratch {
    pub(super) rbin: Vec<f32>,
    pub(super) cbin: Vec<f32>,
    pub(super) dx: Vec<f32>,
    pub(super) dy: Vec<f32>,
    pub(super) wt: Vec<f32>,
    pub(super) mag: Vec<f32>,
    pub(super) ang: Vec<f32>,
}

impl DescriptorScratch {
    /// Empty scratch; sized on first use.
    ///
    /// The buffers are grown monotonically and written by index with a sample
    /// counter, never cleared: every element read is written first, so a reset
    /// would only cost a pass that changes nothing.
    pub fn new() -> Self {
        Self::default()
    }
}

/// Compute one 128-D descriptor.
///
/// `ptx`, `pty` and `scl` are in the **octave's** coordinate frame, and `ori` is
/// the reference's `360 - angle` with a near-360 result collapsed to zero — the
/// caller applies both conversions, as `calcDescriptors` does.
///
/// `sc` is caller-owned scratch; see [`DescriptorScratch`] for why the patch is
/// buffered whole rather than four samples at a time.
#[allow(clippy::too_many_arguments)]
pub fn compute_descriptor(
    img: &[f32],
    w: usize,
    h: usize,
    ptx: f32,
    pty: f32,
    scl: f32,
    ori: f32,
    out: &mut [f32],
    sc: &mut DescriptorScratch,
) {
    const D: usize = DESCR_WIDTH;
    const N: usize = DESCR_HIST_BINS;
    const HISTLEN: usize = (D + 2) * (D + 2) * (N + 2);
    debug_assert_eq!(out.len(), DESCR_LEN);

    let px = ptx.round_ties_even() as i32;
    let py = pty.round_ties_even() as i32;
    let mut cos_t = (ori * (std::f32::consts::PI / 180.0)).cos();
    let mut sin_t = (ori * (std::f32::consts::PI / 180.0)).sin();
    let bins_per_rad = N as f32 / 360.0;
    let exp_scale = -1.0 / (D as f32 * D as f32 * 0.5);
    let hist_width = DESCR_SCL_FCTR * scl;
    let mut radius =
        (hist_width * std::f32::consts::SQRT_2 * (D as f32 + 1.0) * 0.5).round_ties_even() as i32;
    let diag = ((w as f32) * (w as f32) + (h as f32) * (h as f32)).sqrt() as i32;
    if radius > diag {
        radius = diag;
    }
    cos_t /= hist_width;
    sin_t /= hist_width;

    let mut hist = [0.0f32; HISTLEN];

    // Size the buffers to the row span once, then write by index. The
    // reference fills preallocated arrays with a running counter; `Vec::push`
    // costs a capacity check per element, and there are five buffers times
    // ~1400 samples per keypoint.
    let i_lo = (-radius).max(1 - py);
    let i_hi = radius.min(h as i32 - 2 - py);
    let cap = (i_hi - i_lo + 1).max(0) as usize * (2 * radius + 1) as usize;
    // Eight spare values: the x86 lanes store whole blocks (see below).
    for buf in [
        &mut sc.dx,
        &mut sc.dy,
        &mut sc.rbin,
        &mut sc.cbin,
        &mut sc.wt,
    ] {
        grow_to(buf, cap + 8);
    }
    let mut n = 0usize;

    // The row bound is exactly the reference's `r > 0 && r < rows - 1`, hoisted
    // out of the inner test: it depends only on `i`.
    for i in i_lo..=i_hi {
        // Accepted `j` form one contiguous run per row (see `clip_j`). Deriving
        // it skips the ~52% of the square the predicate rejects — measured on
        // apriltags: 5.50M iterations for 2.63M accepted samples.
        //
        // The derived bounds are float arithmetic and the original predicate is
        // NOT float-associative-safe to replace, so the run is widened by one on
        // each side and every surviving `j` still faces the identical test
        // below. Skipping therefore removes provably-rejected iterations only,
        // and cannot move a sample into or out of the histogram.
        let (mut jf_lo, mut jf_hi) = (-(radius as f32), radius as f32);
        let half = D as f32 / 2.0 - 0.5;
        clip_j(
            sin_t,
            i as f32 * cos_t + half,
            D as f32,
            &mut jf_lo,
            &mut jf_hi,
        );
        clip_j(
            cos_t,
            -(i as f32) * sin_t + half,
            D as f32,
            &mut jf_lo,
            &mut jf_hi,
        );
        if jf_lo > jf_hi {
            continue;
        }
        let j_lo = (jf_lo.floor() as i32 - 1).max(-radius).max(1 - px);
        let j_hi = (jf_hi.ceil() as i32 + 1).min(radius).min(w as i32 - 2 - px);

        let r = (py + i) as usize;
        let (row, up, dn) = (r * w, (r - 1) * w, (r + 1) * w);

        // Scalar body, shared by the 4-wide fallback and the tail.
        //
        // SAFETY (both paths): `n` counts accepted samples, and the loops run
        // at most `(i_hi - i_lo + 1) * (2 * radius + 1) == cap` times between
        // them, so `n < cap` and every buffer is `cap` long. The row and
        // column bounds already guarantee all four stencil neighbours exist.
        macro_rules! push_sample {
            ($j:expr) => {{
                let j = $j;
                let c_rot = j as f32 * cos_t - i as f32 * sin_t;
                let r_rot = j as f32 * sin_t + i as f32 * cos_t;
                let rbin = r_rot + D as f32 / 2.0 - 0.5;
                let cbin = c_rot + D as f32 / 2.0 - 0.5;
                if rbin > -1.0 && rbin < D as f32 && cbin > -1.0 && cbin < D as f32 {
                    let c = (px + j) as usize;
                    // The macro expands both inside and outside the NEON
                    // unsafe block, so this inner one is redundant there.
                    #[allow(unused_unsafe)]
                    unsafe {
                        *sc.dx.get_unchecked_mut(n) = img[row + c + 1] - img[row + c - 1];
                        *sc.dy.get_unchecked_mut(n) = img[up + c] - img[dn + c];
                        *sc.rbin.get_unchecked_mut(n) = rbin;
                        *sc.cbin.get_unchecked_mut(n) = cbin;
                        *sc.wt.get_unchecked_mut(n) = (c_rot * c_rot + r_rot * r_rot) * exp_scale;
                    }
                    n += 1;
                }
            }};
        }

        let mut j = j_lo;

        // 4-wide body. `clip_j` widens the accepted run by at most one on each
        // side, so rejects sit only at the run's two ends and almost every
        // block passes whole; a partial block falls back to the scalar body so
        // packing order is preserved. Expression shapes are the scalar's
        // exactly — mul/mul/sub for c_rot, mul/mul/add for r_rot, and
        // mul,mul,add,mul for the weight; **no FMA anywhere** (Rust never
        // contracts, so introducing one would change the descriptor). The
        // hoisted i*sin_t / i*cos_t are the same product the scalar computed
        // per iteration, rounded once — identical value.
        #[cfg(target_arch = "aarch64")]
        unsafe {
            use std::arch::aarch64::*;
            let isin = i as f32 * sin_t;
            let icos = i as f32 * cos_t;
            let half = D as f32 / 2.0 - 0.5;
            let dsize = D as f32;
            let base = vld1q_f32([0.0f32, 1.0, 2.0, 3.0].as_ptr());
            while j + 3 <= j_hi {
                let jv = vaddq_f32(vdupq_n_f32(j as f32), base);
                let c_rot = vsubq_f32(vmulq_n_f32(jv, cos_t), vdupq_n_f32(isin));
                let r_rot = vaddq_f32(vmulq_n_f32(jv, sin_t), vdupq_n_f32(icos));
                let rbin = vaddq_f32(r_rot, vdupq_n_f32(half));
                let cbin = vaddq_f32(c_rot, vdupq_n_f32(half));

                let ok = vandq_u32(
                    vandq_u32(
                        vcgtq_f32(rbin, vdupq_n_f32(-1.0)),
                        vcltq_f32(rbin, vdupq_n_f32(dsize)),
                    ),
                    vandq_u32(
                        vcgtq_f32(cbin, vdupq_n_f32(-1.0)),
                        vcltq_f32(cbin, vdupq_n_f32(dsize)),
                    ),
                );
                if vminvq_u32(ok) != u32::MAX {
                    // Partial block: rejects only at run ends. Scalar keeps
                    // the packed order exact.
                    for jj in j..j + 4 {
                        push_sample!(jj);
                    }
                } else {
                    let c0 = (px + j) as usize;
                    let wt = vmulq_n_f32(
                        vaddq_f32(vmulq_f32(c_rot, c_rot), vmulq_f32(r_rot, r_rot)),
                        exp_scale,
                    );
                    let dxv = vsubq_f32(
                        vld1q_f32(img.as_ptr().add(row + c0 + 1)),
                        vld1q_f32(img.as_ptr().add(row + c0 - 1)),
                    );
                    let dyv = vsubq_f32(
                        vld1q_f32(img.as_ptr().add(up + c0)),
                        vld1q_f32(img.as_ptr().add(dn + c0)),
                    );
                    vst1q_f32(sc.dx.as_mut_ptr().add(n), dxv);
                    vst1q_f32(sc.dy.as_mut_ptr().add(n), dyv);
                    vst1q_f32(sc.rbin.as_mut_ptr().add(n), rbin);
                    vst1q_f32(sc.cbin.as_mut_ptr().add(n), cbin);
                    vst1q_f32(sc.wt.as_mut_ptr().add(n), wt);
                    n += 4;
                }
                j += 4;
            }
        }

        // The same body 8 wide on x86-64 (AVX2), to the row's end. Each lane repeats the
        // scalar's expressions: `(r_rot + D / 2) - 0.5` as the scalar associates it (the NEON
        // block above adds 1.5, its own order), and no fused multiply-add. The samples a block
        // keeps are one run of its lanes (both bin coordinates are monotonic in `j`, so each
        // test keeps an interval of the row): the block's lanes are turned so that the run's
        // first lands at `n`, and what follows the run is overwritten by the next block (the
        // buffers have 8 spare values). The row's last block reads its pixels through a mask.
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        unsafe {
            use std::arch::x86_64::*;
            let isin = _mm256_set1_ps(i as f32 * sin_t);
            let icos = _mm256_set1_ps(i as f32 * cos_t);
            let (cv, sv) = (_mm256_set1_ps(cos_t), _mm256_set1_ps(sin_t));
            let (mid, half) = (_mm256_set1_ps(D as f32 / 2.0), _mm256_set1_ps(0.5));
            let (lo, hi) = (_mm256_set1_ps(-1.0), _mm256_set1_ps(D as f32));
            let scale = _mm256_set1_ps(exp_scale);
            let lanes = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
            let ramp = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let inside = |v| {
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(v, lo),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(v, hi),
                )
            };
            while j <= j_hi {
                // Lanes j..=j_hi of the block.
                let in_row = _mm256_cmpgt_epi32(_mm256_set1_epi32((j_hi - j + 1).min(8)), ramp);
                let jv = _mm256_add_ps(_mm256_set1_ps(j as f32), lanes);
                let c_rot = _mm256_sub_ps(_mm256_mul_ps(jv, cv), isin);
                let r_rot = _mm256_add_ps(_mm256_mul_ps(jv, sv), icos);
                let rbin = _mm256_sub_ps(_mm256_add_ps(r_rot, mid), half);
                let cbin = _mm256_sub_ps(_mm256_add_ps(c_rot, mid), half);
                let keep = _mm256_and_ps(inside(rbin), inside(cbin));
                let kept = _mm256_movemask_ps(_mm256_and_ps(keep, _mm256_castsi256_ps(in_row)));
                let (first, count) = (kept.trailing_zeros(), kept.count_ones());
                if kept != 0 && kept >> first != (1 << count) - 1 {
                    // Not one run (never seen): sample by sample, in order.
                    for jj in j..=j_hi.min(j + 7) {
                        push_sample!(jj);
                    }
                } else if kept != 0 {
                    // SAFETY: the lanes read are j..=min(j + 7, j_hi), within [1 - px,
                    // w - 2 - px] (the row's clipped run), so every pixel read lies inside
                    // the image; masked-off lanes are not read. n + 8 <= cap + 8, the
                    // buffers' length.
                    let (p, c0) = (img.as_ptr(), (px + j) as usize);
                    let load = |at: usize| _mm256_maskload_ps(p.add(at), in_row);
                    let wt = _mm256_mul_ps(
                        _mm256_add_ps(_mm256_mul_ps(c_rot, c_rot), _mm256_mul_ps(r_rot, r_rot)),
                        scale,
                    );
                    let dxv = _mm256_sub_ps(load(row + c0 + 1), load(row + c0 - 1));
                    let dyv = _mm256_sub_ps(load(up + c0), load(dn + c0));
                    let turn = _mm256_add_epi32(ramp, _mm256_set1_epi32(first as i32));
                    let put = |buf: &mut Vec<f32>, v| {
                        _mm256_storeu_ps(buf.as_mut_ptr().add(n), _mm256_permutevar8x32_ps(v, turn))
                    };
                    put(&mut sc.dx, dxv);
                    put(&mut sc.dy, dyv);
                    put(&mut sc.rbin, rbin);
                    put(&mut sc.cbin, cbin);
                    put(&mut sc.wt, wt);
                    n += count as usize;
                }
                j += 8;
            }
        }

        while j <= j_hi {
            push_sample!(j);
            j += 1;
        }
    }

    // One long pass per primitive, as the reference does.
    let len = n;
    grow_to(&mut sc.mag, len);
    grow_to(&mut sc.ang, len);
    exp_batch(&mut sc.wt[..len]);
    mag_ang_batch(
        &sc.dx[..len],
        &sc.dy[..len],
        &mut sc.mag[..len],
        &mut sc.ang[..len],
    );
    scatter(sc, len, ori, bins_per_rad, &mut hist);

    // Fold the circular orientation bins back into the d*d*n array.
    let mut raw = [0.0f32; DESCR_LEN];
    for i in 0..D {
        for j in 0..D {
            let idx = ((i + 1) * (D + 2) + (j + 1)) * (N + 2);
            hist[idx] += hist[idx + N];
            // The reference also folds o-bin N+1 into bin 1, but no scatter can
            // write it: o0 wraps into 0..N-1, so writes reach offset N at most.
            // Folding that guaranteed +0.0 is a no-op (all accumulands are
            // non-negative, so there is no -0.0 for it to normalise).
            for k in 0..N {
                raw[(i * D + j) * N + k] = hist[idx + k];
            }
        }
    }

    // Normalise, clamp at MAG_THR, renormalise, scale and saturate to uchar.
    let thr = nrm2(&raw).sqrt() * DESCR_MAG_THR;
    let mut n2 = 0.0f32;
    for v in raw.iter_mut() {
        let val = v.min(thr);
        *v = val;
        n2 += val * val;
    }
    let scale = INT_DESCR_FCTR / n2.sqrt().max(f32::EPSILON);
    for (o, v) in out.iter_mut().zip(raw.iter()) {
        *o = ((v * scale).round_ties_even()).clamp(0.0, 255.0);
    }
}

/// Convert an oriented keypoint into the descriptor's inputs for its octave.
///
/// The reference rescales by `1 / (1 << octave)` and flips the angle: the stored
/// orientation is counter-clockwise, the descriptor's rotation is clockwise.
pub fn descriptor_inputs(kp: &OrientedKeypoint, octv: i32) -> (f32, f32, f32, f32) {
    let scale = 1.0 / (1 << octv) as f32;
    let mut angle = 360.0 - kp.angle;
    if (angle - 360.0).abs() < f32::EPSILON {
        angle = 0.0;
    }
    (kp.x * scale, kp.y * scale, (kp.size * scale) * 0.5, angle)
}
