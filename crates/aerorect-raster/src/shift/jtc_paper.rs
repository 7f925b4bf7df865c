//! The JTC on the paper's joint image (see `jtc`): the only form for a binarised spectrum, and
//! the reference for the cross-spectrum form.
//!
//! The two frame orders run side by side (on two threads when rayon's pool has them), each
//! stage on a few spectrum columns at a time so that no full complex spectrum is written or
//! transposed:
//!
//! 1. the real FFT of each joint row (h rows; the other h are zero);
//! 2. per batch of columns u: the rows' values gathered into columns, the column FFTs, and only
//!    the power |J(u, v)|^2 kept (u-major), with every 8th value of its filtered form sampled as
//!    soon as its neighbour columns exist;
//! 3. the threshold, the median of that sample;
//! 4. per batch of columns: the filtered, binarised spectrum, whose columns are real, two
//!    columns packed as one complex column B(u) + i B(u + 1), one inverse column FFT, and each
//!    unpacked from its Hermitian part; only rows 0..=h/2 are kept;
//! 5. the inverse real FFT of those rows. The spectrum is real and even
//!    (B(-u, -v) = B(u, v)), so the correlation plane is too: p(x, -y) = p(-x, y) gives the rows
//!    above the axis, and the mirror cross peak at (-(2w + dx), -dy) is exactly the first one
//!    reflected, so only the first is searched.
//!
//! The orders go through the same operations on their own data, so a frame against itself gives
//! both orders the same plane bit for bit, and the antisymmetrised shift exactly 0.

use super::fft2::Plans;
use super::jtc_common::{JtcOptions, Plane, SubPixel, prepare};
use super::jtc_paper_joint::Joint;
use super::jtc_paper_threshold::median;
use super::{ShiftError, ShiftEstimate, check_frame};
use rustfft::num_complex::Complex32;

/// Spectrum columns per batch of column FFTs (8 columns of 2h values stay in L1/L2).
const BATCH: usize = 8;
/// Padding between a batch's gathered columns: with a power-of-two 2h, columns exactly 2h apart
/// put the eight stores of one row's gather 4 KiB apart, where they alias in the cache.
const COL_PAD: usize = 8;

pub(crate) struct PaperJtc {
    joint: Joint,
    opts: JtcOptions,
    r: Vec<f32>,
    t: Vec<f32>,
    /// Reference first (`[0]`: the shift of the current frame), current first (`[1]`).
    orders: [Order; 2],
}

/// One frame order's work, all five stages.
struct Order {
    plans: Plans,
    row_in: Vec<f32>,
    cols: Vec<Complex32>,
    /// The joint image's row spectra (h rows of 3w + 1); after stage 4, rows 0..=h/2 of the
    /// plane's spectrum.
    rows: Vec<Complex32>,
    /// |J(u, v)|^2, u-major: `power[u * 2h + v]`.
    power: Vec<f32>,
    /// The threshold's sample; in stage 4, two filtered columns.
    sample: Vec<f32>,
    /// The sample as `ordered_key`s, for the median.
    keys: Vec<u32>,
    /// The plane around the first cross term: rows dy in -h/2..h/2 (index dy + h/2), joint
    /// columns w..3w + 2 (index x - w).
    window: Vec<f32>,
}

impl PaperJtc {
    pub(crate) fn new(width: usize, height: usize, opts: JtcOptions) -> Self {
        let joint = Joint {
            w: width,
            h: height,
            filter: opts.spectral_filter,
        };
        Self {
            joint,
            opts,
            r: vec![0.0; width * height],
            t: vec![0.0; width * height],
            orders: [Order::new(joint), Order::new(joint)],
        }
    }

    pub(crate) fn estimate(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        // Called from outside rayon's pool, every `rayon::join` is handed to the pool and waited
        // for on its own; one hand-over for the whole pair makes the joins inside local to it.
        rayon::join(|| self.estimate_in_pool(reference, current), || ()).0
    }

    fn estimate_in_pool(
        &mut self,
        reference: &[f32],
        current: &[f32],
    ) -> Result<ShiftEstimate, ShiftError> {
        let (j, opts) = (self.joint, self.opts);
        let (mr, mt) = rayon::join(
            || check_frame("reference", reference, j.w, j.h),
            || check_frame("current", current, j.w, j.h),
        );
        let (mr, mt) = (mr?, mt?);
        let (r, t) = (&mut self.r, &mut self.t);
        rayon::join(
            || prepare(reference, mr, j.w, j.h, opts.laplacian, r),
            || prepare(current, mt, j.w, j.h, opts.laplacian, t),
        );
        let (r, t) = (&self.r, &self.t);
        let [f, b] = &mut self.orders;
        let (forward, backward) =
            rayon::join(|| f.forward(j, opts, r, t), || b.forward(j, opts, t, r));
        rayon::join(|| f.inverse(j, forward), || b.inverse(j, backward));
        let (forward, backward) =
            rayon::join(|| f.peak(j, opts.subpixel), || b.peak(j, opts.subpixel));
        Ok(ShiftEstimate {
            dx: 0.5 * (forward.dx - backward.dx),
            dy: 0.5 * (forward.dy - backward.dy),
            confidence: forward.confidence.min(backward.confidence),
        })
    }
}

impl Order {
    fn new(j: Joint) -> Self {
        let (hh, hw) = (j.hh(), j.hw());
        Self {
            plans: Plans::new(6 * j.w, hh),
            row_in: vec![0.0; 6 * j.w],
            cols: vec![Complex32::default(); BATCH * (hh + COL_PAD)],
            rows: vec![Complex32::default(); j.h * hw],
            power: vec![0.0; hw * hh],
            sample: Vec::with_capacity(hw * hh / 8 + hw),
            keys: Vec::with_capacity(hw * hh / 8 + hw),
            window: vec![0.0; j.h * (2 * j.w + 2)],
        }
    }

    /// Stages 1 to 3 for the joint image with `a` at column 0 and `b` at column 2w: its power
    /// spectrum, and the binarisation threshold when binarising.
    fn forward(&mut self, j: Joint, opts: JtcOptions, a: &[f32], b: &[f32]) -> Option<f32> {
        self.joint_rows(j, a, b);
        self.power_spectrum(j, opts.binarize);
        opts.binarize.then(|| median(&self.sample, &mut self.keys))
    }

    /// Stages 4 and 5: the correlation plane around the first cross term.
    fn inverse(&mut self, j: Joint, threshold: Option<f32>) {
        self.inverse_columns(j, threshold);
        self.plane(j);
    }

    /// Stage 1: the real FFT of rows 0..h of the joint image.
    fn joint_rows(&mut self, j: Joint, a: &[f32], b: &[f32]) {
        let w = j.w;
        let p = &mut self.plans;
        for (y, out) in self.rows.chunks_exact_mut(j.hw()).enumerate() {
            self.row_in.fill(0.0);
            self.row_in[..w].copy_from_slice(&a[y * w..(y + 1) * w]);
            self.row_in[2 * w..3 * w].copy_from_slice(&b[y * w..(y + 1) * w]);
            // Lengths are from the plan, so realfft cannot fail here.
            let _ = p
                .r2c
                .process_with_scratch(&mut self.row_in, out, &mut p.scratch_r);
        }
    }

    /// Stage 2: the column FFTs, batch by batch, keeping |J|^2 and, when `sample`, the
    /// threshold's sample of each column whose neighbours are done.
    fn power_spectrum(&mut self, j: Joint, sample: bool) {
        let (h, hh, hw) = (j.h, j.hh(), j.hw());
        let p = &mut self.plans;
        self.sample.clear();
        let mut sampled = 0;
        for u0 in (0..hw).step_by(BATCH) {
            let n = BATCH.min(hw - u0);
            let cols = &mut self.cols[..n * (hh + COL_PAD)];
            gather_columns(&self.rows, hw, u0, n, cols, hh + COL_PAD);
            let power = &mut self.power[u0 * hh..(u0 + n) * hh];
            for (col, q) in cols
                .chunks_exact_mut(hh + COL_PAD)
                .zip(power.chunks_exact_mut(hh))
            {
                let col = &mut col[..hh];
                col[h..].fill(Complex32::default());
                p.col_fwd.process_with_scratch(col, &mut p.scratch_c);
                for (q, c) in q.iter_mut().zip(col.iter()) {
                    *q = c.norm_sqr();
                }
            }
            if sample {
                // Column u's filtered values need column u + 1, except the last column's.
                let ready = if u0 + n == hw || !j.filter {
                    u0 + n
                } else {
                    u0 + n - 1
                };
                for u in sampled..ready {
                    j.sample_column(&self.power, u, &mut self.sample);
                }
                sampled = ready;
            }
        }
    }

    /// Stage 4: the inverse column FFTs of the processed spectrum (filtered, then binarised at
    /// `threshold`), two real columns at once as B(u) + i B(u + 1); rows 0..=h/2 of each
    /// unpacked into `rows`.
    fn inverse_columns(&mut self, j: Joint, threshold: Option<f32>) {
        let (hh, hw, half) = (j.hh(), j.hw(), j.h / 2);
        let binary = |e: f32, m: f32| if e > m { 1.0 } else { -1.0 };
        self.sample.resize(2 * hh, 0.0);
        let (e0, e1) = self.sample.split_at_mut(hh);
        let p = &mut self.plans;
        for u0 in (0..hw).step_by(2 * BATCH) {
            let pairs = BATCH.min((hw - u0).div_ceil(2));
            let batch = &mut self.cols[..pairs * hh];
            for (k, col) in batch.chunks_exact_mut(hh).enumerate() {
                let u = u0 + 2 * k;
                j.filtered_column(&self.power, u, e0);
                if u + 1 < hw {
                    j.filtered_column(&self.power, u + 1, e1);
                } else {
                    e1.fill(0.0);
                }
                let both = col.iter_mut().zip(e0.iter().zip(e1.iter()));
                match threshold {
                    Some(m) if u + 1 < hw => both.for_each(|(c, (&a, &b))| {
                        *c = Complex32::new(binary(a, m), binary(b, m));
                    }),
                    Some(m) => both.for_each(|(c, (&a, _))| *c = Complex32::new(binary(a, m), 0.0)),
                    None => both.for_each(|(c, (&a, &b))| *c = Complex32::new(a, b)),
                }
            }
            p.col_inv.process_with_scratch(batch, &mut p.scratch_c);
            let n = (hw - u0).min(2 * BATCH);
            for y in 0..=half {
                let neg = if y == 0 { 0 } else { hh - y };
                let out = &mut self.rows[y * hw + u0..y * hw + u0 + n];
                for (col, out) in batch.chunks_exact(hh).zip(out.chunks_mut(2)) {
                    // Z = A + i B with A, B Hermitian in y: A = (Z(y) + conj Z(-y)) / 2,
                    // B = (Z(y) - conj Z(-y)) / 2i.
                    let (z, m) = (col[y], col[neg].conj());
                    let (s, d) = (z + m, z - m);
                    out[0] = Complex32::new(0.5 * s.re, 0.5 * s.im);
                    if let Some(o) = out.get_mut(1) {
                        *o = Complex32::new(0.5 * d.im, -0.5 * d.re);
                    }
                }
            }
        }
    }

    /// Stage 5: the plane's rows dy in -h/2..h/2 around the first cross term.
    fn plane(&mut self, j: Joint) {
        let (w, half, hw) = (j.w, j.h / 2, j.hw());
        let stride = 2 * w + 2;
        let p = &mut self.plans;
        for y in 0..=half {
            let row = &mut self.rows[y * hw..(y + 1) * hw];
            // The DC and Nyquist bins of a real row are real; drop round-off imaginary parts.
            row[0].im = 0.0;
            row[hw - 1].im = 0.0;
            let _ = p
                .c2r
                .process_with_scratch(row, &mut self.row_in, &mut p.scratch_r);
            let data = &self.row_in;
            if y < half {
                // Row dy = y, joint columns w..3w + 2.
                let out = &mut self.window[(half + y) * stride..(half + y + 1) * stride];
                out.copy_from_slice(&data[w..3 * w + 2]);
            }
            if y > 0 {
                // Row dy = -y: p(x, -y) = p(6w - x, y), joint column x = w + c.
                let out = &mut self.window[(half - y) * stride..(half - y + 1) * stride];
                for (o, &d) in out.iter_mut().zip(data[3 * w - 1..=5 * w].iter().rev()) {
                    *o = d;
                }
            }
        }
    }

    /// The cross term's peak, at joint column 2w + dx (window column w + dx) and row dy
    /// (window row dy + h/2).
    fn peak(&self, j: Joint, sub: SubPixel) -> ShiftEstimate {
        let plane = Plane {
            data: &self.window,
            stride: 2 * j.w + 2,
            rows: j.h,
        };
        let (x, y, peak) = plane.peak(0, 2 * j.w, sub);
        ShiftEstimate {
            dx: x - j.w as f64,
            dy: y - (j.h / 2) as f64,
            confidence: plane.confidence(x, y, peak, 2 * j.w),
        }
    }
}
/// `cols[k * stride + y] = rows[y * hw + u0 + k]` for k in 0..n (n <= 8) and every row y. A
/// whole batch goes by 8 x 8 tiles of fixed size, so that each column receives runs of eight
/// values.
fn gather_columns(
    rows: &[Complex32],
    hw: usize,
    u0: usize,
    n: usize,
    cols: &mut [Complex32],
    stride: usize,
) {
    let h = rows.len() / hw;
    // Whole tiles for a whole batch; the rows below them, or a partial batch, one by one.
    let tiles = if n == BATCH { h / BATCH * BATCH } else { 0 };
    let mut tile = [[Complex32::default(); BATCH]; BATCH];
    for y0 in (0..tiles).step_by(BATCH) {
        for (t, row) in tile.iter_mut().zip(rows[y0 * hw..].chunks(hw)) {
            if let Some(src) = row.get(u0..u0 + BATCH) {
                t.copy_from_slice(src);
            }
        }
        for (k, col) in cols.chunks_mut(stride).enumerate().take(BATCH) {
            if let Some(out) = col.get_mut(y0..y0 + BATCH) {
                for (o, t) in out.iter_mut().zip(&tile) {
                    *o = t[k];
                }
            }
        }
    }
    for (y, row) in rows.chunks_exact(hw).enumerate().skip(tiles) {
        for (k, &c) in row[u0..u0 + n].iter().enumerate() {
            cols[k * stride + y] = c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::jtc_common::SubPixel;
    use super::super::jtc_oracle::{joint_image_f64, pairs};
    use super::*;

    /// The smallest frames and odd sizes (odd half-spectrum widths, a last unpaired column, an
    /// odd number of plane rows): a frame against itself has moved by exactly 0 and a pair's
    /// shift is finite, with and without the filter and the binarisation.
    #[test]
    fn small_and_odd_frames_keep_their_symmetry() {
        for (w, h) in [(8, 8), (9, 11), (13, 8), (8, 9), (11, 17)] {
            let (r, t) = pairs(w, h).swap_remove(0);
            for (spectral_filter, binarize) in [(true, true), (false, true), (true, false)] {
                let opts = JtcOptions {
                    spectral_filter,
                    binarize,
                    ..JtcOptions::default()
                };
                let mut jtc = PaperJtc::new(w, h, opts);
                let same = jtc.estimate(&r, &r).unwrap();
                assert_eq!((same.dx, same.dy), (0.0, 0.0), "{w}x{h} {opts:?}");
                let e = jtc.estimate(&r, &t).unwrap();
                assert!(
                    e.dx.is_finite() && e.dy.is_finite(),
                    "{w}x{h} {opts:?}: {e:?}"
                );
            }
        }
    }

    /// The binarised joint image in f32 against its f64 definition (`joint_image_f64`), on noisy
    /// textured pairs, every option with binarisation. Binarisation is discontinuous: spectrum
    /// values within f32 rounding of the threshold take either sign, and on weak peaks
    /// (confidence 0.01-0.1) those flips move the fit by up to 3.0e-3 px (measured, both for the
    /// joint image transformed whole, order by order, and for the batched form here; mean
    /// 2.2e-4 px), 1/30 of the paper's 0.1 px.
    #[test]
    fn the_binarised_joint_image_matches_its_f64_definition() {
        let (mut worst, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
        for (w, h) in [(64, 64), (96, 80), (40, 33), (128, 128)] {
            for subpixel in [SubPixel::Gaussian, SubPixel::Centroid, SubPixel::Parabola] {
                for (laplacian, spectral_filter) in
                    [(true, true), (true, false), (false, true), (false, false)]
                {
                    let opts = JtcOptions {
                        laplacian,
                        spectral_filter,
                        binarize: true,
                        subpixel,
                    };
                    let mut jtc = PaperJtc::new(w, h, opts);
                    for (r, t) in pairs(w, h) {
                        let (ox, oy) = joint_image_f64(&r, &t, w, h, opts);
                        let e = jtc.estimate(&r, &t).unwrap();
                        let d = (ox - e.dx).abs().max((oy - e.dy).abs());
                        if d > 1e-3 {
                            eprintln!("{w}x{h} {opts:?}: ({ox}, {oy}) vs {e:?}");
                        }
                        worst = worst.max(d);
                        (sum, n) = (sum + d, n + 1);
                    }
                }
            }
        }
        let mean = sum / n as f64;
        eprintln!("difference from the f64 joint image: worst {worst:e} px, mean {mean:e} px");
        assert!(worst < 5e-3 && mean < 5e-4, "worst {worst}, mean {mean}");
    }
}
