//! The warp engine: inverse mapping with nearest, bilinear or bicubic (Keys, a = -0.5) sampling,
//! or area averaging (`area`); bilinear and bicubic read a box-reduced pyramid level where the
//! destination is more than twice coarser than the source (`prefilter`).
//!
//! Sampling convention: a source position (x, y) is inside the image when
//! -0.5 <= x < W - 0.5 and -0.5 <= y < H - 0.5 (the pixel footprints); inside, neighbours past
//! the edge repeat the edge pixel. Outside, the destination gets the nodata value and, when asked,
//! a zero in the alpha band (which is OPAQUE where valid).

mod area;
#[cfg(target_arch = "x86_64")]
mod avx2;
mod kernel;
mod prefilter;
mod relative;

use crate::error::RasterError;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::ImageSize;
use rayon::prelude::*;

pub use kernel::keys_weights;
pub use relative::FAST_MAX_ERROR;

/// How the destination pixels' source positions are evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Coordinates {
    /// Every position in f64, as the map gives it.
    Exact,
    /// For projective maps (`PixelMap::projective`): per block of a row (1024 pixels, or 512
    /// or 256 where a longer block's bound is too large), the first position in f64 and the
    /// others as f32 offsets from it, where the block's own error bound is at most
    /// `FAST_MAX_ERROR` (5e-4 px; see `relative`); other blocks, other maps, and the average
    /// kernel (an area, not positions) are exact.
    #[default]
    Fast,
}

/// The interpolation kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Interp {
    Nearest,
    #[default]
    Bilinear,
    /// Keys' cubic convolution with a = -0.5.
    Bicubic,
    /// The mean of the source pixels under the destination pixel's footprint, weighted by the
    /// area they share with it (GDAL's `-r average`, OpenCV's `INTER_AREA`); see `area`.
    Average,
}

impl Interp {
    pub fn name(&self) -> &'static str {
        match self {
            Interp::Nearest => "nearest",
            Interp::Bilinear => "bilinear",
            Interp::Bicubic => "bicubic",
            Interp::Average => "average",
        }
    }
}

impl std::str::FromStr for Interp {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "nearest" => Ok(Interp::Nearest),
            "bilinear" => Ok(Interp::Bilinear),
            "bicubic" => Ok(Interp::Bicubic),
            "average" => Ok(Interp::Average),
            _ => Err(format!(
                "unknown interpolation '{s}': expected nearest, bilinear, bicubic or average"
            )),
        }
    }
}

/// How to warp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarpOptions {
    pub interp: Interp,
    /// The value written where the source has no pixel (must fit the sample type).
    pub nodata: f64,
    /// Append an alpha band: OPAQUE where the source had the pixel, 0 elsewhere.
    pub alpha: bool,
    /// Bilinear and bicubic read a 2 x 2 box-reduced pyramid level where the destination is more
    /// than twice coarser than the source, so they do not alias (see `prefilter`); false keeps
    /// the plain kernels everywhere. No effect at scales below 2 (bit for bit).
    pub prefilter: bool,
    /// Exact or fast source positions (see `Coordinates`).
    pub coordinates: Coordinates,
}

impl Default for WarpOptions {
    fn default() -> Self {
        Self {
            interp: Interp::Bilinear,
            nodata: 0.0,
            alpha: false,
            prefilter: true,
            coordinates: Coordinates::default(),
        }
    }
}

impl WarpOptions {
    /// The nodata value in the sample type, or an error when it does not fit.
    pub fn nodata_as<T: Sample>(&self) -> Result<T, RasterError> {
        T::from_f64_exact(self.nodata).ok_or(RasterError::InvalidNodata {
            value: self.nodata,
            sample: T::NAME,
        })
    }

    /// Bands of the destination for a source of `bands` bands.
    pub fn output_bands(&self, bands: usize) -> usize {
        bands + usize::from(self.alpha)
    }
}

/// Warps `src` into a new `size` raster; `map` gives each destination pixel's source position.
pub fn warp<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    size: ImageSize,
    opts: &WarpOptions,
) -> Result<Raster<T>, RasterError> {
    let mut dst = Raster::new(size, opts.output_bands(src.bands()))?;
    warp_into(src, map, opts, &mut dst)?;
    Ok(dst)
}

/// Warps `src` into `dst` (which fixes the output size); rows are shared out over rayon's pool.
pub fn warp_into<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
) -> Result<(), RasterError> {
    warp_into_impl(src, map, opts, dst, kernel::Build::Best)
}

/// [`warp_into`] with the portable (non-SIMD) build of the kernels, for agreement tests.
#[doc(hidden)]
pub fn warp_into_portable<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
) -> Result<(), RasterError> {
    warp_into_impl(src, map, opts, dst, kernel::Build::Portable)
}

/// [`warp_into`] with the AVX2 build alone (no AVX-512 even where the CPU has it), for
/// agreement tests.
#[doc(hidden)]
pub fn warp_into_avx2<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
) -> Result<(), RasterError> {
    warp_into_impl(src, map, opts, dst, kernel::Build::Avx2)
}

fn warp_into_impl<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
    build: kernel::Build,
) -> Result<(), RasterError> {
    let want = opts.output_bands(src.bands());
    if dst.bands() != want {
        return Err(RasterError::BandMismatch {
            got: dst.bands(),
            want,
        });
    }
    let nodata = opts.nodata_as::<T>()?;
    if src.size().pixels() > u32::MAX as usize {
        // The kernels index source pixels with u32.
        return Err(RasterError::TooLarge {
            width: src.width(),
            height: src.height(),
            bands: src.bands(),
            sample: T::NAME,
            bytes: (src.size().pixels() * std::mem::size_of::<T>()) as u128,
        });
    }
    if opts.prefilter
        && matches!(opts.interp, Interp::Bilinear | Interp::Bicubic)
        && let Some(plan) = prefilter::plan(map, dst.size(), src.size())
    {
        return prefilter::run(src, map, opts, dst, &plan, build);
    }
    dispatch(src, map, opts, nodata, dst, build);
    Ok(())
}

/// Runs `interp`'s kernel over the whole destination (no prefilter; arguments checked).
fn dispatch<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    nodata: T,
    dst: &mut Raster<T>,
    build: kernel::Build,
) {
    let g = kernel::SourceGeometry::of(src, build);
    // The AVX2 build moves the image's limits by the origin in f32: exact below 2^22 pixels.
    let small = src.width().max(src.height()) < 1 << 22;
    let fast = match opts.coordinates {
        Coordinates::Fast if small => map.projective(),
        _ => None,
    };
    let plan = kernel::RowPlan {
        map,
        fast: fast.as_ref(),
        nodata,
        alpha: opts.alpha,
    };
    match opts.interp {
        Interp::Nearest => run::<T, M, kernel::Nearest>(src, &g, &plan, dst),
        Interp::Bilinear => run::<T, M, kernel::Bilinear>(src, &g, &plan, dst),
        Interp::Bicubic => run::<T, M, kernel::Bicubic>(src, &g, &plan, dst),
        Interp::Average => area::run(src, map, nodata, opts.alpha, dst),
    }
}

/// About this many destination pixels per rayon task ...
const PIXELS_PER_TASK: usize = 32 * 1024;
/// ... and at least this many rows: a task walks its rows tile by tile (`TILE_COLS` columns),
/// so that the source pixels of a tile stay in cache from one row to the next even when the
/// destination rows cross the source at an angle (as OpenCV's warp blocks do).
const MIN_ROWS_PER_TASK: usize = 16;
const TILE_COLS: usize = 1024;

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

fn run<T: Sample, M: PixelMap, K: kernel::Kernel>(
    src: &Raster<T>,
    g: &kernel::SourceGeometry,
    plan: &kernel::RowPlan<'_, M, T>,
    dst: &mut Raster<T>,
) {
    let width = dst.width();
    let rows_per_task = (PIXELS_PER_TASK / width).max(MIN_ROWS_PER_TASK);
    row_strips(dst, rows_per_task)
        .into_par_iter()
        .enumerate()
        .for_each_init(kernel::Scratch::<K>::new, |scratch, (t, mut chunks)| {
            let first_row = t * rows_per_task;
            let rows = chunks[0].len() / width;
            for c0 in (0..width).step_by(TILE_COLS) {
                for r in 0..rows {
                    let out = kernel::RowOut {
                        chunks: &mut chunks,
                        start: r * width,
                        row: first_row + r,
                        cols: c0..(c0 + TILE_COLS).min(width),
                        alpha: plan.alpha,
                    };
                    kernel::row::<T, K, M>(src, plan, g, scratch, out);
                }
            }
        });
}

impl WarpOptions {
    /// Checks the nodata value fits the sample type of `img`.
    pub fn nodata_as_for(&self, img: &crate::AnyRaster) -> Result<(), RasterError> {
        match img {
            crate::AnyRaster::U8(_) => self.nodata_as::<u8>().map(|_| ()),
            crate::AnyRaster::U16(_) => self.nodata_as::<u16>().map(|_| ()),
            crate::AnyRaster::F32(_) => self.nodata_as::<f32>().map(|_| ()),
        }
    }
}
