//! Image files: fixtures decoded to their generating formulas, write/read round trips, bad files.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_io::{read_image, read_image_size, write_image};
use aerorect_raster::{AnyRaster, Raster};
use aerorect_testkit::textured_scene;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name)
}

fn check_formula<T: aerorect_raster::Sample>(r: &Raster<T>, f: impl Fn(usize, usize, usize) -> T) {
    assert_eq!(r.size(), ImageSize::new(64, 48));
    for b in 0..r.bands() {
        for y in 0..48 {
            for x in 0..64 {
                assert_eq!(r.get(b, x, y).unwrap(), f(b, x, y), "band {b} ({x}, {y})");
            }
        }
    }
}

#[test]
fn tiled_and_stripped_lzw_deflate_tiffs_decode_to_their_formulas() {
    match read_image(&data("fixtures/tiled_lzw_rgb16.tif")).unwrap() {
        AnyRaster::U16(r) => {
            assert_eq!(r.bands(), 3);
            check_formula(&r, |b, x, y| ((x * 31 + y * 7 + b * 1000) % 65536) as u16);
        }
        other => panic!("expected u16, got {}", other.sample_name()),
    }
    match read_image(&data("fixtures/tiled_deflate_rgba8.tif")).unwrap() {
        AnyRaster::U8(r) => {
            assert_eq!(r.bands(), 4);
            check_formula(&r, |b, x, y| ((x * 3 + y * 5 + b * 40) % 256) as u8);
        }
        other => panic!("expected u8, got {}", other.sample_name()),
    }
    match read_image(&data("fixtures/strips_deflate_gray32f.tif")).unwrap() {
        AnyRaster::F32(r) => check_formula(&r, |_, x, y| x as f32 * 0.5 - y as f32 * 0.25),
        other => panic!("expected f32, got {}", other.sample_name()),
    }
    match read_image(&data("fixtures/strips_lzw_gray8.tif")).unwrap() {
        AnyRaster::U8(r) => check_formula(&r, |_, x, y| ((x * 3 + y * 5) % 256) as u8),
        other => panic!("expected u8, got {}", other.sample_name()),
    }
}

fn round_trip(dir: &Path, name: &str, img: AnyRaster) {
    let p = dir.join(name);
    write_image(&p, &img).unwrap();
    assert_eq!(read_image(&p).unwrap(), img, "{name}");
    assert_eq!(read_image_size(&p).unwrap(), img.size(), "{name}");
}

#[test]
fn tiff_and_png_round_trips_keep_depth_and_bands() {
    let dir = tempfile::tempdir().unwrap();
    let size = ImageSize::new(37, 23);
    for bands in 1..=4 {
        round_trip(
            dir.path(),
            &format!("u8_{bands}.tif"),
            AnyRaster::U8(textured_scene(size, bands, 255.0, 1)),
        );
        round_trip(
            dir.path(),
            &format!("u16_{bands}.tif"),
            AnyRaster::U16(textured_scene(size, bands, 65535.0, 2)),
        );
        round_trip(
            dir.path(),
            &format!("f32_{bands}.tiff"),
            AnyRaster::F32(textured_scene(size, bands, 3.5, 3)),
        );
        round_trip(
            dir.path(),
            &format!("u8_{bands}.png"),
            AnyRaster::U8(textured_scene(size, bands, 255.0, 4)),
        );
        round_trip(
            dir.path(),
            &format!("u16_{bands}.png"),
            AnyRaster::U16(textured_scene(size, bands, 65535.0, 5)),
        );
    }
}

#[test]
fn jpeg_reads_as_rgb8() {
    let img = read_image(&data("aero1.jpg")).unwrap();
    assert_eq!(
        (img.size(), img.bands(), img.sample_name()),
        (ImageSize::new(640, 480), 3, "u8")
    );
}

/// 8-bit images are decoded into kept buffers, handed from one decode to the next: each read,
/// on any thread and after images of other sizes and bands, gives its own pixels (the PNGs
/// their written rasters, the JPEG the image crate's own decode).
#[test]
fn reads_into_kept_buffers_give_each_image_its_own_pixels() {
    use rayon::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let images: Vec<(PathBuf, AnyRaster)> = [(61, 47, 3), (9, 5, 1), (64, 40, 4), (33, 71, 2)]
        .iter()
        .enumerate()
        .map(|(k, &(w, h, bands))| {
            let img = AnyRaster::U8(textured_scene(
                ImageSize::new(w, h),
                bands,
                255.0,
                7 + k as u64,
            ));
            let p = dir.path().join(format!("{k}.png"));
            write_image(&p, &img).unwrap();
            (p, img)
        })
        .collect();
    let jpeg = data("aero1.jpg");
    let rgb = image::open(&jpeg).unwrap().to_rgb8();
    let planes = (0..3)
        .map(|b| rgb.as_raw().iter().skip(b).step_by(3).copied().collect())
        .collect();
    let want_jpeg = AnyRaster::U8(Raster::from_planes(ImageSize::new(640, 480), planes).unwrap());
    (0..40).into_par_iter().for_each(|i| {
        if i % 5 == 4 {
            assert_eq!(read_image(&jpeg).unwrap(), want_jpeg, "read {i}");
        } else {
            let (p, img) = &images[(i * 3) % images.len()];
            assert_eq!(&read_image(p).unwrap(), img, "read {i}: {}", p.display());
        }
    });
}

#[test]
fn header_sizes_equal_the_decoded_sizes() {
    for name in [
        "aero1.jpg",
        "fixtures/tiled_lzw_rgb16.tif",
        "fixtures/strips_deflate_gray32f.tif",
    ] {
        let p = data(name);
        assert_eq!(
            read_image_size(&p).unwrap(),
            read_image(&p).unwrap().size(),
            "{name}"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("notes.txt");
    std::fs::write(&p, "hello, not an image").unwrap();
    let e = read_image_size(&p).unwrap_err().to_string();
    assert!(e.contains("notes.txt"), "{e}");
}

#[test]
fn truncated_and_foreign_files_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    for (src, name) in [
        ("fixtures/tiled_lzw_rgb16.tif", "cut.tif"),
        ("aero1.jpg", "cut.jpg"),
    ] {
        let bytes = std::fs::read(data(src)).unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, &bytes[..bytes.len() / 3]).unwrap();
        let e = match read_image(&p) {
            Ok(_) => panic!("truncated {name} was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(name), "{e}");
    }
    let p = dir.path().join("notes.txt");
    std::fs::write(&p, "hello, not an image").unwrap();
    let e = read_image(&p).unwrap_err().to_string();
    assert!(
        e.contains("notes.txt") && e.contains("not a PNG, JPEG or TIFF"),
        "{e}"
    );
    let e = read_image(&dir.path().join("missing.tif"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.tif"), "{e}");
}

#[test]
fn a_failed_write_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let img = AnyRaster::F32(textured_scene(ImageSize::new(8, 8), 1, 1.0, 1));
    let p = dir.path().join("out.png");
    let e = write_image(&p, &img).unwrap_err().to_string();
    assert!(e.contains("out.png") && e.contains("float"), "{e}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no output and no temporary file"
    );
    let e = write_image(&dir.path().join("out.bmp"), &img)
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown output format"), "{e}");
}

#[test]
fn real_sipi_tiffs_from_shared_data() {
    let Some(dir) = aerorect_testkit::shared_data("aerial") else {
        return;
    };
    let gray = read_image(&dir.join("sipi_5.3.02.tiff")).unwrap();
    assert_eq!((gray.size(), gray.bands()), (ImageSize::new(1024, 1024), 1));
    let rgb = read_image(&dir.join("sipi_2.1.01.tiff")).unwrap();
    assert_eq!((rgb.size(), rgb.bands()), (ImageSize::new(512, 512), 3));
    let geo = read_image(&dir.join("rasterio_RGB.byte.tif")).unwrap();
    assert_eq!((geo.size(), geo.bands()), (ImageSize::new(791, 718), 3));
}
