//! The I/O stages of `rectify` on one drone frame: decoding a 4000 x 2250 JPEG (the DJI frame
//! ../shared/data/drone-xmp/DJI_0010.JPG when present, else a textured scene encoded to JPEG
//! here) and writing a 4000 x 2250 RGB GeoTIFF (that frame's pixels): the parallel strip
//! writer beside the `tiff` crate's encoder as aerorect used it before (one interleaved copy,
//! Deflate level 1 on one thread).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::{GeoReference, read_image, write_image_geo};
use aerorect_raster::AnyRaster;
use criterion::{Criterion, criterion_group, criterion_main};
use std::path::PathBuf;

/// The frame to decode: the DJI photo, or a synthetic one written to `dir`.
fn frame_jpeg(dir: &std::path::Path) -> PathBuf {
    let dji = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/drone-xmp/DJI_0010.JPG");
    if dji.exists() {
        return dji;
    }
    let scene = aerorect_testkit::textured_scene::<u8>(ImageSize::new(4000, 2250), 3, 255.0, 7);
    let path = dir.join("scene.jpg");
    image::RgbImage::from_raw(4000, 2250, scene.to_interleaved())
        .unwrap()
        .save(&path)
        .unwrap();
    path
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let jpeg = frame_jpeg(dir.path());
    let mut g = c.benchmark_group("frame_io 4000x2250 rgb");
    g.sample_size(10);
    g.bench_function("decode jpeg (read_image)", |b| {
        b.iter(|| read_image(&jpeg).unwrap())
    });
    let raster = read_image(&jpeg).unwrap();
    let geo = GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
        pixel_size: [0.03, 0.03],
        top_left: [537_789.9, 5_974_732.8],
        rotation: [0.0, 0.0],
        nodata: Some(0.0),
    };
    let out = dir.path().join("out.tif");
    g.bench_function(
        "geotiff write (parallel strips, predictor + fdeflate)",
        |b| b.iter(|| write_image_geo(&out, &raster, Some(&geo)).unwrap()),
    );
    let AnyRaster::U8(r) = &raster else {
        panic!("an 8-bit frame")
    };
    let old = dir.path().join("old.tif");
    g.bench_function(
        "tiff write (tiff crate, deflate level 1, previous writer)",
        |b| {
            b.iter(|| {
                use tiff::encoder::{Compression, DeflateLevel, TiffEncoder, colortype};
                let f = std::io::BufWriter::new(std::fs::File::create(&old).unwrap());
                let mut enc = TiffEncoder::new(f)
                    .unwrap()
                    .with_compression(Compression::Deflate(DeflateLevel::Fast));
                enc.write_image::<colortype::RGB8>(
                    r.width() as u32,
                    r.height() as u32,
                    &r.to_interleaved(),
                )
                .unwrap();
            })
        },
    );
    g.finish();
    eprintln!(
        "file sizes: parallel strips {} bytes, previous writer {} bytes",
        std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0),
        std::fs::metadata(&old).map(|m| m.len()).unwrap_or(0)
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
