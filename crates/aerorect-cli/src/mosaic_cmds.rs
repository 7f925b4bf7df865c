//! `mosaic`: many drone photos on one grid, optionally after the flight's joint adjustment.

use crate::drone_cmds::FlightArgs;
use crate::flight_print::print_adjustment;
use crate::outputs::Files;
use aerorect::core::RectifyLimits;
use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::mosaic::{check_mosaic_name, mosaic_options, run_mosaic};
use aerorect::raster::{Interp, WarpOptions};
use anyhow::Result;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct MosaicArgs {
    /// Photos of a flight (JPEG with DJI metadata, or any image with --camera and the same tags).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The mosaic (.tif): a tiled GeoTIFF built tile by tile, or a COG with --cog.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    flight: FlightArgs,
    /// How frames meet at seamlines: feather (a cross-fade of --feather-px) or none.
    #[arg(long, default_value = "feather")]
    blend: String,
    /// Width of the cross-fade across a seam, pixels.
    #[arg(long, default_value_t = 16)]
    feather_px: usize,
    /// Resampling: nearest, bilinear, bicubic, or average (the area-weighted mean of the source
    /// pixels under each output pixel, GDAL's -r average, OpenCV's INTER_AREA).
    #[arg(long, default_value = "bilinear")]
    interp: Interp,
    /// Bilinear and bicubic: keep the plain kernel where the output is more than twice coarser
    /// than the source (by default such regions read a 2 x 2 box-reduced level, which stops aliasing).
    #[arg(long)]
    no_prefilter: bool,
    /// Largest frame ortho in pixels; a footprint reaching the horizon is clipped to it.
    #[arg(long, default_value_t = DEFAULT_MAX_OUTPUT_PX)]
    max_output_px: u64,
    /// Write a cloud-optimised GeoTIFF (composited in memory: mosaics up to 200 Mpx).
    #[arg(long)]
    cog: bool,
}

/// Everything mosaic reads and writes.
fn mosaic_files(a: &MosaicArgs) -> Files {
    let mut files = a.flight.inputs(Files::new());
    for input in &a.inputs {
        files = files.input("PHOTOS", Some(input));
    }
    files.output("--out", Some(&a.out))
}

pub fn mosaic_cmd(a: MosaicArgs) -> Result<()> {
    let mopts = mosaic_options(&a.blend, a.feather_px, a.max_output_px)?;
    mosaic_files(&a).check()?;
    aerorect::io::refuse_duplicate_photos(&a.inputs)?;
    // The output's name is checked after the files (an --out aimed at a photo is said first).
    check_mosaic_name(&a.out)?;
    let t0 = std::time::Instant::now();
    let opts = a.flight.options(
        &a.inputs,
        RectifyLimits {
            max_output_px: a.max_output_px,
        },
        WarpOptions {
            interp: a.interp,
            nodata: 0.0,
            alpha: false,
            prefilter: !a.no_prefilter,
            ..WarpOptions::default()
        },
    )?;
    let fo = a
        .flight
        .adjust
        .then(|| a.flight.flight_options())
        .transpose()?;
    let r = run_mosaic(
        &a.inputs,
        &a.out,
        (&opts, &mopts, a.cog),
        fo.as_ref(),
        |flight| print_adjustment(&flight.report),
    )?;
    outln!(
        "{} frames -> {}: {} x {} px at {:.3} m/px, {} tiles{}, {:.2} s",
        r.frames.len(),
        display(&a.out),
        r.size[0],
        r.size[1],
        r.gsd_m,
        r.tiles,
        if a.cog { ", cloud-optimised" } else { "" },
        t0.elapsed().as_secs_f64()
    );
    for f in r.frames.iter().filter(|f| f.cells == 0) {
        eprintln!("warning: {}: no cell of the mosaic comes from it", f.path);
    }
    Ok(())
}

fn display(p: &Path) -> String {
    p.display().to_string()
}
