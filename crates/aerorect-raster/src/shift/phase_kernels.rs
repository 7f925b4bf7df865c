//! The phase correlator's kernels: the weighted cross-power spectrum and the sums of Newton's
//! step (lane loops, compiled for AVX2 where the CPU has it), and the Hann window tables.

use rustfft::num_complex::Complex32;
use std::f64::consts::PI;

// The lane loops below may run compiled for AVX2: the same operations in the same order (no
// fused multiply-add), so the results do not depend on it. (A generic runner taking a closure
// does not work: the closure is not inlined into the AVX2 frame and runs plain.)

/// [`cross_power`] compiled for AVX2 where the CPU has it.
pub(super) fn cross_power_fast<const PHASE: bool>(
    s: &Spectra,
    out: (&mut [Complex32], &mut [f32], &mut [f32]),
) -> (f64, f64) {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::avx2() {
        #[target_feature(enable = "avx2")]
        unsafe fn run<const PHASE: bool>(
            s: &Spectra,
            out: (&mut [Complex32], &mut [f32], &mut [f32]),
        ) -> (f64, f64) {
            cross_power::<PHASE>(s, out)
        }
        // SAFETY: the CPU has AVX2.
        return unsafe { run::<PHASE>(s, out) };
    }
    cross_power::<PHASE>(s, out)
}

/// [`newton_sums`] compiled for AVX2 where the CPU has it.
pub(super) fn newton_sums_fast(
    q: (&[f32], &[f32]),
    rows: [&[f32]; 4],
    ex: &[(f64, f64)],
    w: usize,
    h: usize,
) -> [f64; 6] {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::avx2() {
        #[target_feature(enable = "avx2")]
        unsafe fn run(
            q: (&[f32], &[f32]),
            rows: [&[f32]; 4],
            ex: &[(f64, f64)],
            w: usize,
            h: usize,
        ) -> [f64; 6] {
            newton_sums(q, rows, ex, w, h)
        }
        // SAFETY: the CPU has AVX2.
        return unsafe { run(q, rows, ex, w, h) };
    }
    newton_sums(q, rows, ex, w, h)
}

/// The two spectra and the smoothing Gaussian's factors (per column u, per row v).
pub(super) struct Spectra<'a> {
    pub(super) r: &'a [Complex32],
    pub(super) t: &'a [Complex32],
    pub(super) gx: &'a [f32],
    pub(super) gy: &'a [f32],
    pub(super) w: usize,
}

/// Q = G conj(R) T, divided by |R| |T| with `PHASE`, into `out` = (interleaved, real parts,
/// imaginary parts); returns sum G |R|^2, sum G |T|^2 over the whole spectrum.
#[inline(always)]
fn cross_power<const PHASE: bool>(
    s: &Spectra,
    out: (&mut [Complex32], &mut [f32], &mut [f32]),
) -> (f64, f64) {
    let (q, q_re, q_im) = out;
    let (w, h) = (s.w, s.gy.len());
    let (mut er, mut et) = (0.0f64, 0.0f64);
    for (u, &gu) in s.gx.iter().enumerate() {
        let weight = if u == 0 || (w.is_multiple_of(2) && u == w / 2) {
            1.0
        } else {
            2.0
        };
        let col = u * h..(u + 1) * h;
        let (sr, st) = cross_column::<PHASE>(
            (&s.r[col.clone()], &s.t[col.clone()], s.gy, gu),
            (&mut q[col.clone()], &mut q_re[col.clone()], &mut q_im[col]),
        );
        er += weight * sr;
        et += weight * st;
    }
    (er, et)
}

/// One column of [`cross_power`], eight lanes at a time.
#[inline(always)]
fn cross_column<const PHASE: bool>(
    (r, t, gy, gu): (&[Complex32], &[Complex32], &[f32], f32),
    (q, q_re, q_im): (&mut [Complex32], &mut [f32], &mut [f32]),
) -> (f64, f64) {
    const L: usize = 8;
    let one = |a: Complex32, b: Complex32, g: f32| {
        let (ra, tb) = (a.norm_sqr(), b.norm_sqr());
        let scale = if !PHASE {
            g
        } else {
            // 1 / |R* T| as 1 / (|R| |T|): no overflow of the squared product.
            let m = ra.sqrt() * tb.sqrt();
            if m > 0.0 { g / m } else { 0.0 }
        };
        (a.conj() * b * scale, g * ra, g * tb)
    };
    let (mut sr, mut st) = ([0.0f32; L], [0.0f32; L]);
    let n = r.len() / L * L;
    let lanes = r[..n]
        .chunks_exact(L)
        .zip(t[..n].chunks_exact(L))
        .zip(gy[..n].chunks_exact(L))
        .zip(q[..n].chunks_exact_mut(L))
        .zip(q_re[..n].chunks_exact_mut(L))
        .zip(q_im[..n].chunks_exact_mut(L));
    for (((((rc, tc), gc), qc), rec), imc) in lanes {
        let (mut pr, mut pi) = ([0.0f32; L], [0.0f32; L]);
        for l in 0..L {
            let (p, a, b) = one(rc[l], tc[l], gu * gc[l]);
            (pr[l], pi[l]) = (p.re, p.im);
            sr[l] += a;
            st[l] += b;
        }
        rec.copy_from_slice(&pr);
        imc.copy_from_slice(&pi);
        for l in 0..L {
            qc[l] = Complex32::new(pr[l], pi[l]);
        }
    }
    let (mut er, mut et) = (
        sr.iter().map(|&v| v as f64).sum::<f64>(),
        st.iter().map(|&v| v as f64).sum::<f64>(),
    );
    for v in n..r.len() {
        let (p, a, b) = one(r[v], t[v], gu * gy[v]);
        (q[v], q_re[v], q_im[v]) = (p, p.re, p.im);
        er += a as f64;
        et += b as f64;
    }
    (er, et)
}

/// c, its gradient and Hessian (see `newton_terms`) from Q's parts, the per-row tables
/// [cos, sin, k, k^2] and the per-column phase factors `ex`.
#[inline(always)]
fn newton_sums(
    (q_re, q_im): (&[f32], &[f32]),
    rows: [&[f32]; 4],
    ex: &[(f64, f64)],
    w: usize,
    h: usize,
) -> [f64; 6] {
    let mut t = [0.0f64; 6]; // c, cx, cy, cxx, cyy, cxy
    for (u, &(c, s)) in ex.iter().enumerate() {
        let weight = if u == 0 || (w.is_multiple_of(2) && u == w / 2) {
            1.0
        } else {
            2.0
        };
        let col = u * h..(u + 1) * h;
        // S_n = sum_v Q e_y k_v^n; a0 = S0, a1 = i S1, a2 = -S2.
        let [s0r, s0i, s1r, s1i, s2r, s2i] = column_sums(&q_re[col.clone()], &q_im[col], rows);
        let (a0, a1, a2) = ((s0r, s0i), (-s1i, s1r), (-s2r, -s2i));
        let kx = 2.0 * PI * u as f64 / w as f64;
        let re = |a: (f64, f64)| a.0 * c - a.1 * s; // Re(e_x a)
        let im = |a: (f64, f64)| a.0 * s + a.1 * c; // Im(e_x a)
        t[0] += weight * re(a0);
        t[1] += weight * -kx * im(a0);
        t[2] += weight * re(a1);
        t[3] += weight * -kx * kx * re(a0);
        t[4] += weight * re(a2);
        t[5] += weight * -kx * im(a1);
    }
    t
}

/// Hann weights of n samples, the window moved by `shift` (zero outside [-0.5, n - 0.5)).
pub(super) fn hann_table(n: usize, shift: f64) -> Vec<f32> {
    let mut t = vec![0.0; n];
    fill_hann(&mut t, shift);
    t
}

pub(super) fn fill_hann(t: &mut [f32], shift: f64) {
    let n = t.len() as f64;
    for (i, v) in t.iter_mut().enumerate() {
        let p = i as f64 - shift + 0.5;
        *v = if (0.0..=n).contains(&p) {
            (0.5 - 0.5 * (2.0 * PI * p / n).cos()) as f32
        } else {
            0.0
        };
    }
}

/// [S0, S1, S2] (real and imaginary parts) of one column: S_n = sum_v Q_v e_v k_v^n with
/// e_v = (cos, sin) and [cos, sin, k, k^2] per row in `rows`.
#[inline(always)]
fn column_sums(q_re: &[f32], q_im: &[f32], rows: [&[f32]; 4]) -> [f64; 6] {
    const L: usize = 8;
    let [ec, es, k1, k2] = rows;
    let mut acc = [[0.0f32; L]; 6];
    let n = q_re.len() / L * L;
    let lanes = |s: &[f32], i: usize| -> [f32; L] {
        let mut a = [0.0; L];
        a.copy_from_slice(&s[i..i + L]);
        a
    };
    for i in (0..n).step_by(L) {
        let (qr, qi, c, s, a, b) = (
            lanes(q_re, i),
            lanes(q_im, i),
            lanes(ec, i),
            lanes(es, i),
            lanes(k1, i),
            lanes(k2, i),
        );
        for l in 0..L {
            let pr = qr[l] * c[l] - qi[l] * s[l];
            let pi = qr[l] * s[l] + qi[l] * c[l];
            acc[0][l] += pr;
            acc[1][l] += pi;
            acc[2][l] += a[l] * pr;
            acc[3][l] += a[l] * pi;
            acc[4][l] += b[l] * pr;
            acc[5][l] += b[l] * pi;
        }
    }
    let mut out = acc.map(|a| a.iter().map(|&v| v as f64).sum::<f64>());
    for v in n..q_re.len() {
        let pr = (q_re[v] * ec[v] - q_im[v] * es[v]) as f64;
        let pi = (q_re[v] * es[v] + q_im[v] * ec[v]) as f64;
        let (a, b) = (k1[v] as f64, k2[v] as f64);
        for (o, d) in out.iter_mut().zip([pr, pi, a * pr, a * pi, b * pr, b * pi]) {
            *o += d;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane loops compiled for AVX2 give the plain build's results to the bit (same
    /// operations in the same order), on spectra with a column length that leaves a tail.
    #[test]
    fn the_avx2_build_of_the_lane_loops_changes_nothing() {
        let (w, h) = (10, 21);
        let n = (w / 2 + 1) * h;
        let spec = |k: f32| -> Vec<Complex32> {
            (0..n)
                .map(|i| Complex32::new((i as f32 * k).sin() * 3.0, (i as f32 * 0.7 + k).cos()))
                .collect()
        };
        let (r, t) = (spec(0.37), spec(1.13));
        let gx: Vec<f32> = (0..=w / 2).map(|u| 1.0 / (1.0 + u as f32)).collect();
        let gy: Vec<f32> = (0..h)
            .map(|v| 0.5 + (v as f32 * 0.1).cos() * 0.25)
            .collect();
        let s = Spectra {
            r: &r,
            t: &t,
            gx: &gx,
            gy: &gy,
            w,
        };
        let mut a = (vec![Complex32::default(); n], vec![0.0; n], vec![0.0; n]);
        let mut b = a.clone();
        let ea = cross_power::<true>(&s, (&mut a.0, &mut a.1, &mut a.2));
        let eb = cross_power_fast::<true>(&s, (&mut b.0, &mut b.1, &mut b.2));
        assert_eq!((ea, &a), (eb, &b));
        let ea = cross_power::<false>(&s, (&mut a.0, &mut a.1, &mut a.2));
        let eb = cross_power_fast::<false>(&s, (&mut b.0, &mut b.1, &mut b.2));
        assert_eq!((ea, &a), (eb, &b));
        let rows: Vec<Vec<f32>> = (0..4)
            .map(|k| (0..h).map(|v| (v as f32 * 0.3 + k as f32).sin()).collect())
            .collect();
        let rows = [&rows[0][..], &rows[1], &rows[2], &rows[3]];
        let ex: Vec<(f64, f64)> = (0..=w / 2).map(|u| (u as f64).sin_cos()).collect();
        assert_eq!(
            newton_sums((&a.1, &a.2), rows, &ex, w, h),
            newton_sums_fast((&a.1, &a.2), rows, &ex, w, h)
        );
    }
}
