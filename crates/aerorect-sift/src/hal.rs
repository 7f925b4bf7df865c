//! The three scalar-math primitives the orientation and descriptor stages
//! depend on, reproduced bit for bit.
//!
//! On this platform the reference's `exp32f`, `fastAtan2` and `magnitude32f` are
//! overridden by an accelerated backend built on ARM's *estimate* instructions —
//! `FRECPE`/`FRECPS` and `FRSQRTE`/`FRSQRTS` — not on exact division or square
//! root. `atan2f`, `expf` and `sqrtf` do not reproduce them.
//!
//! The CUDA port had to emulate those instructions with baked lookup tables and
//! integer exponent assembly. Here they are simply *called*: this is aarch64, so
//! `vrecpeq_f32` and friends are the hardware, which also means the zero and
//! infinity special cases come free rather than needing to be hand-written (a
//! missing one of those was a real bug on the GPU side).

#[cfg(target_arch = "aarch64")]
use std::arch::aarch64::*;

/// Reciprocal: estimate plus exactly two Newton-Raphson steps.
///
/// Two, not three: measured against the reference, one step leaves 2540
/// mismatches per 4096, two leaves 0, and three leaves 262. More refinement is
/// *worse*, because the target is the backend's approximation, not `1/x`.
#[cfg(target_arch = "aarch64")]
#[inline]
pub fn recip(v: f32) -> f32 {
    // SAFETY: NEON is baseline on aarch64.
    unsafe {
        let x = vdupq_n_f32(v);
        let mut r = vrecpeq_f32(x);
        r = vmulq_f32(vrecpsq_f32(x, r), r);
        r = vmulq_f32(vrecpsq_f32(x, r), r);
        vgetq_lane_f32(r, 0)
    }
}

/// Reciprocal square root: estimate plus exactly two refinement steps.
#[cfg(target_arch = "aarch64")]
#[inline]
pub fn rsqrt(v: f32) -> f32 {
    // SAFETY: NEON is baseline on aarch64.
    unsafe {
        let x = vdupq_n_f32(v);
        let mut e = vrsqrteq_f32(x);
        e = vmulq_f32(vrsqrtsq_f32(vmulq_f32(e, e), x), e);
        e = vmulq_f32(vrsqrtsq_f32(vmulq_f32(e, e), x), e);
        vgetq_lane_f32(e, 0)
    }
}

/// Magnitude, as the backend computes it: `recip(rsqrt(x*x + y*y))`.
///
/// It never issues a square root. The sum must be a single fused
/// multiply-add — computing it with two roundings disagrees on ~7% of inputs.
#[cfg(target_arch = "aarch64")]
#[inline]
pub fn magnitude(x: f32, y: f32) -> f32 {
    recip(rsqrt(x.mul_add(x, y * y)))
}

/// Magnitude, portable fallback.
///
/// **Not** bit-exact against the reference: off aarch64 the estimate
/// instructions the backend composes are unavailable, so this issues a real
/// square root. The bit-exactness contract holds on aarch64 only, and the
/// oracle tests that assert it are skipped elsewhere.
#[cfg(not(target_arch = "aarch64"))]
#[inline]
pub fn magnitude(x: f32, y: f32) -> f32 {
    x.mul_add(x, y * y).sqrt()
}

/// Angle in degrees, clockwise from +x, in `[0, 360)`.
///
/// The polynomial must be a **fused Horner chain**. The backend's own source
/// spells it as separate multiplies and adds, but only the fused form reproduces
/// the reference's bits — they differ by one ULP, which was a long-standing
/// residual on the CUDA side. Constants are products evaluated in `f64` then
/// narrowed; computing them from `f32` literals changes `p1`'s last bit.
#[cfg_attr(not(target_arch = "aarch64"), allow(dead_code))]
#[inline]
pub fn atan2_deg(y: f32, x: f32) -> f32 {
    atan2_deg_with(y, x, &ATAN_C)
}

/// [`atan2_deg`] with its constants given (fork: a batch loop reads the lazily built
/// constants once, not once per sample, which is what lets it vectorise).
#[inline]
fn atan2_deg_with(y: f32, x: f32, consts: &AtanConsts) -> f32 {
    let AtanConsts {
        p1,
        p3,
        p5,
        p7,
        eps,
    } = *consts;

    let (ax, ay) = (x.abs(), y.abs());
    let (tmin, tmax) = (ax.min(ay), ax.max(ay));
    #[cfg(target_arch = "aarch64")]
    let c = tmin * recip(tmax + eps);
    #[cfg(not(target_arch = "aarch64"))]
    let c = tmin / (tmax + eps);
    let c2 = c * c;

    let mut a = c2.mul_add(p7, p5);
    a = a.mul_add(c2, p3);
    a = a.mul_add(c2, p1);
    a *= c;

    // Deliberately the negated form, not `ax < ay`: the reference spells it this
    // way and the two differ when either operand is NaN, which decides the
    // quadrant fixup. Not a readability wart.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(ax >= ay) {
        a = 90.0 - a;
    }
    if x < 0.0 {
        a = 180.0 - a;
    }
    if y < 0.0 {
        a = 360.0 - a;
    }
    a
}

/// `2^(i/64) * A0`, where `A0` is the constant the polynomial's coefficients are
/// divided by. The factor cancels algebraically, but the intermediate rounding
/// does not, so it has to be kept.
///
/// Built **once**. Rebuilding it per call means 64 `powf` evaluations for every
/// exponential, and this is called once per patch sample — tens of millions of
/// times an image. That is the same mistake, in a different guise, as the baked
/// tables that ended up in per-thread local memory on the CUDA side.
pub(crate) static EXP_TAB: std::sync::LazyLock<[f32; 64]> = std::sync::LazyLock::new(|| {
    const A0: f64 = 0.009_670_371_139_572_338;
    let mut t = [0.0f32; 64];
    for (i, slot) in t.iter_mut().enumerate() {
        *slot = (2f64.powf(i as f64 / 64.0) * A0) as f32;
    }
    t
});

/// The exponential's polynomial coefficients and range, also built once.
pub(crate) struct ExpConsts {
    pub(crate) a1: f32,
    pub(crate) a2: f32,
    pub(crate) a3: f32,
    pub(crate) a4: f32,
    pub(crate) prescale: f32,
    pub(crate) postscale: f32,
    pub(crate) minval: f32,
    pub(crate) maxval: f32,
}

pub(crate) static EXP_C: std::sync::LazyLock<ExpConsts> = std::sync::LazyLock::new(|| {
    const A0: f64 = 0.009_670_371_139_572_338;
    let pre = std::f64::consts::LOG2_E * 64.0;
    let exp_max = 3000.0f64 * 64.0;
    ExpConsts {
        a1: (0.055_503_393_667_531_25 / A0) as f32,
        a2: (0.240_226_510_951_330_15 / A0) as f32,
        a3: (0.693_147_180_552_144_8 / A0) as f32,
        a4: (1.0f64 / A0) as f32,
        prescale: pre as f32,
        postscale: (1.0f64 / 64.0) as f32,
        minval: (-exp_max / pre) as f32,
        maxval: (exp_max / pre) as f32,
    }
});

/// The angle polynomial's constants: products evaluated in `f64` then narrowed.
pub(crate) struct AtanConsts {
    pub(crate) p1: f32,
    pub(crate) p3: f32,
    pub(crate) p5: f32,
    pub(crate) p7: f32,
    pub(crate) eps: f32,
}

pub(crate) static ATAN_C: std::sync::LazyLock<AtanConsts> = std::sync::LazyLock::new(|| {
    const D: f64 = 180.0 / std::f64::consts::PI;
    AtanConsts {
        p1: (0.999_787_841_279_480_7 * D) as f32,
        p3: (-0.325_808_397_464_097_5 * D) as f32,
        p5: (0.155_578_651_846_328_1 * D) as f32,
        p7: (-0.044_326_555_547_921_28 * D) as f32,
        eps: f64::EPSILON as f32,
    }
});

/// The reference's exponential: 64-entry table, exponent injection, and a
/// four-term FMA polynomial. Not `expf`.
#[cfg_attr(not(target_arch = "aarch64"), allow(dead_code))]
#[inline]
pub fn exp(x: f32) -> f32 {
    exp_with(x, &EXP_C, &EXP_TAB)
}

/// [`exp`] with its constants and table given (fork: see [`atan2_deg_with`]).
#[inline]
fn exp_with(x: f32, c: &ExpConsts, tab: &[f32; 64]) -> f32 {
    let (a1, a2, a3, a4) = (c.a1, c.a2, c.a3, c.a4);
    let mut x = x.clamp(c.minval, c.maxval);
    x *= c.prescale;
    let xi = x.round_ties_even() as i32;
    let xf = (x - xi as f32) * c.postscale;
    let mut yf = tab[(xi & 63) as usize];
    let t = ((xi >> 6) + 127).clamp(0, 255) as u32;
    yf *= f32::from_bits(t << 23);

    let mut z = xf + a1;
    z = z.mul_add(xf, a2);
    z = z.mul_add(xf, a3);
    z = z.mul_add(xf, a4);
    z * yf
}

/// `exp` in place over a whole buffer, four lanes at a time with a scalar tail.
///
/// The reference runs each of its primitives as one long pass over the sample
/// set rather than a few samples at a time between consumers, and that is worth
/// a lot here: interleaved, the transcendental emulations and the caller's
/// scatter compete for the same registers. The lane-wise and scalar forms are
/// bit-identical, so where the tail begins does not affect the result.
#[inline]
pub(super) fn exp_batch(v: &mut [f32]) {
    #[cfg_attr(not(target_arch = "aarch64"), allow(unused_mut))]
    let mut k = x86::exp_lanes(v);
    #[cfg(target_arch = "aarch64")]
    {
        use std::arch::aarch64::*;
        // SAFETY: `k + 4 <= v.len()` on every iteration.
        unsafe {
            while k + 4 <= v.len() {
                let p = v.as_mut_ptr().add(k);
                vst1q_f32(p, x4::exp(vld1q_f32(p)));
                k += 4;
            }
        }
    }
    let (c, tab) = (&*EXP_C, &*EXP_TAB);
    for x in &mut v[k..] {
        *x = exp_with(*x, c, tab);
    }
}

/// `magnitude` and `atan2` over a whole buffer, four lanes at a time.
///
/// `mag` and `ang` are fully overwritten, so callers pass scratch that is sized
/// but not zeroed.
#[inline]
pub(super) fn mag_ang_batch(dx: &[f32], dy: &[f32], mag: &mut [f32], ang: &mut [f32]) {
    let len = dx.len();
    debug_assert_eq!(dy.len(), len);
    debug_assert_eq!(mag.len(), len);
    debug_assert_eq!(ang.len(), len);
    #[cfg_attr(not(target_arch = "aarch64"), allow(unused_mut))]
    let mut k = x86::mag_ang_lanes(dx, dy, mag, ang);
    #[cfg(target_arch = "aarch64")]
    {
        use std::arch::aarch64::*;
        // SAFETY: `k + 4 <= len` and all four buffers are `len` long.
        unsafe {
            while k + 4 <= len {
                let vdx = vld1q_f32(dx.as_ptr().add(k));
                let vdy = vld1q_f32(dy.as_ptr().add(k));
                vst1q_f32(mag.as_mut_ptr().add(k), x4::magnitude(vdx, vdy));
                vst1q_f32(ang.as_mut_ptr().add(k), x4::atan2_deg(vdy, vdx));
                k += 4;
            }
        }
    }
    let consts = &*ATAN_C;
    while k < len {
        mag[k] = magnitude(dx[k], dy[k]);
        ang[k] = atan2_deg_with(dy[k], dx[k], consts);
        k += 1;
    }
}

/// Grow `v` to at least `len` without re-zeroing what is already there.
///
/// The buffers these back are fully overwritten before they are read, so the
/// fill value never survives; `Vec::clear` + `resize` would zero every element
/// once per keypoint for nothing.
#[inline]
pub(super) fn grow_to(v: &mut Vec<f32>, len: usize) {
    if v.len() < len {
        v.resize(len, 0.0);
    }
}

/// Four-lane forms of the three primitives.
///
/// Lane-wise identical to the scalar versions — the same instructions, four at a
/// time — so a caller can vectorise the *evaluation* of a patch while still
/// scattering the results sequentially, and stay bit-exact. That split is what
/// makes the descriptor and orientation loops vectorisable at all: their
/// accumulation order is fixed, but the work feeding it is not.
///
/// Keep this `cfg` attached to `x4` and nothing else: the batch helpers above
/// are portable (each has its own inner `cfg` around the NEON body) and are
/// imported unconditionally, so an item inserted between this attribute and the
/// module steals the gate and breaks every non-aarch64 build.
#[cfg(target_arch = "aarch64")]
pub mod x4 {
    use super::{ATAN_C, EXP_C, EXP_TAB};
    use std::arch::aarch64::*;

    #[inline]
    unsafe fn recip(x: float32x4_t) -> float32x4_t {
        let mut r = vrecpeq_f32(x);
        r = vmulq_f32(vrecpsq_f32(x, r), r);
        r = vmulq_f32(vrecpsq_f32(x, r), r);
        r
    }

    #[inline]
    unsafe fn rsqrt(x: float32x4_t) -> float32x4_t {
        let mut e = vrsqrteq_f32(x);
        e = vmulq_f32(vrsqrtsq_f32(vmulq_f32(e, e), x), e);
        e = vmulq_f32(vrsqrtsq_f32(vmulq_f32(e, e), x), e);
        e
    }

    /// `recip(rsqrt(x*x + y*y))`, with the sum as one fused multiply-add.
    ///
    /// # Safety
    /// Requires NEON, which is baseline on aarch64.
    #[inline]
    pub unsafe fn magnitude(x: float32x4_t, y: float32x4_t) -> float32x4_t {
        recip(rsqrt(vfmaq_f32(vmulq_f32(y, y), x, x)))
    }

    /// Angle in degrees, clockwise from +x, in `[0, 360)`.
    ///
    /// # Safety
    /// Requires NEON, which is baseline on aarch64.
    #[inline]
    pub unsafe fn atan2_deg(y: float32x4_t, x: float32x4_t) -> float32x4_t {
        let c = &*ATAN_C;
        let ax = vabsq_f32(x);
        let ay = vabsq_f32(y);
        let tmin = vminq_f32(ax, ay);
        let tmax = vmaxq_f32(ax, ay);
        let cc = vmulq_f32(tmin, recip(vaddq_f32(tmax, vdupq_n_f32(c.eps))));
        let c2 = vmulq_f32(cc, cc);

        let mut a = vfmaq_n_f32(vdupq_n_f32(c.p5), c2, c.p7);
        a = vfmaq_f32(vdupq_n_f32(c.p3), a, c2);
        a = vfmaq_f32(vdupq_n_f32(c.p1), a, c2);
        a = vmulq_f32(a, cc);

        // `!(ax >= ay)` — the negated form, matching the reference, which
        // differs from `ax < ay` when an operand is NaN.
        let swap = vmvnq_u32(vcgeq_f32(ax, ay));
        a = vbslq_f32(swap, vsubq_f32(vdupq_n_f32(90.0), a), a);
        let negx = vcltq_f32(x, vdupq_n_f32(0.0));
        a = vbslq_f32(negx, vsubq_f32(vdupq_n_f32(180.0), a), a);
        let negy = vcltq_f32(y, vdupq_n_f32(0.0));
        vbslq_f32(negy, vsubq_f32(vdupq_n_f32(360.0), a), a)
    }

    /// Table-and-polynomial exponential.
    ///
    /// The table index is data-dependent, so those four lookups stay scalar;
    /// everything around them is vector.
    ///
    /// # Safety
    /// Requires NEON, which is baseline on aarch64.
    #[inline]
    pub unsafe fn exp(x: float32x4_t) -> float32x4_t {
        let c = &*EXP_C;
        let tab = &*EXP_TAB;
        let x = vminq_f32(vmaxq_f32(x, vdupq_n_f32(c.minval)), vdupq_n_f32(c.maxval));
        let x = vmulq_f32(x, vdupq_n_f32(c.prescale));
        let xi = vcvtnq_s32_f32(x); // round to nearest, ties to even
        let xf = vmulq_n_f32(vsubq_f32(x, vcvtq_f32_s32(xi)), c.postscale);

        let mut idx = [0i32; 4];
        vst1q_s32(idx.as_mut_ptr(), xi);
        let mut yf = [0.0f32; 4];
        for (l, &i) in idx.iter().enumerate() {
            let t = ((i >> 6) + 127).clamp(0, 255) as u32;
            yf[l] = tab[(i & 63) as usize] * f32::from_bits(t << 23);
        }
        let yf = vld1q_f32(yf.as_ptr());

        let mut z = vaddq_f32(xf, vdupq_n_f32(c.a1));
        z = vfmaq_f32(vdupq_n_f32(c.a2), z, xf);
        z = vfmaq_f32(vdupq_n_f32(c.a3), z, xf);
        z = vfmaq_f32(vdupq_n_f32(c.a4), z, xf);
        vmulq_f32(z, yf)
    }
}

/// The batch primitives 8 lanes wide on x86-64 (AVX2 and FMA): each lane does the scalar's
/// operations in its order (`exp_with`, `magnitude`, `atan2_deg_with`: a fused multiply-add
/// exactly where the scalar calls `mul_add`, IEEE division and square root, rounding to
/// nearest even), so the results are the scalar's bits. Each returns how many leading values
/// it did (a multiple of 8); the scalar loop finishes the rest.
#[cfg(all(
    target_arch = "x86_64",
    target_feature = "avx2",
    target_feature = "fma"
))]
mod x86 {
    use super::{ATAN_C, EXP_C, EXP_TAB};
    use std::arch::x86_64::*;

    pub(super) fn exp_lanes(v: &mut [f32]) -> usize {
        let (c, tab) = (&*EXP_C, &*EXP_TAB);
        let mut k = 0;
        // SAFETY: AVX2 and FMA are enabled at compile time (the module's cfg); loads and
        // stores touch k..k + 8 < v.len(), and the gather reads tab[xi & 63], inside 64.
        unsafe {
            let set = _mm256_set1_ps;
            let (lo, hi) = (set(c.minval), set(c.maxval));
            let (pre, post) = (set(c.prescale), set(c.postscale));
            let (a1, a2, a3, a4) = (set(c.a1), set(c.a2), set(c.a3), set(c.a4));
            let (mask, bias) = (_mm256_set1_epi32(63), _mm256_set1_epi32(127));
            let (zero, top) = (_mm256_setzero_si256(), _mm256_set1_epi32(255));
            while k + 8 <= v.len() {
                let p = v.as_mut_ptr().add(k);
                let x = _mm256_mul_ps(
                    _mm256_min_ps(_mm256_max_ps(_mm256_loadu_ps(p), lo), hi),
                    pre,
                );
                // Round to nearest, ties to even (the default rounding mode).
                let xi = _mm256_cvtps_epi32(x);
                let xf = _mm256_mul_ps(_mm256_sub_ps(x, _mm256_cvtepi32_ps(xi)), post);
                let t = _mm256_add_epi32(_mm256_srai_epi32::<6>(xi), bias);
                let t = _mm256_min_epi32(_mm256_max_epi32(t, zero), top);
                let yf = _mm256_mul_ps(
                    _mm256_i32gather_ps::<4>(tab.as_ptr(), _mm256_and_si256(xi, mask)),
                    _mm256_castsi256_ps(_mm256_slli_epi32::<23>(t)),
                );
                let mut z = _mm256_add_ps(xf, a1);
                z = _mm256_fmadd_ps(z, xf, a2);
                z = _mm256_fmadd_ps(z, xf, a3);
                z = _mm256_fmadd_ps(z, xf, a4);
                _mm256_storeu_ps(p, _mm256_mul_ps(z, yf));
                k += 8;
            }
        }
        k
    }

    pub(super) fn mag_ang_lanes(dx: &[f32], dy: &[f32], mag: &mut [f32], ang: &mut [f32]) -> usize {
        let c = &*ATAN_C;
        let len = dx.len().min(dy.len()).min(mag.len()).min(ang.len());
        let mut k = 0;
        // SAFETY: as in `exp_batch`; every slice is at least `len` long.
        unsafe {
            let set = _mm256_set1_ps;
            let (p1, p3, p5, p7, eps) = (set(c.p1), set(c.p3), set(c.p5), set(c.p7), set(c.eps));
            let abs = _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX));
            let zero = _mm256_setzero_ps();
            while k + 8 <= len {
                let x = _mm256_loadu_ps(dx.as_ptr().add(k));
                let y = _mm256_loadu_ps(dy.as_ptr().add(k));
                let m = _mm256_sqrt_ps(_mm256_fmadd_ps(x, x, _mm256_mul_ps(y, y)));
                _mm256_storeu_ps(mag.as_mut_ptr().add(k), m);
                let (ax, ay) = (_mm256_and_ps(x, abs), _mm256_and_ps(y, abs));
                let (tmin, tmax) = (_mm256_min_ps(ax, ay), _mm256_max_ps(ax, ay));
                let cc = _mm256_div_ps(tmin, _mm256_add_ps(tmax, eps));
                let c2 = _mm256_mul_ps(cc, cc);
                let mut a = _mm256_fmadd_ps(c2, p7, p5);
                a = _mm256_fmadd_ps(a, c2, p3);
                a = _mm256_fmadd_ps(a, c2, p1);
                a = _mm256_mul_ps(a, cc);
                // `!(ax >= ay)`: not-greater-or-equal, true where unordered as well.
                let swap = _mm256_cmp_ps::<_CMP_NGE_UQ>(ax, ay);
                a = _mm256_blendv_ps(a, _mm256_sub_ps(set(90.0), a), swap);
                let neg_x = _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero);
                a = _mm256_blendv_ps(a, _mm256_sub_ps(set(180.0), a), neg_x);
                let neg_y = _mm256_cmp_ps::<_CMP_LT_OQ>(y, zero);
                a = _mm256_blendv_ps(a, _mm256_sub_ps(set(360.0), a), neg_y);
                _mm256_storeu_ps(ang.as_mut_ptr().add(k), a);
                k += 8;
            }
        }
        k
    }
}

/// Elsewhere the scalar (or NEON) loops do every value.
#[cfg(not(all(
    target_arch = "x86_64",
    target_feature = "avx2",
    target_feature = "fma"
)))]
mod x86 {
    pub(super) fn exp_lanes(_: &mut [f32]) -> usize {
        0
    }

    pub(super) fn mag_ang_lanes(_: &[f32], _: &[f32], _: &mut [f32], _: &mut [f32]) -> usize {
        0
    }
}
