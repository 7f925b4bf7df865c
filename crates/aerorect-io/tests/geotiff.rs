//! GeoTIFF tags read back through the tiff crate's own tag API, and the world file.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::{GeoReference, read_georeference, read_image, write_image_geo};
use aerorect_raster::{AnyRaster, Raster};
use tiff::decoder::Decoder;
use tiff::tags::Tag;

fn geo() -> GeoReference {
    GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
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

/// The NGI DEM's CRS: a WKT transverse Mercator (lon_0 25) with a vertical part, no EPSG code.
const LO25_WKT: &str = r#"COMPD_CS["Lo25 WGS84 + EGM2008 height",PROJCS["Lo25 WGS84 + EGM2008 height",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563,AUTHORITY["EPSG","7030"]],AUTHORITY["EPSG","6326"]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433,AUTHORITY["EPSG","9122"]],AUTHORITY["EPSG","4326"]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",25],PARAMETER["scale_factor",1],PARAMETER["false_easting",0],PARAMETER["false_northing",0],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Easting",EAST],AXIS["Northing",NORTH]],VERT_CS["EGM2008 height",VERT_DATUM["EGM2008 geoid",2005,AUTHORITY["EPSG","1027"]],UNIT["metre",1,AUTHORITY["EPSG","9001"]],AXIS["Up",UP]]]"#;

/// One CRS of each kind. Files written with these were opened with rasterio 1.4 (GDAL 3.10):
/// every GeoTIFF and every PNG (through its .png.aux.xml; GDAL ignores a .prj beside a PNG)
/// had the geotransform written and a CRS projecting (24.4 E, 33.7 S) to within 1e-6 m of
/// pyproj's projection through the CRS written.
fn crs_of_each_kind() -> Vec<Crs> {
    vec![
        Crs::from_epsg(32735).unwrap(),
        Crs::from_epsg(4326).unwrap(),
        Crs::from_wkt(LO25_WKT).unwrap(),
        Crs::from_proj_string(
            "+proj=tmerc +lat_0=0 +lon_0=25 +k=1 +x_0=0 +y_0=0 +datum=WGS84 +units=m",
        )
        .unwrap(),
        Crs::from_proj_string("+proj=utm +zone=34 +south +ellps=GRS80 +units=m").unwrap(),
    ]
}

fn same_projection(a: &Crs, b: &Crs) {
    let p = a.from_lon_lat(24.4, -33.7).unwrap();
    let q = b.from_lon_lat(24.4, -33.7).unwrap();
    assert!(
        (p[0] - q[0]).abs() < 1e-6 && (p[1] - q[1]).abs() < 1e-6,
        "{a} -> {p:?}, {b} -> {q:?}"
    );
}

#[test]
fn geotiffs_of_any_crs_read_back_as_the_same_projection() {
    let dir = tempfile::tempdir().unwrap();
    let img =
        AnyRaster::U8(Raster::from_planes(ImageSize::new(4, 3), vec![vec![7u8; 12]]).unwrap());
    for (i, crs) in crs_of_each_kind().into_iter().enumerate() {
        let g = GeoReference {
            crs: crs.clone(),
            ..geo()
        };
        let p = dir.path().join(format!("{i}.tif"));
        write_image_geo(&p, &img, Some(&g)).unwrap();
        let back = read_georeference(&p).unwrap().unwrap();
        assert_eq!(back.geotransform(), g.geotransform());
        assert_eq!(back.crs.epsg(), crs.epsg());
        same_projection(&crs, &back.crs);
    }
    // A rotated grid (an NGI frame's) is written as ModelTransformation and read back.
    let g = GeoReference {
        pixel_size: [-5.639, 5.639],
        rotation: [-0.0159, -0.0158],
        ..geo()
    };
    let p = dir.path().join("rotated.tif");
    write_image_geo(&p, &img, Some(&g)).unwrap();
    assert_eq!(read_georeference(&p).unwrap().unwrap(), g);
}

#[test]
fn png_sidecars_carry_the_crs_and_fail_together() {
    let dir = tempfile::tempdir().unwrap();
    let img = AnyRaster::U8(Raster::from_planes(ImageSize::new(3, 2), vec![vec![1u8; 6]]).unwrap());
    for crs in crs_of_each_kind() {
        let g = GeoReference { crs, ..geo() };
        let p = dir.path().join("g.png");
        write_image_geo(&p, &img, Some(&g)).unwrap();
        let prj = std::fs::read_to_string(dir.path().join("g.prj")).unwrap();
        assert_eq!(prj, g.crs.to_wkt().unwrap());
        same_projection(&g.crs, &Crs::parse(&prj).unwrap());
        let aux = std::fs::read_to_string(dir.path().join("g.png.aux.xml")).unwrap();
        let doc = roxmltree::Document::parse(&aux).unwrap();
        let srs = doc.descendants().find(|n| n.has_tag_name("SRS")).unwrap();
        assert_eq!(srs.text().unwrap(), prj);
    }
    // A sidecar that cannot be renamed into place (a directory is in the way): no image and
    // no other sidecar is left, and no temporary file.
    let d2 = tempfile::tempdir().unwrap();
    std::fs::create_dir(d2.path().join("h.prj")).unwrap();
    let p = d2.path().join("h.png");
    assert!(write_image_geo(&p, &img, Some(&geo())).is_err());
    let mut left: Vec<String> = std::fs::read_dir(d2.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["h.prj"]);
    // A PROJ string with no WKT form is refused before anything is written.
    let g = GeoReference {
        crs: Crs::from_proj_string("+proj=merc +datum=WGS84").unwrap(),
        ..geo()
    };
    let e = write_image_geo(&d2.path().join("m.png"), &img, Some(&g)).unwrap_err();
    assert!(e.to_string().contains("+proj=merc"), "{e}");
    assert!(!d2.path().join("m.png").exists());
}
