//! aerorect: the geometry of airborne camera images.
//!
//! The facade joins the pure geometry (`aerorect-core`), the pixel loops (`aerorect-raster`),
//! the estimators (`aerorect-solve`), georeferencing (`aerorect-geo`) and the file adapters
//! (`aerorect-io`) into pipelines, a folder per job: georeferenced orthos of photos
//! ([`ortho`]), a flight made consistent from its overlaps ([`flight`]), the [`mosaic`],
//! image motion ([`motion`]), lens calibration and undistortion ([`lens`]), and the paper's
//! method and experiments as published ([`paper`]). What a front end asks for is checked in
//! [`options`]. Each layer is also re-exported whole (`aerorect::core`, `aerorect::raster`,
//! `aerorect::solve`, `aerorect::io`, `aerorect::geo`), so the front ends (the CLI, the Python
//! package) depend on this crate alone.

pub mod error;
pub mod flight;
pub mod lens;
pub mod memory;
pub mod mosaic;
pub mod motion;
pub mod options;
pub mod ortho;
pub mod paper;
pub mod sane;

// Each module also by its short path (`aerorect::drone`, `aerorect::rectify`), as the front
// ends, examples and tests name them.
pub use flight::sift as features;
pub use lens::{calibration, undistort};
pub(crate) use ortho::drone_options;
pub use ortho::{batch, drone, georef, overlap, photo_source, report_html};
pub use paper::{
    compare, demo, evaluate, gcp, lens_compare, rectify, register, sensitivity, simulate,
};

pub use aerorect_core as core;
pub use aerorect_geo as geo;
pub use aerorect_io as io;
pub use aerorect_raster as raster;
pub use aerorect_solve as solve;
pub use error::Error;

use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, PixelMap, WarpOptions, warp};

/// Refuses an image that is not the size a plan (or its camera, `of`) was made for.
pub(crate) fn check_input_size(
    input: &AnyRaster,
    planned: ImageSize,
    of: &str,
) -> Result<(), Error> {
    let got = input.size();
    if got == planned {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "the image is {} x {} but the {of} is for {} x {}",
        got.width, got.height, planned.width, planned.height
    )))
}

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

/// The integer grid from floor(min) to ceil(max) of `map` over `points`: its origin and its
/// width and height (as f64, for the caller's own size check). `Err(p)`: the first point `map`
/// has no image for.
pub(crate) fn covering_grid(
    points: impl IntoIterator<Item = [f64; 2]>,
    map: impl Fn([f64; 2]) -> Option<[f64; 2]>,
) -> Result<([f64; 2], [f64; 2]), [f64; 2]> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points {
        let q = map(p).ok_or(p)?;
        for d in 0..2 {
            lo[d] = lo[d].min(q[d]);
            hi[d] = hi[d].max(q[d]);
        }
    }
    let origin = [lo[0].floor(), lo[1].floor()];
    Ok((
        origin,
        [
            hi[0].ceil() - origin[0] + 1.0,
            hi[1].ceil() - origin[1] + 1.0,
        ],
    ))
}
