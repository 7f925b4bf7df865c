//! The JTC on the paper's joint image (see `jtc`): the only form for a binarised spectrum, and
//! the reference for the cross-spectrum form.
//!
//! The joint image is a frame a at column 0 and a frame b at column 2w of a 6w x 2h grid, so
//! its spectrum is A + c B, c(u) = exp(-2 pi i u 2w / 6w) = exp(-2 pi i u / 3), with A and B
//! the frames' spectra on that grid; the other order's is B + c A. Each frame is transformed
//! once; in a track (a pair whose reference is the last pair's current frame) the current
//! frame's spectrum is kept, and the next pair's reference not transformed again. Each stage
//! runs on a few spectrum columns at a time so that no spectrum is transposed, and each is
//! split over two threads when rayon's pool has them:
//!
//! 1. per frame, the real FFT of each prepared row zero-padded to 6w (h rows; the other h are
//!    zero), half the rows on each thread;
//! 2. per batch of columns u, half the columns on each thread: the rows' values gathered into
//!    columns, the column FFTs, and the power |R + c T|^2 and |T + c R|^2 of the two orders
//!    (u-major), with every 8th value of their filtered form sampled as soon as its neighbour
//!    columns exist;
//! 3. per order, the threshold: the median of that sample;
//! 4. per order and batch of columns: the filtered, binarised spectrum, whose columns are real,
//!    two columns packed as one complex column B(u) + i B(u + 1), one inverse column FFT, and
//!    each unpacked from its Hermitian part; only rows 0..=h/2 are kept;
//! 5. per order, the inverse real FFT of those rows. The spectrum is real and even
//!    (B(-u, -v) = B(u, v)), so the correlation plane is too: p(x, -y) = p(-x, y) gives the
//!    rows above the axis, and the mirror cross peak at (-(2w + dx), -dy) is exactly the first
//!    one reflected, so only the first is searched.
//!
//! The orders go through the same operations on swapped data, so a frame against itself gives
//! both orders the same plane bit for bit and the antisymmetrised shift exactly 0; a kept
//! spectrum is the one the frame's own transform gives, so a track equals fresh pairs bit for
//! bit.

use super::fft2::Plans;
use super::jtc::{JtcOptions, Plane, SubPixel, prepare};
use super::{ShiftError, ShiftEstimate, check_frame};
use rustfft::num_complex::Complex32;
use std::ops::Range;

/// Spectrum columns per batch of column FFTs (8 columns of 2h values stay in L1/L2).
const BATCH: usize = 8;
/// Padding between a batch's gathered columns: with a power-of-two 2h, columns exactly 2h apart
/// put the eight stores of one row's gather 4 KiB apart, where they alias in the cache.
const COL_PAD: usize = 8;

pub(crate) struct PaperJtc {
    joint: Joint,
    opts: JtcOptions,
    /// The prepared frames: reference, current.
    prepared: [Vec<f32>; 2],
    /// The frames' row spectra (h rows of 3w + 1): reference, current.
    rows: [Vec<Complex32>; 2],
    /// Column spectra (u-major, `[u * 2h + v]`): `[1]` the current frame's, kept for the next
    /// pair in a track; `[0]` the reference's when it was kept from the last pair.
    spectra: [Vec<Complex32>; 2],
    /// The last current frame (when `last_valid`), and whether `spectra[1]` holds its spectrum.
    last: Vec<f32>,
    last_valid: bool,
    kept: bool,
    /// Stages 1 and 2 on two threads: halves of the rows, then of the columns.
    workers: [Worker; 2],
    /// Reference first (`[0]`: the shift of the current frame), current first (`[1]`).
    orders: [Order; 2],
}

/// The joint image's geometry: 6w x 2h, half spectrum of 3w + 1 columns of 2h.
#[derive(Debug, Clone, Copy)]
struct Joint {
    w: usize,
    h: usize,
    filter: bool,
}

impl Joint {
    fn hh(self) -> usize {
        2 * self.h
    }

    fn hw(self) -> usize {
        3 * self.w + 1
    }

    /// Whether column u's filtered values need no reflection (and there is a filter).
    fn interior(self, u: usize) -> bool {
        self.filter && u > 0 && u < 3 * self.w
    }

    /// E(u, v) = 2 P(u, v) - P(u - 1, v) - P(u + 1, v) with P(-u, -v) = P(u, v) beyond the half
    /// spectrum's ends (or P without the filter), at one frequency of the power spectrum `p`.
    fn filtered(self, p: &[f32], u: usize, v: usize) -> f32 {
        let (hh, hw) = (self.hh(), self.hw());
        if !self.filter {
            return p[u * hh + v];
        }
        let mirror = || (hh - v) % hh;
        let lo = if u == 0 {
            p[hh + mirror()]
        } else {
            p[(u - 1) * hh + v]
        };
        let hi = if u + 1 == hw {
            p[(hw - 2) * hh + mirror()]
        } else {
            p[(u + 1) * hh + v]
        };
        2.0 * p[u * hh + v] - lo - hi
    }

    /// Column u of the filtered spectrum.
    fn filtered_column(self, p: &[f32], u: usize, out: &mut [f32]) {
        let hh = self.hh();
        if !self.filter {
            out.copy_from_slice(&p[u * hh..(u + 1) * hh]);
        } else if self.interior(u) {
            let (lo, mid, hi) = (
                &p[(u - 1) * hh..u * hh],
                &p[u * hh..(u + 1) * hh],
                &p[(u + 1) * hh..(u + 2) * hh],
            );
            for (((e, &b), &a), &c) in out.iter_mut().zip(mid).zip(lo).zip(hi) {
                *e = 2.0 * b - a - c;
            }
        } else {
            for (v, e) in out.iter_mut().enumerate() {
                *e = self.filtered(p, u, v);
            }
        }
    }

    /// Writes column u's share of the threshold's sample, the filtered values at every 8th
    /// index u * 2h + v of the u-major half spectrum, to the front of `out`; returns how many.
    /// `p` holds the power from column `p0` on, including the neighbours u's filter reads.
    fn sample_column(self, p: &[f32], p0: usize, u: usize, out: &mut [f32]) -> usize {
        let hh = self.hh();
        let start = (8 - (u * hh) % 8) % 8;
        let n = (hh - start).div_ceil(8);
        let at = |u: usize| &p[(u - p0) * hh..(u - p0 + 1) * hh];
        let (out, vs) = (&mut out[..n], (start..hh).step_by(8));
        if !self.filter {
            let mid = at(u);
            for (o, v) in out.iter_mut().zip(vs) {
                *o = mid[v];
            }
        } else if self.interior(u) {
            let (lo, mid, hi) = (at(u - 1), at(u), at(u + 1));
            for (o, v) in out.iter_mut().zip(vs) {
                *o = 2.0 * mid[v] - lo[v] - hi[v];
            }
        } else {
            // An end column (as `filtered`): the outer neighbour is the inner one mirrored.
            let inner = if u == 0 { at(1) } else { at(u - 1) };
            let (mid, mirror) = (at(u), |v: usize| inner[(hh - v) % hh]);
            for (o, v) in out.iter_mut().zip(vs) {
                *o = if u == 0 {
                    2.0 * mid[v] - mirror(v) - inner[v]
                } else {
                    2.0 * mid[v] - inner[v] - mirror(v)
                };
            }
        }
        n
    }
}

/// exp(-2 pi i u / 3): the phase of the frame at column 2w of the joint image.
fn separation_phase(u: usize) -> Complex32 {
    const S: f32 = 0.866_025_4; // sqrt(3) / 2
    match u % 3 {
        0 => Complex32::new(1.0, 0.0),
        1 => Complex32::new(-0.5, -S),
        _ => Complex32::new(-0.5, S),
    }
}

/// Stages 1 and 2 on one thread: its plans, a row buffer, a batch of columns per frame and its
/// share of each order's threshold sample.
struct Worker {
    plans: Plans,
    row_in: Vec<f32>,
    cols: [Vec<Complex32>; 2],
    sample: [Vec<f32>; 2],
    taken: usize,
}

/// The column FFTs of the columns `us` gathered from `rows` into `cols` (padded), each into
/// `out` (column after column) when given, else in place.
fn transform_columns(
    p: &mut Plans,
    j: Joint,
    rows: &[Complex32],
    us: Range<usize>,
    cols: &mut [Complex32],
    mut out: Option<&mut [Complex32]>,
) {
    let (h, hh) = (j.h, j.hh());
    let n = us.len();
    gather_columns(rows, j.hw(), us.start, n, cols, hh + COL_PAD);
    for (k, col) in cols.chunks_exact_mut(hh + COL_PAD).take(n).enumerate() {
        let col = &mut col[..hh];
        col[h..].fill(Complex32::default());
        match out.as_deref_mut() {
            Some(o) => {
                let o = &mut o[k * hh..(k + 1) * hh];
                p.col_fwd
                    .process_outofplace_with_scratch(col, o, &mut p.scratch_c);
            }
            None => p.col_fwd.process_with_scratch(col, &mut p.scratch_c),
        }
    }
}

/// One column of both orders' power: |R + c T|^2 (reference first) and |T + c R|^2.
fn order_powers(c: Complex32, r: &[Complex32], t: &[Complex32], pf: &mut [f32], pb: &mut [f32]) {
    for (((f, b), &a), &t) in pf.iter_mut().zip(pb.iter_mut()).zip(r).zip(t) {
        *f = (a + c * t).norm_sqr();
        *b = (t + c * a).norm_sqr();
    }
}

/// One frame order's stages 3 to 5.
struct Order {
    plans: Plans,
    cols: Vec<Complex32>,
    /// Two filtered columns.
    e: Vec<f32>,
    /// Rows 0..=h/2 of the plane's spectrum (3w + 1 each).
    rows: Vec<Complex32>,
    /// |J(u, v)|^2, u-major: `power[u * 2h + v]`.
    power: Vec<f32>,
    /// The threshold's sample.
    sample: Vec<f32>,
    row_out: Vec<f32>,
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
        let (rows, spectrum) = (height * joint.hw(), joint.hw() * joint.hh());
        let zeros = |n| vec![Complex32::default(); n];
        Self {
            joint,
            opts,
            prepared: [vec![0.0; width * height], vec![0.0; width * height]],
            rows: [zeros(rows), zeros(rows)],
            spectra: [zeros(spectrum), zeros(spectrum)],
            last: vec![0.0; width * height],
            last_valid: false,
            kept: false,
            workers: [Worker::new(joint), Worker::new(joint)],
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
        // A track keeps each current frame's spectrum for the next pair; independent pairs do
        // not pay for storing it.
        let track = self.last_valid && reference == self.last.as_slice();
        let reuse = track && self.kept;
        let mr = if reuse {
            0.0
        } else {
            check_frame("reference", reference, j.w, j.h)?
        };
        // A refused current frame leaves no spectrum to reuse.
        (self.last_valid, self.kept) = (false, false);
        let mt = check_frame("current", current, j.w, j.h)?;
        if reuse {
            self.spectra.swap(0, 1);
        } else {
            self.transform_rows(0, reference, mr);
        }
        self.transform_rows(1, current, mt);
        self.columns(reuse, track);
        self.last.copy_from_slice(current);
        (self.last_valid, self.kept) = (true, track);
        let [f, b] = &mut self.orders;
        let (tf, tb) = rayon::join(|| f.threshold(opts), || b.threshold(opts));
        rayon::join(|| f.inverse(j, tf), || b.inverse(j, tb));
        let (forward, backward) =
            rayon::join(|| f.peak(j, opts.subpixel), || b.peak(j, opts.subpixel));
        Ok(ShiftEstimate {
            dx: 0.5 * (forward.dx - backward.dx),
            dy: 0.5 * (forward.dy - backward.dy),
            confidence: forward.confidence.min(backward.confidence),
        })
    }

    /// Stage 1 for frame `i` (0: reference, 1: current): prepared, then its rows' real FFTs.
    fn transform_rows(&mut self, i: usize, frame: &[f32], mean: f32) {
        let (j, laplacian) = (self.joint, self.opts.laplacian);
        let prepared = &mut self.prepared[i];
        prepare(frame, mean, j.w, j.h, laplacian, prepared);
        let split = j.h / 2;
        let (top, bottom) = self.rows[i].split_at_mut(split * j.hw());
        let [w0, w1] = &mut self.workers;
        let prepared = &*prepared;
        rayon::join(
            || w0.rows(j, prepared, 0, top),
            || w1.rows(j, prepared, split, bottom),
        );
    }

    /// Stage 2: the column spectra of the current frame (kept when `keep`) and of the
    /// reference (transformed, or the kept one when `reuse`), both orders' power and samples.
    fn columns(&mut self, reuse: bool, keep: bool) {
        let j = self.joint;
        let (hh, hw) = (j.hh(), j.hw());
        let mid = (hw / 2).div_ceil(BATCH) * BATCH;
        let [sr, st] = &mut self.spectra;
        let (sr0, sr1) = sr.split_at(mid * hh);
        let (st0, st1) = st.split_at_mut(mid * hh);
        let [of, ob] = &mut self.orders;
        let (pf0, pf1) = of.power.split_at_mut(mid * hh);
        let (pb0, pb1) = ob.power.split_at_mut(mid * hh);
        let rows = [&self.rows[0][..], &self.rows[1][..]];
        let kept = |s| reuse.then_some(s);
        let (st0, st1) = (keep.then_some(st0), keep.then_some(st1));
        let [w0, w1] = &mut self.workers;
        rayon::join(
            || w0.columns(j, rows, 0..mid, (kept(sr0), st0), [pf0, pb0]),
            || w1.columns(j, rows, mid..hw, (kept(sr1), st1), [pf1, pb1]),
        );
        for (o, order) in self.orders.iter_mut().enumerate() {
            order.sample.clear();
            for w in &self.workers {
                order.sample.extend_from_slice(&w.sample[o][..w.taken]);
            }
            if j.filter {
                // The columns either side of the split, each needing one from the other half.
                for u in [mid - 1, mid] {
                    let n = j.sample_column(&order.power, 0, u, &mut order.e);
                    order.sample.extend_from_slice(&order.e[..n]);
                }
            }
        }
    }
}

impl Worker {
    fn new(j: Joint) -> Self {
        let (hh, hw) = (j.hh(), j.hw());
        let cols = || vec![Complex32::default(); BATCH * (hh + COL_PAD)];
        let sample = || vec![0.0; hw * hh / 8 + hw];
        Self {
            plans: Plans::new(6 * j.w, hh),
            row_in: vec![0.0; 6 * j.w],
            cols: [cols(), cols()],
            sample: [sample(), sample()],
            taken: 0,
        }
    }

    /// The real FFTs of the prepared frame's rows `y0..`, zero-padded to 6w, into `out`.
    fn rows(&mut self, j: Joint, prepared: &[f32], y0: usize, out: &mut [Complex32]) {
        let w = j.w;
        let p = &mut self.plans;
        for (y, out) in (y0..).zip(out.chunks_exact_mut(j.hw())) {
            self.row_in[..w].copy_from_slice(&prepared[y * w..(y + 1) * w]);
            self.row_in[w..].fill(0.0);
            // Lengths are from the plan, so realfft cannot fail here.
            let _ = p
                .r2c
                .process_with_scratch(&mut self.row_in, out, &mut p.scratch_r);
        }
    }

    /// Stage 2 for the columns `range`: the reference's column spectrum (from `kept` when
    /// given, else transformed), the current's (transformed, into `current` when given), both
    /// orders' power (into `power`, from column `range.start`) and this worker's samples.
    fn columns(
        &mut self,
        j: Joint,
        rows: [&[Complex32]; 2],
        range: Range<usize>,
        (kept, mut current): (Option<&[Complex32]>, Option<&mut [Complex32]>),
        power: [&mut [f32]; 2],
    ) {
        let (hh, hw) = (j.hh(), j.hw());
        let (start, end) = (range.start, range.end);
        let [pf, pb] = power;
        self.taken = 0;
        let mut sampled = start;
        for u0 in range.step_by(BATCH) {
            let n = BATCH.min(end - u0);
            let [cr, ct] = &mut self.cols;
            let at = (u0 - start) * hh;
            let out = current.as_deref_mut().map(|s| &mut s[at..at + n * hh]);
            transform_columns(&mut self.plans, j, rows[1], u0..u0 + n, ct, out);
            if kept.is_none() {
                transform_columns(&mut self.plans, j, rows[0], u0..u0 + n, cr, None);
            }
            fn column(buf: &[Complex32], k: usize, hh: usize) -> &[Complex32] {
                &buf[k * (hh + COL_PAD)..][..hh]
            }
            for k in 0..n {
                let at = at + k * hh;
                let t = current
                    .as_deref()
                    .map_or(column(ct, k, hh), |s| &s[at..at + hh]);
                let r = kept.map_or(column(cr, k, hh), |s| &s[at..at + hh]);
                let (qf, qb) = (&mut pf[at..at + hh], &mut pb[at..at + hh]);
                order_powers(separation_phase(u0 + k), r, t, qf, qb);
            }
            // Column u's filtered values need column u + 1 (the last column, column hw - 2);
            // the columns beside this worker's range are sampled after both halves are done.
            let ready = if !j.filter || u0 + n == hw {
                u0 + n
            } else {
                u0 + n - 1
            };
            let first = if j.filter && start > 0 {
                sampled.max(start + 1)
            } else {
                sampled
            };
            for u in first..ready {
                let [sf, sb] = &mut self.sample;
                let n = j.sample_column(pf, start, u, &mut sf[self.taken..]);
                j.sample_column(pb, start, u, &mut sb[self.taken..]);
                self.taken += n;
            }
            sampled = ready.max(sampled);
        }
    }
}

impl Order {
    fn new(j: Joint) -> Self {
        let (hh, hw) = (j.hh(), j.hw());
        Self {
            plans: Plans::new(6 * j.w, hh),
            cols: vec![Complex32::default(); BATCH * hh],
            e: vec![0.0; 2 * hh],
            rows: vec![Complex32::default(); (j.h / 2 + 1) * hw],
            power: vec![0.0; hw * hh],
            sample: Vec::with_capacity(hw * hh / 8 + hw),
            row_out: vec![0.0; 6 * j.w],
            window: vec![0.0; j.h * (2 * j.w + 2)],
        }
    }

    /// Stage 3: the binarisation threshold, when binarising.
    fn threshold(&mut self, opts: JtcOptions) -> Option<f32> {
        opts.binarize.then(|| {
            let n = self.sample.len();
            *self.sample.select_nth_unstable_by(n / 2, f32::total_cmp).1
        })
    }

    /// Stages 4 and 5.
    fn inverse(&mut self, j: Joint, threshold: Option<f32>) {
        self.inverse_columns(j, threshold);
        self.plane(j);
    }

    /// Stage 4: the inverse column FFTs of the processed spectrum (filtered, then binarised at
    /// `threshold`), two real columns at once as B(u) + i B(u + 1); rows 0..=h/2 of each
    /// unpacked into `rows`.
    fn inverse_columns(&mut self, j: Joint, threshold: Option<f32>) {
        let (hh, hw, half) = (j.hh(), j.hw(), j.h / 2);
        let binary = |e: f32, m: f32| if e > m { 1.0 } else { -1.0 };
        let (e0, e1) = self.e.split_at_mut(hh);
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
                .process_with_scratch(row, &mut self.row_out, &mut p.scratch_r);
            let data = &self.row_out;
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

/// `cols[k * stride + y] = rows[y * hw + u0 + k]` for k in 0..n and every row y. A whole batch
/// goes by 8 x 8 tiles of fixed size, so that each column receives runs of eight values.
fn gather_columns(
    rows: &[Complex32],
    hw: usize,
    u0: usize,
    n: usize,
    cols: &mut [Complex32],
    stride: usize,
) {
    let h = rows.len() / hw;
    if n < BATCH {
        for (y, row) in rows.chunks_exact(hw).enumerate() {
            for (k, &c) in row[u0..u0 + n].iter().enumerate() {
                cols[k * stride + y] = c;
            }
        }
        return;
    }
    let tiles = h / BATCH * BATCH;
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
        for (k, &c) in row[u0..u0 + BATCH].iter().enumerate() {
            cols[k * stride + y] = c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::jtc::SubPixel;
    use super::super::jtc_oracle::{joint_image_f64, pairs};
    use super::*;

    /// A track (each frame against the previous one, whose spectrum is kept) gives bit for bit
    /// what a fresh estimator gives for each pair, with and without the filter; a refused
    /// current frame leaves no spectrum behind.
    #[test]
    fn a_track_equals_fresh_pairs() {
        let (w, h) = (64, 48);
        let frames: Vec<Vec<f32>> = pairs(w, h).into_iter().flat_map(|(r, t)| [r, t]).collect();
        for spectral_filter in [true, false] {
            let opts = JtcOptions {
                spectral_filter,
                ..JtcOptions::default()
            };
            let mut track = PaperJtc::new(w, h, opts);
            for pair in frames.windows(2) {
                let reused = track.estimate(&pair[0], &pair[1]).unwrap();
                let fresh = PaperJtc::new(w, h, opts)
                    .estimate(&pair[0], &pair[1])
                    .unwrap();
                assert_eq!(reused, fresh);
            }
            let bad = vec![1.0; w * h];
            assert!(track.estimate(&frames[0], &bad).is_err());
            let again = track.estimate(&frames[2], &frames[3]).unwrap();
            let fresh = PaperJtc::new(w, h, opts)
                .estimate(&frames[2], &frames[3])
                .unwrap();
            assert_eq!(again, fresh);
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
