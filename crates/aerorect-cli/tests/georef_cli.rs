//! `rectify` / `batch` with terrain, poses and CRSs: a constant DEM against the flat path, OPK
//! poses against the metadata, and the refusals (each names the file, field and value, exits
//! non-zero and writes nothing).
#![allow(clippy::unwrap_used)]

mod common;
use aerorect::core::ImageSize;
use aerorect::geo::Crs;
use aerorect::io::GeoReference;
use aerorect::raster::{AnyRaster, Raster};
use common::{aerorect, fails, ok};
use std::path::{Path, PathBuf};

/// The bundled JPEG with a DJI XMP packet (camera 80 m above the take-off point at 230 m).
fn photo(dir: &Path, name: &str, extra: &str) -> PathBuf {
    let x = format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-70.00" {extra}/></rdf:RDF></x:xmpmeta>"#
    );
    common::jpeg_with_xmp(dir, name, Some(&x))
}

/// A float DEM GeoTIFF of `n` x `n` cells of `cell` m in UTM 35N around the photo's position.
fn dem(dir: &Path, name: &str, n: usize, cell: f64, height: impl Fn(usize, usize) -> f32) {
    let values = (0..n * n).map(|i| height(i % n, i / n)).collect();
    let raster = Raster::from_planes(ImageSize::new(n, n), vec![values]).unwrap();
    let half = n as f64 * cell / 2.0;
    let geo = GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
        pixel_size: [cell, cell],
        top_left: [536138.43 - half, 5972535.86 + half],
        rotation: [0.0, 0.0],
        nodata: None,
    };
    aerorect::io::write_image_geo(&dir.join(name), &AnyRaster::F32(raster), Some(&geo)).unwrap();
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(&d, "a.jpg", "");
    dem(&d, "flat.tif", 200, 5.0, |_, _| 230.0);
    (dir, d)
}

fn pixels(p: &Path) -> Vec<u8> {
    match aerorect::io::read_image(p).unwrap() {
        AnyRaster::U8(r) => r.plane(0).to_vec(),
        _ => panic!("u8"),
    }
}

/// A DEM at the take-off point's height gives the flat ortho: the same grid, and pixels equal
/// up to the rounding of two exact maps (a homography and a per-pixel projection).
#[test]
fn a_constant_dem_gives_the_flat_ortho() {
    let (_t, d) = setup();
    let common = ["--camera", "cam.toml", "--gsd-m", "0.5"];
    ok(&aerorect(
        &[&["rectify", "a.jpg", "f.tif"][..], &common].concat(),
        &d,
    ));
    ok(&aerorect(
        &[
            &[
                "rectify", "a.jpg", "d.tif", "--dem", "flat.tif", "--report", "d.json",
            ][..],
            &common,
        ]
        .concat(),
        &d,
    ));
    let (gf, gd) = (
        aerorect::io::read_georeference(&d.join("f.tif"))
            .unwrap()
            .unwrap(),
        aerorect::io::read_georeference(&d.join("d.tif"))
            .unwrap()
            .unwrap(),
    );
    assert_eq!(gf.pixel_size, gd.pixel_size);
    let (f, m) = (pixels(&d.join("f.tif")), pixels(&d.join("d.tif")));
    // The DEM's footprint comes from marched rays: its grid may differ by a pixel at the edges.
    let off = [
        ((gf.top_left[0] - gd.top_left[0]) / 0.5).round() as i64,
        ((gd.top_left[1] - gf.top_left[1]) / 0.5).round() as i64,
    ];
    assert!(off[0].abs() <= 1 && off[1].abs() <= 1, "{off:?}");
    let (wf, wd) = (
        aerorect::io::read_image(&d.join("f.tif"))
            .unwrap()
            .size()
            .width as i64,
        aerorect::io::read_image(&d.join("d.tif"))
            .unwrap()
            .size()
            .width as i64,
    );
    let (mut n, mut big) = (0, 0);
    for (i, &v) in f.iter().enumerate() {
        let (c, r) = (i as i64 % wf + off[0], i as i64 / wf + off[1]);
        if c < 0 || r < 0 || c >= wd || (r * wd + c) as usize >= m.len() {
            continue;
        }
        let w = m[(r * wd + c) as usize];
        if v != 0 && w != 0 {
            n += 1;
            big += (v.abs_diff(w) > 1) as usize;
        }
    }
    assert!(
        n > 10_000 && big * 1000 < n,
        "{big} of {n} differ by more than 1"
    );
    let report = std::fs::read_to_string(d.join("d.json")).unwrap();
    assert!(
        report.contains("flat.tif") && report.contains("AbsoluteAltitude"),
        "{report}"
    );
}

#[test]
fn bad_dems_are_refused_naming_the_file() {
    let (_t, d) = setup();
    std::fs::write(d.join("junk.tif"), b"not a tiff at all").unwrap();
    dem(&d, "empty.tif", 50, 5.0, |_, _| f32::NAN);
    dem(&d, "far.tif", 8, 5.0, |_, _| 230.0); // 40 m across: not the whole footprint
    for (file, needle) in [
        ("junk.tif", "junk.tif"),
        ("empty.tif", "no valid height"),
        ("missing.tif", "missing.tif"),
    ] {
        let out = aerorect(
            &[
                "rectify", "a.jpg", "o.tif", "--camera", "cam.toml", "--dem", file,
            ],
            &d,
        );
        fails(&out, &[needle]);
        assert!(!d.join("o.tif").exists());
    }
    let out = aerorect(
        &[
            "rectify", "a.jpg", "o.tif", "--camera", "cam.toml", "--dem", "far.tif", "--strict",
        ],
        &d,
    );
    fails(&out, &["far.tif", "nodata or outside", "--strict"]);
    assert!(!d.join("o.tif").exists());
    let out = aerorect(
        &[
            "rectify", "a.jpg", "o.tif", "--camera", "cam.toml", "--dem", "far.tif",
        ],
        &d,
    );
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stderr).contains("outside it"));
}

#[test]
fn bad_poses_and_crs_strings_are_refused() {
    let (_t, d) = setup();
    let run = |pose: &str, crs: &str| {
        aerorect(
            &[
                "rectify",
                "a.jpg",
                "o.tif",
                "--camera",
                "cam.toml",
                &format!("--pose={pose}"),
                "--crs",
                crs,
                "--ground-height-m",
                "230",
            ],
            &d,
        )
    };
    let good = "536138.4,5972535.9,310,0,0,0";
    fails(
        &run("536138.4,5972535.9,NaN,0,0,0", "EPSG:32635"),
        &["--pose", "NaN"],
    );
    fails(
        &run("536138.4,5972535.9,310,0,120,0", "EPSG:32635"),
        &["phi", "120"],
    );
    fails(&run("1,2,3", "EPSG:32635"), &["--pose", "six numbers"]);
    fails(&run(good, "+proj=nonsense"), &["+proj=nonsense"]);
    fails(&run(good, "EPSG:4326"), &["geographic"]);
    assert!(!d.join("o.tif").exists());
    // A pose needs the ground.
    let out = aerorect(
        &[
            "rectify",
            "a.jpg",
            "o.tif",
            "--camera",
            "cam.toml",
            &format!("--pose={good}"),
            "--crs",
            "EPSG:32635",
        ],
        &d,
    );
    fails(&out, &["--dem or --ground-height-m"]);
    ok(&run(good, "EPSG:32635"));
}

/// XMP calibration for another aspect ratio than the image's: refused, naming both sizes.
#[test]
fn tags_for_another_aspect_ratio_are_refused() {
    let (_t, d) = setup();
    photo(
        &d,
        "odd.jpg",
        r#"drone-dji:CalibratedFocalLength="3000" drone-dji:CalibratedOpticalCenterX="2000" drone-dji:CalibratedOpticalCenterY="500""#,
    );
    let out = aerorect(&["rectify", "odd.jpg", "o.tif"], &d);
    fails(&out, &["odd.jpg", "4000x1000", "640x480"]);
    assert!(!d.join("o.tif").exists());
}

/// batch --poses: every frame from the table (CRS from the .prj beside it); a frame not in the
/// table is listed as failed.
#[test]
fn batch_takes_poses_from_a_table_and_its_prj() {
    let (_t, d) = setup();
    let b = photo(&d, "b.jpg", "");
    // Another photo than a.jpg, not a copy (a copy is refused as one photo given twice): a
    // byte after the JPEG's end.
    let mut bytes = std::fs::read(&b).unwrap();
    bytes.push(0);
    std::fs::write(&b, bytes).unwrap();
    std::fs::write(
        d.join("poses.csv"),
        "filename,x,y,z,omega,phi,kappa\na,536138.4,5972535.9,310,10,-5,30\n",
    )
    .unwrap();
    std::fs::write(
        d.join("poses.prj"),
        "+proj=utm +zone=35 +datum=WGS84 +units=m +no_defs",
    )
    .unwrap();
    let out = aerorect(
        &[
            "batch",
            "a.jpg",
            "b.jpg",
            "--out-dir",
            "out",
            "--poses",
            "poses.csv",
            "--camera",
            "cam.toml",
            "--dem",
            "flat.tif",
            "--gsd-m",
            "0.5",
        ],
        &d,
    );
    fails(&out, &["b.jpg", "not in the pose table"]);
    assert!(d.join("out/a.tif").exists() && !d.join("out/b.tif").exists());
}
