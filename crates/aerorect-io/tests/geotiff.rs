//! GeoTIFF tags read back through the tiff crate's own tag API, and the world file.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_io::{Crs, GeoReference, read_georeference, read_image, write_image_geo};
use aerorect_raster::{AnyRaster, Raster};
use tiff::decoder::Decoder;
use tiff::tags::Tag;

fn geo() -> GeoReference {
    GeoReference {
        crs: Crs::Epsg(32635),
        pixel_size: [0.25, 0.25],
        top_left: [500_123.5, 5_975_432.25],
        rotation: [0.0, 0.0],
        nodata: Some(0.0),
    }
}

#[test]
fn geotiff_tags_are_the_geotiff_spec_values() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.tif");
    let img =
        AnyRaster::U8(Raster::from_planes(ImageSize::new(7, 5), vec![vec![9u8; 35]]).unwrap());
    write_image_geo(&p, &img, Some(&geo())).unwrap();
    let mut dec = Decoder::new(std::fs::File::open(&p).unwrap()).unwrap();
    assert_eq!(
        dec.get_tag_f64_vec(Tag::Unknown(33550)).unwrap(),
        [0.25, 0.25, 0.0]
    );
    assert_eq!(
        dec.get_tag_f64_vec(Tag::Unknown(33922)).unwrap(),
        [0.0, 0.0, 0.0, 500_123.5, 5_975_432.25, 0.0]
    );
    let keys = dec.get_tag_u16_vec(Tag::Unknown(34735)).unwrap();
    // Header 1.1.0 with 4 keys; projected; PixelIsArea; EPSG 32635; metres.
    assert_eq!(
        keys,
        [
            1, 1, 0, 4, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32635, 3076, 0, 1, 9001
        ]
    );
    assert_eq!(
        dec.get_tag_ascii_string(Tag::Unknown(42113))
            .unwrap()
            .trim_matches('\0'),
        "0"
    );
    assert_eq!(read_georeference(&p).unwrap(), Some(geo()));
    assert_eq!(read_image(&p).unwrap().plane_f32(0), vec![9.0; 35]);
}

#[test]
fn png_gets_a_world_file_with_the_pixel_centre() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g.png");
    let img = AnyRaster::U8(Raster::from_planes(ImageSize::new(3, 2), vec![vec![1u8; 6]]).unwrap());
    write_image_geo(&p, &img, Some(&geo())).unwrap();
    let w = std::fs::read_to_string(dir.path().join("g.pgw")).unwrap();
    let v: Vec<f64> = w.lines().map(|l| l.parse().unwrap()).collect();
    assert_eq!(v.len(), 6);
    assert_eq!((v[0], v[1], v[2], v[3]), (0.25, 0.0, 0.0, -0.25));
    assert!((v[4] - 500_123.625).abs() < 1e-6 && (v[5] - 5_975_432.125).abs() < 1e-6);
}
