//! TIFF formats beyond the fixtures: GDAL's JPEG-compressed YCbCr (the NGI frames) checked
//! against GDAL's own decode, BigTIFF, and EXIF/XMP/GDAL metadata carried in TIFF tags.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_io::{read_image, read_photo_metadata};
use aerorect_raster::AnyRaster;
use aerorect_testkit::shared_data;
use tiff::encoder::{Rational, TiffEncoder, colortype};
use tiff::tags::Tag;

#[test]
fn ngi_jpeg_ycbcr_frame_decodes_as_gdal_decodes_it() {
    let Some(p) = shared_data("ngi/3324c_2015_1004_05_0182_RGB.tif") else {
        return;
    };
    let AnyRaster::U8(r) = read_image(&p).unwrap() else {
        panic!("expected u8");
    };
    assert_eq!((r.size(), r.bands()), (ImageSize::new(640, 1152), 3));
    // rasterio 1.4 (GDAL 3.10, libjpeg-turbo) `src.read()[:, row, col]`. The decoders upsample
    // the 2x2-subsampled chroma differently: over the frame the mean difference is 0.4 levels,
    // 98% of samples are within 2, and the largest (21) sit on sharp colour edges; so single
    // pixels away from edges are checked to 2 levels and 16 x 16 block means to 1.
    for (c, rw, rgb) in [
        (100, 100, [125, 129, 140]),
        (300, 500, [89, 93, 105]),
        (600, 1100, [96, 97, 102]),
        (0, 0, [136, 139, 156]),
        (500, 200, [142, 157, 154]),
    ] {
        for (b, want) in rgb.into_iter().enumerate() {
            let got = r.get(b, c, rw).unwrap();
            assert!(
                (i32::from(got) - want).abs() <= 2,
                "({c}, {rw}) band {b}: {got} vs GDAL {want}"
            );
        }
    }
    // numpy `src.read()[:, r:r+16, c:c+16].mean(axis=(1, 2))`.
    for (c, rw, means) in [
        (96, 96, [162.488, 165.598, 160.102]),
        (288, 496, [94.242, 98.406, 108.125]),
        (592, 1088, [92.324, 94.098, 98.039]),
        (320, 576, [118.855, 116.484, 117.297]),
    ] {
        for (b, want) in means.into_iter().enumerate() {
            let sum: f64 = (rw..rw + 16)
                .flat_map(|y| (c..c + 16).map(move |x| (x, y)))
                .map(|(x, y)| f64::from(r.get(b, x, y).unwrap()))
                .sum();
            let got = sum / 256.0;
            assert!(
                (got - want).abs() < 1.0,
                "block ({c}, {rw}) band {b}: {got} vs GDAL {want}"
            );
        }
    }
}

#[test]
fn bigtiff_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.tif");
    let data: Vec<u16> = (0..5 * 4 * 3).map(|i| i * 1000).collect();
    let mut enc = TiffEncoder::new_big(std::fs::File::create(&p).unwrap()).unwrap();
    enc.write_image::<colortype::RGB16>(5, 4, &data).unwrap();
    drop(enc);
    assert_eq!(&std::fs::read(&p).unwrap()[..4], b"II+\0");
    let AnyRaster::U16(r) = read_image(&p).unwrap() else {
        panic!("expected u16");
    };
    assert_eq!((r.size(), r.bands()), (ImageSize::new(5, 4), 3));
    assert_eq!(r.to_interleaved(), data);
}

const XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GimbalPitchDegree="-90.00" drone-dji:GimbalYawDegree="+12.50" drone-dji:RelativeAltitude="+80.10"/></rdf:RDF></x:xmpmeta>"#;

#[test]
fn tiff_tag_700_xmp_and_the_exif_ifd_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("exif.tif");
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
    let mut exif = enc.extra_directory().unwrap();
    exif.write_tag(Tag::Unknown(37386), Rational { n: 473, d: 100 })
        .unwrap(); // FocalLength
    exif.write_tag(Tag::Unknown(41989), 26u16).unwrap(); // FocalLengthIn35mmFilm
    exif.write_tag(Tag::Unknown(40962), 4000u32).unwrap(); // PixelXDimension
    exif.write_tag(Tag::Unknown(40963), 2250u32).unwrap(); // PixelYDimension
    let exif_at = exif.finish_with_offsets().unwrap();
    let mut img = enc.new_image::<colortype::Gray8>(2, 2).unwrap();
    let e = img.encoder();
    e.write_tag(Tag::Unknown(271), "DJI").unwrap(); // Make
    e.write_tag(Tag::Unknown(272), "FC220").unwrap(); // Model
    e.write_tag(Tag::Unknown(34665), exif_at.offset).unwrap(); // ExifIFD
    e.write_tag(Tag::Unknown(700), XMP.as_bytes()).unwrap(); // XMP
    img.write_data(&[0u8; 4]).unwrap();
    drop(enc);
    let m = read_photo_metadata(&p).unwrap();
    assert_eq!(
        (m.make.as_deref(), m.model.as_deref()),
        (Some("DJI"), Some("FC220"))
    );
    assert_eq!(
        (m.focal_length_mm, m.focal_length_35mm),
        (Some(4.73), Some(26.0))
    );
    assert_eq!((m.width, m.height), (Some(4000), Some(2250)));
    assert_eq!(m.dji.gimbal_pitch_deg, Some(-90.0));
    assert_eq!(m.dji.gimbal_yaw_deg, Some(12.5));
    assert_eq!(m.dji.relative_altitude_m, Some(80.1));
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn gdal_metadata_tiff(path: &std::path::Path, items: &str) {
    let xml = format!("<GDALMetadata>\n{items}</GDALMetadata>\n");
    let mut enc = TiffEncoder::new(std::fs::File::create(path).unwrap()).unwrap();
    let mut img = enc.new_image::<colortype::Gray8>(2, 2).unwrap();
    img.encoder()
        .write_tag(Tag::Unknown(42112), xml.as_str())
        .unwrap();
    img.write_data(&[0u8; 4]).unwrap();
}

#[test]
fn gdal_metadata_exif_items_and_xmp_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gdal.tif");
    // As GDAL writes a JPEG's EXIF into a GeoTIFF: rationals in brackets, DMS as three.
    let items = format!(
        r#"  <Item name="EXIF_FocalLength">(4.73)</Item>
  <Item name="EXIF_FocalLengthIn35mmFilm">26</Item>
  <Item name="EXIF_Make">DJI</Item>
  <Item name="EXIF_Model">FC220</Item>
  <Item name="EXIF_PixelXDimension">4000</Item>
  <Item name="EXIF_PixelYDimension">2250</Item>
  <Item name="EXIF_GPSLatitude">(53) (54) (1.2)</Item>
  <Item name="EXIF_GPSLatitudeRef">S</Item>
  <Item name="EXIF_GPSLongitude">(27) (33) (36)</Item>
  <Item name="EXIF_GPSLongitudeRef">W</Item>
  <Item name="EXIF_GPSAltitude">(312.5)</Item>
  <Item name="XMP" domain="xml:XMP">{}</Item>
"#,
        escape(XMP)
    );
    gdal_metadata_tiff(&p, &items);
    let m = read_photo_metadata(&p).unwrap();
    assert_eq!(
        (m.make.as_deref(), m.model.as_deref()),
        (Some("DJI"), Some("FC220"))
    );
    assert_eq!(
        (m.focal_length_mm, m.focal_length_35mm),
        (Some(4.73), Some(26.0))
    );
    assert_eq!((m.width, m.height), (Some(4000), Some(2250)));
    let lat = m.latitude_deg.unwrap();
    assert!(
        (lat + (53.0 + 54.0 / 60.0 + 1.2 / 3600.0)).abs() < 1e-12,
        "{lat}"
    );
    assert!((m.longitude_deg.unwrap() + 27.56).abs() < 1e-12);
    assert_eq!(m.gps_altitude_m, Some(312.5));
    assert_eq!(m.dji.gimbal_yaw_deg, Some(12.5));

    let bad = dir.path().join("bad.tif");
    gdal_metadata_tiff(&bad, r#"<Item name="EXIF_FocalLength">(4,73)</Item>"#);
    let e = read_photo_metadata(&bad).unwrap_err().to_string();
    assert!(
        e.contains("bad.tif") && e.contains("EXIF_FocalLength = '(4,73)'"),
        "{e}"
    );
}
