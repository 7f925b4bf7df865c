//! `mosaic` as a front end asks for it: the options by name, checked, and the whole run (the
//! frames planned, or adjusted first, then composited into one GeoTIFF or COG).

use super::{Blend, MosaicFrame, MosaicOptions, MosaicReport, frames_from_photos};
use super::{mosaic_cog_with, mosaic_with};
use crate::Error;
use crate::drone::DroneOptions;
use crate::flight::{AdjustedFlight, FlightOptions, adjust_flight_for};
use crate::options::OptionError;
use aerorect_raster::AnyRaster;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The mosaic's options: `blend` by name (feather, none), the seam's cross-fade, the largest
/// frame ortho.
pub fn mosaic_options(
    blend: &str,
    feather_px: usize,
    max_output_px: u64,
) -> Result<MosaicOptions, Error> {
    let blend: Blend = blend.parse().map_err(Error::Invalid)?;
    let m = MosaicOptions {
        blend,
        feather_px,
        max_output_px,
        ..MosaicOptions::default()
    };
    m.validate()?;
    Ok(m)
}

/// Refuses a mosaic name that is not a GeoTIFF's (`.tif`, `.tiff`).
pub fn check_mosaic_name(out: &Path) -> Result<(), Error> {
    let ext = out.extension().and_then(|e| e.to_str());
    if ext.is_some_and(|e| e.eq_ignore_ascii_case("tif") || e.eq_ignore_ascii_case("tiff")) {
        return Ok(());
    }
    let why = Error::Invalid("the mosaic is a GeoTIFF: give a .tif or .tiff name".into());
    Err(OptionError::value("out", out.display(), why).into())
}

/// The mosaic of `inputs` written to `out` (a COG when `cog`): each frame planned from `opts`
/// (see [`frame_options`]), or with `flight` the flight adjusted first (`adjusted` sees it
/// before any tile is made).
pub fn run_mosaic(
    inputs: &[PathBuf],
    out: &Path,
    (opts, mopts, cog): (&DroneOptions, &MosaicOptions, bool),
    flight: Option<&FlightOptions>,
    adjusted: impl FnOnce(&AdjustedFlight),
) -> Result<MosaicReport, Error> {
    let Some(fo) = flight else {
        let (frames, crs) = frames_from_photos(inputs, &frame_options(opts))?;
        let decode = |f: &MosaicFrame| Ok(aerorect_io::read_image(&f.path)?);
        return write((frames, crs), out, (mopts, cog), decode);
    };
    let f = adjust_flight_for(inputs, &frame_options(opts), fo, false)?;
    adjusted(&f);
    mosaic_adjusted(&f, out, (opts, mopts, cog))
}

/// The mosaic of an adjusted flight's frames, each with its adjusted orientation.
pub fn mosaic_adjusted(
    flight: &AdjustedFlight,
    out: &Path,
    (opts, mopts, cog): (&DroneOptions, &MosaicOptions, bool),
) -> Result<MosaicReport, Error> {
    let frames = flight.mosaic_frames(&frame_options(opts))?;
    // The photos the rounds kept are handed over, not decoded again.
    let load = |f: &MosaicFrame| flight.photo(&f.path);
    write((frames, flight.crs().clone()), out, (mopts, cog), load)
}

/// The options a mosaic plans its frames with: `opts` without nodata, alpha or COG (the
/// mosaic's alpha band marks coverage, and the mosaic itself is the COG).
pub fn frame_options(opts: &DroneOptions) -> DroneOptions {
    let mut o = opts.clone();
    o.warp.nodata = 0.0;
    o.warp.alpha = false;
    o.cog = None;
    o
}

/// The mosaic of `frames` written to `out` (a COG when `cog`), each frame's image from `load`.
fn write<R: Into<Arc<AnyRaster>>>(
    (frames, crs): (Vec<MosaicFrame>, aerorect_geo::Crs),
    out: &Path,
    (mopts, cog): (&MosaicOptions, bool),
    load: impl Fn(&MosaicFrame) -> Result<R, Error> + Sync,
) -> Result<MosaicReport, Error> {
    if cog {
        let c = aerorect_io::CogOptions::masked_by_alpha(mopts.alpha);
        mosaic_cog_with(frames, crs, out, (mopts, &c), load)
    } else {
        mosaic_with(frames, crs, out, mopts, load)
    }
}
