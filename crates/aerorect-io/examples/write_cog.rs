//! Writes a cloud-optimised GeoTIFF from any image aerorect reads (its georeferencing kept):
//!
//! ```sh
//! cargo run --release -p aerorect-io --example write_cog -- IN.tif OUT.tif \
//!     [--tile 512] [--jpeg QUALITY] [--mask-alpha] [--nodata V] [--no-overviews] [--bigtiff]
//! ```
//!
//! `bench/check_cog.py` runs it and checks the output with GDAL (rasterio) and
//! `rio cogeo validate`.

use aerorect_io::{
    CogCompression, CogMask, CogOptions, read_georeference, read_image, write_image_cog,
};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("write_cog: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut paths: Vec<PathBuf> = Vec::new();
    let mut opts = CogOptions::default();
    let value = |args: &mut dyn Iterator<Item = String>, flag: &str| {
        args.next().ok_or_else(|| format!("{flag} needs a value"))
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--tile" => {
                opts.tile = value(&mut args, &a)?
                    .parse()
                    .map_err(|e| format!("--tile: {e}"))?
            }
            "--jpeg" => {
                let quality = value(&mut args, &a)?
                    .parse()
                    .map_err(|e| format!("--jpeg: {e}"))?;
                opts.compression = CogCompression::Jpeg { quality };
            }
            "--nodata" => {
                opts.nodata = Some(
                    value(&mut args, &a)?
                        .parse()
                        .map_err(|e| format!("--nodata: {e}"))?,
                )
            }
            "--mask-alpha" => opts.mask = CogMask::AlphaBand,
            "--no-overviews" => opts.overviews = false,
            "--bigtiff" => opts.bigtiff = Some(true),
            _ if a.starts_with("--") => return Err(format!("unknown option {a}")),
            _ => paths.push(a.into()),
        }
    }
    let [input, output] = <[PathBuf; 2]>::try_from(paths)
        .map_err(|_| "usage: write_cog IN OUT [--tile N] [--jpeg Q] [--mask-alpha] [--nodata V] [--no-overviews] [--bigtiff]".to_string())?;
    let raster = read_image(&input).map_err(|e| e.to_string())?;
    let geo = read_georeference(&input).unwrap_or(None);
    write_image_cog(&output, &raster, geo.as_ref(), &opts).map_err(|e| e.to_string())
}
