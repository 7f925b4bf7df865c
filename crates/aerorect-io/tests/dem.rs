//! DEMs and GeoTIFFs of any CRS: the NGI DEM and frames (../shared/data/ngi, a user-defined
//! transverse Mercator written by GDAL) against values read by GDAL/PROJ, and DEMs written
//! here with the tiff crate for each sample type and refusal.
#![allow(clippy::unwrap_used)]

use aerorect_geo::{Crs, CrsForm};
use aerorect_io::{read_dem, read_georeference};
use aerorect_testkit::shared_data;
use std::path::Path;
use tiff::encoder::{TiffEncoder, colortype};
use tiff::tags::Tag;

/// pyproj 3.7 (PROJ 9), `Transformer.from_crs("EPSG:4326", <dem.tif CRS>, always_xy=True)
/// .transform(24.4, -33.7)`, the CRS as rasterio reads it from ../shared/data/ngi/dem.tif.
const PROJ_LON_LAT: [f64; 2] = [24.4, -33.7];
const PROJ_EN: [f64; 2] = [-55_625.367_290_298_54, -3_730_547.142_075_638];

fn assert_projects_like_proj(crs: &Crs) {
    let [e, n] = crs.from_lon_lat(PROJ_LON_LAT[0], PROJ_LON_LAT[1]).unwrap();
    assert!(
        (e - PROJ_EN[0]).abs() < 1e-3 && (n - PROJ_EN[1]).abs() < 1e-3,
        "{crs}: ({e}, {n}) vs PROJ {PROJ_EN:?}"
    );
}

#[test]
fn ngi_dem_reads_its_tm_crs_grid_and_heights() {
    let Some(p) = shared_data("ngi/dem.tif") else {
        return;
    };
    let dem = read_dem(&p).unwrap();
    assert_eq!((dem.width, dem.height), (327, 508));
    assert_eq!(dem.name, p.display().to_string());
    // rasterio: Affine(24, 0, -60454, 0, -24, -3723500), nodata nan.
    assert_eq!(dem.top_left, [-60454.0, -3_723_500.0]);
    assert_eq!(dem.cell_size, [24.0, 24.0]);
    let geo = read_georeference(&p).unwrap().unwrap();
    assert_eq!(
        geo.geotransform(),
        [-60454.0, 24.0, 0.0, -3_723_500.0, 0.0, -24.0]
    );
    assert!(geo.nodata.unwrap().is_nan());
    assert!(matches!(dem.crs.form(), CrsForm::Proj(_)), "{:?}", dem.crs);
    assert_eq!(dem.crs, geo.crs);
    assert_projects_like_proj(&dem.crs);
    // rasterio `src.read(1)[row, col]`, and the same at the cell's centre.
    for (c, r, h) in [
        (0, 0, 241.064_437_866_210_94),
        (100, 200, 255.223_403_930_664_06),
        (326, 507, 739.921_997_070_312_5),
        (163, 254, 346.101_501_464_843_75),
    ] {
        assert_eq!(dem.values[r * dem.width + c] as f64, h, "({c}, {r})");
        let [x, y] = geo.ground_of_pixel(c as f64, r as f64);
        assert_eq!(dem.height_at(x, y), Some(h), "({c}, {r})");
    }
    // rasterio `src.xy(254, 163)` (pixel centre).
    assert_eq!(geo.ground_of_pixel(163.0, 254.0), [-56530.0, -3_729_608.0]);
    let [c, r] = geo.pixel_of_ground(-56530.0, -3_729_608.0).unwrap();
    assert!((c - 163.0).abs() < 1e-9 && (r - 254.0).abs() < 1e-9);
}

#[test]
fn ngi_frame_has_gdals_rotated_geotransform() {
    let Some(p) = shared_data("ngi/3324c_2015_1004_05_0182_RGB.tif") else {
        return;
    };
    let g = read_georeference(&p).unwrap().unwrap();
    // rasterio `src.transform.to_gdal()`, from ModelTransformation (34264).
    let gdal = [
        -53_284.285_247_725_11,
        -5.639_122_614_945_984,
        -0.015_889_135_588_938_785,
        -3_730_647.082_199_863,
        -0.015_889_135_589_077_34,
        5.639_122_614_946_245_4,
    ];
    assert_eq!(g.geotransform(), gdal);
    assert_eq!(g.nodata, Some(0.0));
    assert_projects_like_proj(&g.crs);
}

/// A 3 x 2 DEM of `C` samples with the NGI DEM's grid and EPSG:32735 keys.
fn write_dem<C: colortype::ColorType>(path: &Path, data: &[C::Inner], nodata: &str)
where
    [C::Inner]: tiff::encoder::TiffValue,
{
    let mut enc = TiffEncoder::new(std::fs::File::create(path).unwrap()).unwrap();
    let mut img = enc.new_image::<C>(3, 2).unwrap();
    let e = img.encoder();
    e.write_tag(Tag::Unknown(33550), &[24.0f64, 24.0, 0.0][..])
        .unwrap();
    e.write_tag(
        Tag::Unknown(33922),
        &[0.0f64, 0.0, 0.0, 500_000.0, 6_000_000.0, 0.0][..],
    )
    .unwrap();
    let keys: [u16; 12] = [1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 32735];
    e.write_tag(Tag::Unknown(34735), &keys[..]).unwrap();
    if !nodata.is_empty() {
        e.write_tag(Tag::Unknown(42113), nodata).unwrap();
    }
    img.write_data(data).unwrap();
}

#[test]
fn integer_and_double_dems_become_f32_with_nodata_as_nan() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("i16.tif");
    write_dem::<colortype::GrayI16>(&p, &[-32768, 5, -7, 100, 200, -32768], "-32768");
    let dem = read_dem(&p).unwrap();
    assert_eq!(dem.crs, Crs::from_epsg(32735).unwrap());
    assert_eq!(dem.top_left, [500_000.0, 6_000_000.0]);
    let h = &dem.values;
    assert!(h[0].is_nan() && h[5].is_nan());
    assert_eq!(&h[1..5], &[5.0, -7.0, 100.0, 200.0]);

    let p = dir.path().join("f64.tif");
    write_dem::<colortype::Gray64Float>(&p, &[1.5, 2.5, -9999.0, 4.0, 5.0, 6.25], "-9999");
    let h = read_dem(&p).unwrap().values;
    assert_eq!((h[0], h[1], h[5]), (1.5, 2.5, 6.25));
    assert!(h[2].is_nan());

    let p = dir.path().join("u16.tif");
    write_dem::<colortype::Gray16>(&p, &[1, 2, 3, 4, 5, 65535], "");
    assert_eq!(read_dem(&p).unwrap().values[5], 65535.0);

    let p = dir.path().join("i32.tif");
    write_dem::<colortype::GrayI32>(&p, &[-100_000, 2, 3, 4, 5, 6], "");
    assert_eq!(read_dem(&p).unwrap().values[0], -100_000.0);
}

#[test]
fn bad_dems_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("allnodata.tif");
    write_dem::<colortype::GrayI16>(&p, &[-1; 6], "-1");
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(e.contains("allnodata.tif has no valid height"), "{e}");

    let p = dir.path().join("rgb.tif");
    write_dem::<colortype::RGB8>(&p, &[1; 18], "");
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(e.contains("rgb.tif") && e.contains("3 bands"), "{e}");

    let p = dir.path().join("plain.tif");
    aerorect_io::write_image(
        &p,
        &aerorect_raster::AnyRaster::F32(
            aerorect_raster::Raster::from_planes(
                aerorect_core::ImageSize::new(2, 2),
                vec![vec![1.0; 4]],
            )
            .unwrap(),
        ),
    )
    .unwrap();
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(
        e.contains("plain.tif") && e.contains("no georeferencing"),
        "{e}"
    );

    let p = dir.path().join("missing.tif");
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(e.contains("missing.tif"), "{e}");

    let p = dir.path().join("text.tif");
    std::fs::write(&p, "not a tiff").unwrap();
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(e.contains("text.tif"), "{e}");
}

#[test]
fn unknown_projection_keys_name_the_file_key_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("odd.tif");
    let mut enc = TiffEncoder::new(std::fs::File::create(&p).unwrap()).unwrap();
    let mut img = enc.new_image::<colortype::Gray32Float>(1, 1).unwrap();
    let e = img.encoder();
    e.write_tag(Tag::Unknown(33550), &[1.0f64, 1.0, 0.0][..])
        .unwrap();
    e.write_tag(Tag::Unknown(33922), &[0.0f64; 6][..]).unwrap();
    // Projected, user-defined, WGS 84, ProjCoordTransGeoKey = 23 (not one we know).
    let keys: [u16; 20] = [
        1, 1, 0, 4, 1024, 0, 1, 1, 2048, 0, 1, 4326, 3072, 0, 1, 32767, 3075, 0, 1, 23,
    ];
    e.write_tag(Tag::Unknown(34735), &keys[..]).unwrap();
    img.write_data(&[1.0f32]).unwrap();
    let e = read_dem(&p).unwrap_err().to_string();
    assert!(
        e.contains("odd.tif") && e.contains("ProjCoordTransGeoKey (3075) = 23"),
        "{e}"
    );
}

/// What the terrain planner cannot sample is refused where the DEM is read, naming the file:
/// a rotated grid, a grid too small to interpolate, a height no terrain has.
#[test]
fn dems_the_planner_cannot_sample_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, size: (usize, usize), heights: Vec<f32>, rotation: [f64; 2]| {
        let p = dir.path().join(name);
        let raster = aerorect_raster::Raster::from_planes(
            aerorect_core::ImageSize::new(size.0, size.1),
            vec![heights],
        )
        .unwrap();
        let geo = aerorect_io::GeoReference {
            crs: Crs::from_epsg(32735).unwrap(),
            pixel_size: [24.0, 24.0],
            top_left: [500_000.0, 6_000_000.0],
            rotation,
            nodata: None,
        };
        aerorect_io::write_image_geo(&p, &aerorect_raster::AnyRaster::F32(raster), Some(&geo))
            .unwrap();
        (p.display().to_string(), read_dem(&p).map(|d| d.values))
    };
    let (name, r) = write("rotated.tif", (3, 2), vec![1.0; 6], [0.5, 0.0]);
    let e = r.unwrap_err().to_string();
    assert_eq!(
        e,
        format!("DEM {name}: a rotated grid (geotransform terms [0.5, 0.0]) is not supported")
    );
    let (name, r) = write("one.tif", (1, 1), vec![1.0], [0.0; 2]);
    let e = r.unwrap_err().to_string();
    assert_eq!(
        e,
        format!("DEM: {name}: 1 x 1 is too small for interpolation")
    );
    let (name, r) = write("huge.tif", (2, 2), vec![1.0, 2.0, 1e30, 3.0], [0.0; 2]);
    let e = r.unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("DEM: {name}: a height of 1e30 m")),
        "{e}"
    );
    let (_, r) = write("fine.tif", (2, 2), vec![1.0, 2.0, 3.0, 4.0], [0.0; 2]);
    assert_eq!(r.unwrap(), [1.0, 2.0, 3.0, 4.0]);
}
