//! Pixel buffers and everything that loops over pixels.
//!
//! Buffers are planar ([`Raster`]: one `Vec<T>` per band, row-major). The warp engine maps every
//! destination pixel to a source position through a [`PixelMap`] (f64 coordinates, or for a
//! homography f32 offsets within a tested 5e-4 px of them: [`Coordinates`]; no fixed-point
//! tables) and samples it with a kernel chosen once per call.

pub mod chessboard;
mod cpu;
pub mod error;
pub mod features;
pub mod map;
pub mod pyramid;
pub mod raster;
mod sample_kind;
pub mod shift;
pub mod warp;

pub use error::RasterError;
pub use map::{LensDirection, LensMap, PixelMap, Then};
pub use raster::{AnyRaster, Raster, Sample, SampleKind};
pub use warp::{
    Coordinates, Interp, ReducedLevels, WarpOptions, warp, warp_into, warp_into_avx2,
    warp_into_portable, warp_levels,
};
