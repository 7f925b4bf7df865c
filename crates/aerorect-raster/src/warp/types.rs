//! Types shared by the warp's dispatcher and every build of its kernels (portable, AVX2,
//! AVX-512): the source geometry, the build, the kernel trait, one warp's row plan and one
//! destination row. They live here, below the dispatcher and the kernels, so that
//! neither imports the other.

use super::block::MIN_FAST_BLOCK;
use super::relative::RelativeBlock;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::Mat3;

/// What the kernels need to know of the source image.
pub(crate) struct SourceGeometry {
    pub(crate) width: usize,
    pub(crate) height: usize,
    /// Offset to the right neighbour (0 for a one-column image).
    pub(crate) step_x: usize,
    /// Offset to the neighbour below (0 for a one-row image).
    pub(crate) step_y: usize,
    /// Use the AVX2 build of the row loop.
    pub(crate) simd: bool,
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
    pub(crate) fn inside(&self, x: f64, y: f64) -> bool {
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
    pub(crate) fn block<K: Kernel>(
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
    pub(crate) fn positions(
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
    pub(crate) fn write_alpha(&mut self, range: std::ops::Range<usize>, valid: &[bool]) {
        if let (true, Some(alpha)) = (self.alpha, self.chunks.last_mut()) {
            for (d, &ok) in alpha[range].iter_mut().zip(valid) {
                *d = if ok { T::OPAQUE } else { T::default() };
            }
        }
    }
}

/// The destination cut into strips of `rows` rows, one task each: per strip, its part of every
/// band (alpha last).
pub(crate) fn row_strips<T: Sample>(dst: &mut Raster<T>, rows: usize) -> Vec<Vec<&mut [T]>> {
    let width = dst.width();
    let n_tasks = dst.height().div_ceil(rows);
    let mut tasks: Vec<Vec<&mut [T]>> = (0..n_tasks).map(|_| Vec::new()).collect();
    for plane in dst.planes_mut() {
        for (task, chunk) in tasks.iter_mut().zip(plane.chunks_mut(rows * width)) {
            task.push(chunk);
        }
    }
    tasks
}
