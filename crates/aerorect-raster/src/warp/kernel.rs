//! Resampling kernels: prepare each destination pixel's taps once, then apply them to every band.

use super::relative::RelativeBlock;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::Mat3;

/// What the kernels need to know of the source image.
pub(crate) struct SourceGeometry {
    width: usize,
    height: usize,
    /// Offset to the right neighbour (0 for a one-column image).
    step_x: usize,
    /// Offset to the neighbour below (0 for a one-row image).
    step_y: usize,
    /// Use the AVX2 build of the row loop.
    simd: bool,
    /// The AVX2 build may also use AVX-512 F, BW, VL, VBMI and VNNI (`Build::Best` on a CPU
    /// with them).
    pub(crate) avx512: bool,
}

/// Which build of the kernels a warp runs: the portable one, AVX2 alone, or the best this CPU
/// has (AVX2, with AVX-512 steps where it has F, BW, VL, VBMI and VNNI). Tests compare all
/// three.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Build {
    Portable,
    Avx2,
    Best,
}

impl SourceGeometry {
    pub(crate) fn width(&self) -> usize {
        self.width
    }

    pub(crate) fn height(&self) -> usize {
        self.height
    }

    /// The geometry of `src`, for kernels of `build` (as far as the CPU has it).
    pub(crate) fn of<T: Sample>(src: &Raster<T>, build: Build) -> Self {
        let (width, height) = (src.width(), src.height());
        let simd = build != Build::Portable && crate::cpu::avx2();
        Self {
            width,
            height,
            step_x: usize::from(width > 1),
            step_y: if height > 1 { width } else { 0 },
            simd,
            avx512: simd && build == Build::Best && crate::cpu::avx512_vbmi_vnni(),
        }
    }

    /// Inside the pixel footprints: -0.5 <= x < W - 0.5 (false for NaN).
    #[inline(always)]
    fn inside(&self, x: f64, y: f64) -> bool {
        x >= -0.5 && x < self.width as f64 - 0.5 && y >= -0.5 && y < self.height as f64 - 0.5
    }
}

/// A resampling kernel: per-pixel taps, prepared once and applied to each band.
pub(crate) trait Kernel: 'static {
    type Tap: Copy + Default + Send;
    /// Whether the kernel takes fast positions (`Coordinates::Fast`) at all.
    const FAST: bool = true;
    /// Added to fast positions before they are split into an integer origin and an f32
    /// offset (`RelativeBlock::new`): the kernel's own rounding then falls on the offset.
    const FAST_SHIFT: f64 = 0.0;
    /// Writes the taps of source position (x, y); false when (x, y) is outside the image.
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut Self::Tap) -> bool;
    fn apply<T: Sample>(plane: &[T], g: &SourceGeometry, tap: &Self::Tap) -> T;
}

/// The most destination pixels handled per block: coordinates, taps and all bands stay in L1
/// (a block's set-up, fast positions' above all, is then paid once per 1024 pixels).
pub(crate) const BLOCK: usize = 1024;

/// The shortest block fast positions are tried on (`RowPlan::block`).
pub(crate) const MIN_FAST_BLOCK: usize = 256;

/// Per-task buffers, one block long, reused block after block.
pub(crate) struct Scratch<K: Kernel> {
    xs: Vec<f64>,
    ys: Vec<f64>,
    taps: Vec<K::Tap>,
    valid: Vec<bool>,
    #[cfg(target_arch = "x86_64")]
    simd: super::avx2::SimdScratch,
}

impl<K: Kernel> Scratch<K> {
    pub(crate) fn new() -> Self {
        Self {
            xs: vec![0.0; BLOCK],
            ys: vec![0.0; BLOCK],
            taps: vec![K::Tap::default(); BLOCK],
            valid: vec![false; BLOCK],
            #[cfg(target_arch = "x86_64")]
            simd: super::avx2::SimdScratch::new(),
        }
    }
}

/// What every row of one warp shares: the map, its matrix when positions are fast
/// (`Coordinates::Fast` on a projective map), the nodata value and whether alpha is written.
pub(crate) struct RowPlan<'a, M, T> {
    pub(crate) map: &'a M,
    pub(crate) fast: Option<&'a Mat3>,
    pub(crate) nodata: T,
    pub(crate) alpha: bool,
}

impl<M: PixelMap, T> RowPlan<'_, M, T> {
    /// The block from (`col0`, `row`) for kernel `K`: its length (at most `max_n`) and its fast
    /// positions where they apply (`RelativeBlock::new`). Fast blocks are tried at `max_n`, then
    /// halved down to `MIN_FAST_BLOCK` (a long block's f32 offsets are larger, and so is its
    /// error bound); a block none of them covers is `MIN_FAST_BLOCK` long with exact positions,
    /// so the next one tries again. Both builds cut rows this way, so they see the same positions.
    #[inline]
    fn block<K: Kernel>(
        &self,
        row: usize,
        col0: usize,
        max_n: usize,
    ) -> (usize, Option<RelativeBlock>) {
        let Some(m) = self.fast.filter(|_| K::FAST) else {
            return (max_n, None);
        };
        let mut n = max_n;
        loop {
            if let Some(block) = RelativeBlock::new(m, row, col0, n, K::FAST_SHIFT) {
                return (n, Some(block));
            }
            if n <= MIN_FAST_BLOCK {
                return (n, None);
            }
            n = (n / 2).max(MIN_FAST_BLOCK);
        }
    }

    /// Fills the source positions of a block (`block`) of `xs.len()` pixels from
    /// (`col0`, `row`): fast where `fast` is given, exact otherwise.
    #[inline]
    fn positions(
        &self,
        fast: Option<&RelativeBlock>,
        row: usize,
        col0: usize,
        xs: &mut [f64],
        ys: &mut [f64],
    ) {
        match fast {
            Some(block) => block.fill(0, xs, ys),
            None => self.map.source_row(row, col0, xs, ys),
        }
    }
}

/// One destination row inside a task's chunks (one chunk per band, alpha last).
pub(crate) struct RowOut<'a, 'b, T> {
    pub(crate) chunks: &'a mut [&'b mut [T]],
    /// Index of the row's first pixel in each chunk.
    pub(crate) start: usize,
    pub(crate) row: usize,
    /// The columns of the row to resample (a tile's share of it).
    pub(crate) cols: std::ops::Range<usize>,
    pub(crate) alpha: bool,
}

impl<T: Sample> RowOut<'_, '_, T> {
    /// With an alpha band (the last chunk): opaque where `valid`, transparent elsewhere, over
    /// `range` of the chunk.
    fn write_alpha(&mut self, range: std::ops::Range<usize>, valid: &[bool]) {
        if let (true, Some(alpha)) = (self.alpha, self.chunks.last_mut()) {
            for (d, &ok) in alpha[range].iter_mut().zip(valid) {
                *d = if ok { T::OPAQUE } else { T::default() };
            }
        }
    }
}

/// Resamples one destination row. Uses the AVX2 build of the kernels where the CPU has it.
pub(crate) fn row<T: Sample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    out: RowOut<'_, '_, T>,
) {
    #[cfg(target_arch = "x86_64")]
    if g.simd && g.width >= 4 && g.height >= 4 && src.bands() <= MAX_SIMD_BANDS {
        // SAFETY: `g.simd` is only set after `crate::cpu::avx2()` returned true;
        // the source is at least 4 x 4.
        let out = match same_type::<T, u8, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<u8, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        let out = match same_type::<T, u16, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<u16, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        let out = match same_type::<T, f32, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<f32, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        return row_body::<T, K, M>(src, plan, g, scratch, out);
    }
    row_body::<T, K, M>(src, plan, g, scratch, out);
}

/// The source, plan and row as sample type `S` when `T` is `S`; the row back otherwise.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::type_complexity)]
fn same_type<'s, 'p, 'a, 'b, T: Sample, S: Sample, M>(
    src: &'s Raster<T>,
    plan: &RowPlan<'p, M, T>,
    out: RowOut<'a, 'b, T>,
) -> Result<(&'s Raster<S>, RowPlan<'p, M, S>, RowOut<'a, 'b, S>), RowOut<'a, 'b, T>> {
    use std::any::TypeId;
    if TypeId::of::<T>() != TypeId::of::<S>() {
        return Err(out);
    }
    // SAFETY: T and S are the same type (equal TypeIds), so these casts change no type.
    let (src, chunks, nodata) = unsafe {
        (
            &*(src as *const Raster<T> as *const Raster<S>),
            &mut *(out.chunks as *mut [&'b mut [T]] as *mut [&'b mut [S]]),
            *(&plan.nodata as *const T as *const S),
        )
    };
    let plan = RowPlan {
        map: plan.map,
        fast: plan.fast,
        nodata,
        alpha: plan.alpha,
    };
    let out = RowOut {
        chunks,
        start: out.start,
        row: out.row,
        cols: out.cols,
        alpha: out.alpha,
    };
    Ok((src, plan, out))
}

/// Bands handled by the AVX2 kernels without allocating.
#[cfg(target_arch = "x86_64")]
const MAX_SIMD_BANDS: usize = 8;

/// The AVX2 build: per block, the kernel's taps eight (four) pixels at a time, then each band.
///
/// # Safety
/// The CPU has AVX2; the source is at least 4 x 4 with at most `MAX_SIMD_BANDS` full planes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn row_avx2<T: super::avx2::SimdSample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    mut out: RowOut<'_, '_, T>,
) {
    use super::avx2::{self, Buffered, Exact, Relative};
    use std::any::TypeId;
    let kernel = TypeId::of::<K>();
    let nodata = plan.nodata;
    let bands = src.bands();
    let mut planes: [&[T]; MAX_SIMD_BANDS] = [&[]; MAX_SIMD_BANDS];
    for (p, b) in planes.iter_mut().zip(0..bands) {
        *p = src.plane(b);
    }
    let planes = &planes[..bands];
    let Scratch {
        xs,
        ys,
        valid,
        simd,
        ..
    } = scratch;
    let mut c0 = out.cols.start;
    while c0 < out.cols.end {
        let (n, fast) = plan.block::<K>(out.row, c0, BLOCK.min(out.cols.end - c0));
        let range = out.start + c0..out.start + c0 + n;
        let (xs, ys, valid) = (&mut xs[..n], &mut ys[..n], &mut valid[..n]);
        let mut outs: [&mut [T]; MAX_SIMD_BANDS] = Default::default();
        for (o, chunk) in outs.iter_mut().zip(out.chunks.iter_mut().take(bands)) {
            *o = &mut chunk[range.clone()];
        }
        let outs = &mut outs[..bands];
        let cubic = (&mut simd.cubic[..], &mut simd.base[..], &mut simd.state[..]);
        // SAFETY (all arms): AVX2 is enabled; the source is at least 4 x 4 with full planes;
        // positions and outputs are n long.
        match fast {
            Some(block) => {
                let rel = Relative::new(g, &block, n);
                if kernel == TypeId::of::<Nearest>() {
                    unsafe { avx2::nearest_block(g, &rel, planes, outs, valid, nodata) };
                } else {
                    let whole = n / 8 * 8;
                    let (px, py) = (&mut simd.px[..whole], &mut simd.py[..whole]);
                    rel.fill_offsets(px, py);
                    let pos = Buffered { rel: &rel, px, py };
                    if kernel == TypeId::of::<Bicubic>() {
                        unsafe { avx2::bicubic_block(g, &pos, planes, outs, valid, cubic, nodata) };
                    } else {
                        unsafe { avx2::bilinear_block(g, &pos, planes, outs, valid, nodata) };
                    }
                }
            }
            None if kernel == TypeId::of::<Bicubic>() => {
                plan.map.source_row(out.row, c0, xs, ys);
                let pos = Exact { xs, ys };
                unsafe { avx2::bicubic_block(g, &pos, planes, outs, valid, cubic, nodata) };
            }
            None => {
                plan.map.source_row(out.row, c0, xs, ys);
                let pos = Exact { xs, ys };
                if kernel == TypeId::of::<Nearest>() {
                    unsafe { avx2::nearest_block(g, &pos, planes, outs, valid, nodata) };
                } else {
                    unsafe { avx2::bilinear_block(g, &pos, planes, outs, valid, nodata) };
                }
            }
        }
        out.write_alpha(range, valid);
        c0 += n;
    }
}

#[inline(always)]
fn row_body<T: Sample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    mut out: RowOut<'_, '_, T>,
) {
    let nodata = plan.nodata;
    let Scratch {
        xs,
        ys,
        taps,
        valid,
        ..
    } = scratch;
    let mut c0 = out.cols.start;
    while c0 < out.cols.end {
        let (n, fast) = plan.block::<K>(out.row, c0, BLOCK.min(out.cols.end - c0));
        let (xs, ys, taps, valid) = (&mut xs[..n], &mut ys[..n], &mut taps[..n], &mut valid[..n]);
        plan.positions(fast.as_ref(), out.row, c0, xs, ys);
        for (((x, y), tap), ok) in xs
            .iter()
            .zip(ys.iter())
            .zip(taps.iter_mut())
            .zip(valid.iter_mut())
        {
            *ok = K::prepare::<T>(g, *x, *y, tap);
        }
        let range = out.start + c0..out.start + c0 + n;
        for b in 0..src.bands() {
            let plane = src.plane(b);
            let dst = &mut out.chunks[b][range.clone()];
            for ((d, tap), &ok) in dst.iter_mut().zip(taps.iter()).zip(valid.iter()) {
                *d = if ok { K::apply(plane, g, tap) } else { nodata };
            }
        }
        out.write_alpha(range, valid);
        c0 += n;
    }
}

pub(crate) struct Nearest;

impl Kernel for Nearest {
    type Tap = u32;
    /// floor(x + 0.5) becomes origin + floor(offset).
    const FAST_SHIFT: f64 = 0.5;

    /// Branch-free like the bilinear one: the index is always valid, the flag tells inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut u32) -> bool {
        let nearest = |v: f64, n: usize| ((v + 0.5).max(0.0) as i32).min(n as i32 - 1) as u32;
        *tap = nearest(y, g.height) * g.width as u32 + nearest(x, g.width);
        g.inside(x, y)
    }

    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], _g: &SourceGeometry, tap: &u32) -> T {
        plane[*tap as usize]
    }
}

pub(crate) struct Bilinear;

#[derive(Clone, Copy, Default)]
pub(crate) struct BilinearTap {
    /// Index of the upper-left neighbour; the other three are `step_x`, `step_y` further on.
    offset: u32,
    fx: f32,
    fy: f32,
    /// The sample type's integer weights (`Sample::bilinear_weights`), made once for all bands.
    w: [i32; 4],
}

impl Kernel for Bilinear {
    type Tap = BilinearTap;

    /// Branch-free so that the loop vectorises: the taps are always valid indices (NaN and
    /// outside positions are clamped), the returned flag says whether the pixel is inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut BilinearTap) -> bool {
        let (x0, fx) = left_neighbour(x, g.width);
        let (y0, fy) = left_neighbour(y, g.height);
        *tap = BilinearTap {
            offset: y0 * g.width as u32 + x0,
            fx,
            fy,
            w: T::bilinear_weights((fx, fy)),
        };
        g.inside(x, y)
    }

    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], g: &SourceGeometry, t: &BilinearTap) -> T {
        let o = t.offset as usize;
        let last = o + g.step_y + g.step_x;
        assert!(last < plane.len()); // one check instead of four; `prepare` keeps it true
        // SAFETY: o <= o + step_x, o + step_y <= last < plane.len(), checked just above.
        let p = unsafe {
            [
                *plane.get_unchecked(o),
                *plane.get_unchecked(o + g.step_x),
                *plane.get_unchecked(o + g.step_y),
                *plane.get_unchecked(last),
            ]
        };
        T::bilinear(p, (t.fx, t.fy), t.w)
    }
}

/// The left (upper) neighbour index and the fraction towards the next one, with the edge
/// repeated: x is clamped to [0, n - 1] (NaN to 0) and the index to [0, n - 2].
#[inline(always)]
fn left_neighbour(x: f64, n: usize) -> (u32, f32) {
    let xc = x.max(0.0).min((n - 1) as f64);
    let i = (xc as i32).min(n.saturating_sub(2) as i32);
    (i as u32, (xc - i as f64) as f32)
}

pub(crate) struct Bicubic;

#[derive(Clone, Copy, Default)]
pub(crate) struct BicubicTap {
    /// Column indices of the four taps (edge repeated).
    cols: [u32; 4],
    /// Row start offsets of the four taps (edge repeated).
    rows: [u32; 4],
    wx: [f32; 4],
    wy: [f32; 4],
}

/// Keys' cubic convolution kernel with a = -0.5 at distance d: the definition that the per-tap
/// polynomials of `keys_weights` are tested against.
#[cfg(test)]
fn keys(d: f64) -> f64 {
    const A: f64 = -0.5;
    let d = d.abs();
    if d <= 1.0 {
        ((A + 2.0) * d - (A + 3.0)) * d * d + 1.0
    } else if d < 2.0 {
        ((A * d - 5.0 * A) * d + 8.0 * A) * d - 4.0 * A
    } else {
        0.0
    }
}

/// The four Keys (a = -0.5) weights of taps floor(x)-1 .. floor(x)+2 for t = x - floor(x):
/// keys(1 + t), keys(t), keys(1 - t), keys(2 - t), expanded (Catmull-Rom).
#[inline(always)]
pub fn keys_weights(t: f64) -> [f64; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    ]
}

/// `keys_weights` in f32, as the kernels use them (the fraction rounded to f32 first); the
/// operations and their order are those of the AVX2 build.
#[inline(always)]
pub(crate) fn keys_weights_f32(t: f32) -> [f32; 4] {
    let (t2, half_t) = (t * t, 0.5 * t);
    let t3 = t2 * t;
    [
        (-0.5 * t3 + t2) - half_t,
        (1.5 * t3 - 2.5 * t2) + 1.0,
        (-1.5 * t3 + 2.0 * t2) + half_t,
        0.5 * t3 - 0.5 * t2,
    ]
}

impl Kernel for Bicubic {
    type Tap = BicubicTap;

    /// Branch-free: indices are clamped (NaN to the first pixel), the flag tells inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut BicubicTap) -> bool {
        let inside = g.inside(x, y);
        // Positions are clamped to [-1, n] before flooring: taps are clamped anyway.
        let xc = x.max(-1.0).min(g.width as f64);
        let yc = y.max(-1.0).min(g.height as f64);
        let (xf, yf) = (xc.floor(), yc.floor());
        let wx = keys_weights_f32((xc - xf) as f32);
        let wy = keys_weights_f32((yc - yf) as f32);
        let (xi, yi) = (xf as i32, yf as i32);
        let (wmax, hmax) = (g.width as i32 - 1, g.height as i32 - 1);
        for k in 0..4 {
            tap.cols[k] = (xi - 1 + k as i32).clamp(0, wmax) as u32;
            tap.rows[k] = (yi - 1 + k as i32).clamp(0, hmax) as u32 * g.width as u32;
            tap.wx[k] = wx[k];
            tap.wy[k] = wy[k];
        }
        inside
    }

    /// Vertical first (per column i: ((p0i wy0 + p1i wy1) + p2i wy2) + p3i wy3), then
    /// horizontal as (h0 + h2) + (h1 + h3): the order of the AVX2 build, which does the four
    /// columns as one vector.
    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], g: &SourceGeometry, t: &BicubicTap) -> T {
        // Every index is below width * height = plane.len() by construction in `prepare`.
        assert!(plane.len() == g.width * g.height);
        let mut h = [0.0f32; 4];
        for (i, h) in h.iter_mut().enumerate() {
            // SAFETY: rows[j] <= (h-1) w and cols[i] <= w - 1, so the index is < w h = len.
            let p = |j: usize| unsafe {
                plane
                    .get_unchecked(t.rows[j] as usize + t.cols[i] as usize)
                    .to_f32()
            };
            let col = p(0) * t.wy[0] + p(1) * t.wy[1] + p(2) * t.wy[2] + p(3) * t.wy[3];
            *h = col * t.wx[i];
        }
        T::from_f32((h[0] + h[2]) + (h[1] + h[3]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_weights_are_the_kernel_to_f32_precision() {
        for k in 0..=4096 {
            let t = k as f64 / 4096.0 + 1e-7;
            let (w32, w64) = (keys_weights_f32(t as f32), keys_weights(t));
            for i in 0..4 {
                let e = (f64::from(w32[i]) - w64[i]).abs();
                assert!(
                    e < 3e-7,
                    "t = {t}, tap {i}: {} vs {} ({e:e})",
                    w32[i],
                    w64[i]
                );
            }
        }
    }

    #[test]
    fn expanded_weights_equal_the_kernel_definition() {
        for k in 0..=1000 {
            let t = k as f64 / 1000.0;
            let w = keys_weights(t);
            let d = [keys(1.0 + t), keys(t), keys(1.0 - t), keys(2.0 - t)];
            for i in 0..4 {
                assert!(
                    (w[i] - d[i]).abs() < 1e-14,
                    "t = {t}, tap {i}: {} vs {}",
                    w[i],
                    d[i]
                );
            }
            assert!(
                (w.iter().sum::<f64>() - 1.0).abs() < 1e-14,
                "partition of unity"
            );
        }
    }
}
