//! Mosaic of drone photos from their metadata (flat ground at the take-off height):
//! `cargo run --release -p aerorect --example mosaic_photos -- OUT.tif [--gsd-m G] PHOTO...`
use aerorect::drone::DroneOptions;
use aerorect::mosaic::{MosaicOptions, frames_from_photos, mosaic};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut opts = DroneOptions::default();
    if let Some(i) = args.iter().position(|a| a == "--gsd-m") {
        opts.gsd_m = Some(args.get(i + 1).ok_or("--gsd-m needs a value")?.parse()?);
        args.drain(i..i + 2);
    }
    let (out, photos) = args
        .split_first()
        .ok_or("usage: OUT.tif [--gsd-m G] PHOTO...")?;
    let photos: Vec<PathBuf> = photos.iter().map(PathBuf::from).collect();
    let t = std::time::Instant::now();
    let (frames, crs) = frames_from_photos(&photos, &opts)?;
    println!(
        "planned {} frames in {:.2} s",
        frames.len(),
        t.elapsed().as_secs_f64()
    );
    let report = mosaic(frames, crs, out.as_ref(), &MosaicOptions::default())?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
