//! aerorect: the geometry of airborne camera images.
//!
//! The facade joins the pure geometry (`aerorect-core`), the pixel loops (`aerorect-raster`),
//! the estimators (`aerorect-solve`) and the file adapters (`aerorect-io`) into pipelines:
//! [`rectify`], [`simulate`], [`evaluate`], the attitude-error [`sensitivity`] experiment and
//! the [`demo`].

pub mod calibration;
pub mod compare;
pub mod demo;
pub mod drone;
pub mod error;
pub mod evaluate;
pub mod gcp;
pub mod lens_compare;
pub mod motion;
pub mod rectify;
pub mod register;
pub mod report_html;
pub mod sensitivity;
pub mod simulate;
pub mod undistort;

pub use aerorect_core as core;
pub use aerorect_io as io;
pub use aerorect_raster as raster;
pub use error::Error;

use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, PixelMap, WarpOptions, warp};

/// Warps any sample type with one map (the enum is matched once, the loop is generic).
pub fn warp_any<M: PixelMap>(
    src: &AnyRaster,
    map: &M,
    size: ImageSize,
    opts: &WarpOptions,
) -> Result<AnyRaster, Error> {
    Ok(match src {
        AnyRaster::U8(r) => AnyRaster::U8(warp(r, map, size, opts)?),
        AnyRaster::U16(r) => AnyRaster::U16(warp(r, map, size, opts)?),
        AnyRaster::F32(r) => AnyRaster::F32(warp(r, map, size, opts)?),
    })
}
