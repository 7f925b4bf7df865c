//! The warp engine: inverse mapping with nearest, bilinear or bicubic (Keys, a = -0.5) sampling,
//! or area averaging (`area`); bilinear and bicubic read a box-reduced pyramid level where the
//! destination is more than twice coarser than the source (`prefilter`); `levels` keeps those
//! levels between warps of one image.
//!
//! Sampling convention: a source position (x, y) is inside the image when
//! -0.5 <= x < W - 0.5 and -0.5 <= y < H - 0.5 (the pixel footprints); inside, neighbours past
//! the edge repeat the edge pixel. Outside, the destination gets the nodata value and, when asked,
//! a zero in the alpha band (which is OPAQUE where valid).
//!
//! Layout: the public API here and in `options`; `dispatch` picks the kernel and shares rows
//! out; `types` holds what the dispatcher and the kernels share; `portable` is the portable
//! build, one file per kernel; `simd` picks the build for each row and holds the AVX2 and
//! AVX-512 builds, one file per kernel (its docs, `SIMD.md`, are the SIMD notes).

mod area;
mod block;
mod dispatch;
mod levels;
mod options;
mod portable;
mod prefilter;
mod relative;
mod scratch;
mod simd;
mod types;

use crate::error::RasterError;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::ImageSize;
use dispatch::dispatch;
use types::Build;

pub use levels::{ReducedLevels, warp_levels};
pub use options::{Coordinates, Interp, WarpOptions};
pub use portable::keys_weights;
pub use relative::FAST_MAX_ERROR;

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
    warp_into_impl(src, map, opts, dst, Build::Best)
}

/// [`warp_into`] with the portable (non-SIMD) build of the kernels, for agreement tests.
#[doc(hidden)]
pub fn warp_into_portable<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
) -> Result<(), RasterError> {
    warp_into_impl(src, map, opts, dst, Build::Portable)
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
    warp_into_impl(src, map, opts, dst, Build::Avx2)
}

fn warp_into_impl<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
    build: Build,
) -> Result<(), RasterError> {
    let want = opts.output_bands(src.bands());
    if dst.bands() != want {
        return Err(RasterError::BandMismatch {
            got: dst.bands(),
            want,
        });
    }
    let nodata = opts.nodata_as::<T>()?;
    source_fits::<T>(src.size(), src.bands())?;
    if prefilter::applies(opts)
        && let Some(plan) = prefilter::plan(map, dst.size(), src.size())
    {
        return prefilter::run(src, map, opts, dst, &plan, build);
    }
    dispatch(src, map, opts, nodata, dst, build);
    Ok(())
}

/// Refuses a source of more than 2^32 pixels: the kernels index source pixels with u32.
fn source_fits<T: Sample>(size: ImageSize, bands: usize) -> Result<(), RasterError> {
    if size.pixels() <= u32::MAX as usize {
        return Ok(());
    }
    Err(RasterError::TooLarge {
        width: size.width,
        height: size.height,
        bands,
        sample: T::NAME,
        bytes: (size.pixels() * std::mem::size_of::<T>()) as u128,
    })
}
