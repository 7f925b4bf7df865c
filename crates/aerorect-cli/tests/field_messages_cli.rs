//! Issue 28, items 5-7: every output is checked before any work; a refusal names the real
//! file, tag or option and its value (not a flag nobody gave, not a temporary file); absurd
//! values are refused where they are read. Each test fails on the code before the fix.
#![allow(clippy::unwrap_used)]

mod common;
use aerorect::core::ImageSize;
use aerorect::geo::Crs;
use aerorect::io::GeoReference;
use aerorect::raster::{AnyRaster, Raster};
use common::{aerorect, fails, jpeg_with_xmp};
use std::path::{Path, PathBuf};

/// The bundled JPEG with a DJI XMP packet; `attrs` replaces the altitude attributes.
fn photo(dir: &Path, name: &str, attrs: &str) -> PathBuf {
    let x = format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" {attrs} drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-80.00"/></rdf:RDF></x:xmpmeta>"#
    );
    jpeg_with_xmp(dir, name, Some(&x))
}

const HEIGHTS: &str = r#"drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+80.00""#;

/// A folder with cam.toml (640 x 480), a.jpg (80 m up, absolute 310 m) and a file that is no
/// image (bad.jpg: the decoder fails on it, so a check made after decoding names it instead).
fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(&d, "a.jpg", HEIGHTS);
    std::fs::write(d.join("bad.jpg"), b"not a jpeg").unwrap();
    (dir, d)
}

fn run(d: &Path, args: &[&str]) -> std::process::Output {
    aerorect(args, d)
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Nothing but the inputs (and `keep`) in `d`: the refusal wrote nothing.
fn only(d: &Path, keep: &[&str]) {
    let mut names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !["cam.toml", "a.jpg", "bad.jpg"].contains(&n.as_str()))
        .filter(|n| !keep.contains(&n.as_str()))
        .collect();
    names.sort();
    assert!(names.is_empty(), "written: {names:?}");
}

#[test]
fn a_bad_report_html_path_is_refused_before_any_frame_naming_the_path() {
    let (_t, d) = setup();
    std::fs::create_dir(d.join("adir")).unwrap();
    for (report, needle) in [
        ("missing/r.html", "the folder missing does not exist"),
        ("adir", "is a folder"),
    ] {
        let out = run(
            &d,
            &[
                "batch",
                "a.jpg",
                "--out-dir",
                "out",
                "--camera",
                "cam.toml",
                "--report-html",
                report,
            ],
        );
        fails(&out, &["--report-html", report, needle]);
        assert!(!stderr(&out).contains(".aerorect-"), "{}", stderr(&out));
        // Found before the frame was rectified: no out folder, no frame.
        assert!(!d.join("out").exists(), "{}", stderr(&out));
    }
}

#[test]
fn every_output_is_checked_before_the_first_frame_is_decoded() {
    let (_t, d) = setup();
    std::fs::create_dir(d.join("adir")).unwrap();
    std::fs::write(d.join("plain.txt"), "x").unwrap();
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["rectify", "bad.jpg", "no/o.tif", "--camera", "cam.toml"],
            &["OUTPUT no/o.tif", "the folder no does not exist"],
        ),
        (
            &[
                "rectify", "bad.jpg", "o.tif", "--camera", "cam.toml", "--report", "adir",
            ],
            &["--report adir", "is a folder"],
        ),
        (
            &[
                "rectify",
                "bad.jpg",
                "plain.txt/o.tif",
                "--camera",
                "cam.toml",
            ],
            &["plain.txt is not a folder"],
        ),
        (
            &[
                "batch",
                "bad.jpg",
                "--out-dir",
                "plain.txt",
                "--camera",
                "cam.toml",
            ],
            &["--out-dir plain.txt", "not a folder"],
        ),
        (
            &[
                "calibrate",
                "--model",
                "opencv",
                "--images",
                "bad.jpg",
                "--board",
                "9x6",
                "--square-m",
                "0.025",
                "--camera-out",
                "adir",
            ],
            &["--camera-out adir", "is a folder"],
        ),
        (
            &[
                "mosaic",
                "bad.jpg",
                "a.jpg",
                "--out",
                "nowhere/m.tif",
                "--camera",
                "cam.toml",
            ],
            &["--out nowhere/m.tif", "does not exist"],
        ),
    ];
    for (args, needles) in cases {
        let out = run(&d, args);
        fails(&out, needles);
        assert!(
            !stderr(&out).contains("bad.jpg"),
            "decoded first: {}",
            stderr(&out)
        );
        only(&d, &["adir", "plain.txt"]);
    }
}

/// A float DEM GeoTIFF of 200 x 200 cells of 5 m in UTM 35N around the photo's position.
fn dem(dir: &Path, name: &str, height: f32) {
    let n = 200;
    let raster = Raster::from_planes(ImageSize::new(n, n), vec![vec![height; n * n]]).unwrap();
    let geo = GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
        pixel_size: [5.0, 5.0],
        top_left: [536138.43 - 500.0, 5972535.86 + 500.0],
        rotation: [0.0, 0.0],
        nodata: None,
    };
    aerorect::io::write_image_geo(&dir.join(name), &AnyRaster::F32(raster), Some(&geo)).unwrap();
}

#[test]
fn a_camera_below_the_ground_is_said_so_not_a_gsd_nobody_gave() {
    let (_t, d) = setup();
    let rectify = |args: &[&str]| {
        let mut all = vec!["rectify", args[0], "o.tif", "--camera", "cam.toml"];
        all.extend_from_slice(&args[1..]);
        run(&d, &all)
    };
    // AbsoluteAltitude 310 m over ground at 400 m.
    let out = rectify(&["a.jpg", "--ground-height-m", "400"]);
    fails(&out, &["a.jpg", "310", "400", "-90"]);
    assert!(!stderr(&out).contains("--gsd-m"), "{}", stderr(&out));
    // Over a DEM at 500 m, without RelativeAltitude (no take-off height to fall back on).
    photo(&d, "abs.jpg", r#"drone-dji:AbsoluteAltitude="+310.00""#);
    dem(&d, "high.tif", 500.0);
    let out = rectify(&["abs.jpg", "--dem", "high.tif"]);
    fails(
        &out,
        &["abs.jpg", "not above the ground", "310", "high.tif", "500"],
    );
    assert!(!stderr(&out).contains("--gsd-m"), "{}", stderr(&out));
    // With RelativeAltitude the take-off ground (230 m) gives the GSD; the DEM is still above.
    let out = rectify(&["a.jpg", "--dem", "high.tif"]);
    fails(&out, &["a.jpg", "high.tif"]);
    assert!(!stderr(&out).contains("--gsd-m"), "{}", stderr(&out));
    // A DEM of 1e30 (an undeclared nodata value): named with the height.
    dem(&d, "huge.tif", 1e30);
    let out = rectify(&["abs.jpg", "--dem", "huge.tif"]);
    fails(&out, &["huge.tif", "1e30"]);
    assert!(!stderr(&out).contains("--gsd-m"), "{}", stderr(&out));
    only(&d, &["abs.jpg", "high.tif", "huge.tif"]);
}

#[test]
fn a_garbage_prj_is_named() {
    let (_t, d) = setup();
    std::fs::write(
        d.join("poses.csv"),
        "filename,x,y,z,omega,phi,kappa\na,536138.4,5972535.9,310,0,0,0\n",
    )
    .unwrap();
    std::fs::write(d.join("poses.prj"), "garbage, not a CRS").unwrap();
    let out = run(
        &d,
        &[
            "batch",
            "a.jpg",
            "--out-dir",
            "out",
            "--poses",
            "poses.csv",
            "--camera",
            "cam.toml",
        ],
    );
    fails(&out, &["poses.prj", "garbage, not a CRS"]);
    assert!(!stderr(&out).contains("--crs"), "{}", stderr(&out));
    only(&d, &["poses.csv", "poses.prj"]);
}

#[test]
fn huge_heights_gsds_and_lever_arms_are_refused_at_their_source() {
    let (_t, d) = setup();
    photo(
        &d,
        "high.jpg",
        r#"drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+1e308""#,
    );
    let out = run(
        &d,
        &["rectify", "high.jpg", "o.tif", "--camera", "cam.toml"],
    );
    fails(&out, &["high.jpg", "RelativeAltitude", "1e308"]);
    assert!(!stderr(&out).contains("singular"), "{}", stderr(&out));
    for (flag, value) in [("--gsd-m", "1e308"), ("--lever-arm-m", "0,1e308,0")] {
        let out = run(
            &d,
            &[
                "rectify", "a.jpg", "o.tif", "--camera", "cam.toml", flag, value,
            ],
        );
        fails(&out, &[flag, value]);
        assert!(!stderr(&out).contains("singular"), "{}", stderr(&out));
    }
    only(&d, &["high.jpg"]);
}

#[test]
fn an_unknown_epsg_code_is_called_unknown() {
    let (_t, d) = setup();
    let out = run(
        &d,
        &[
            "rectify",
            "a.jpg",
            "o.tif",
            "--camera",
            "cam.toml",
            "--crs",
            "EPSG:999999",
        ],
    );
    fails(&out, &["--crs", "EPSG:999999", "unknown EPSG code"]);
    assert!(!stderr(&out).contains("not a number"), "{}", stderr(&out));
}

#[test]
fn a_huge_chessboard_square_is_refused_naming_it() {
    let (_t, d) = setup();
    let out = run(
        &d,
        &[
            "calibrate",
            "--model",
            "opencv",
            "--images",
            "a.jpg",
            "--board",
            "9x6",
            "--square-m",
            "1e308",
        ],
    );
    fails(&out, &["--square-m 1e308", "square size 1e308 m"]);
    assert!(!stderr(&out).contains("not finite"), "{}", stderr(&out));
}

#[test]
fn absurd_camera_values_are_refused_naming_the_file_and_field() {
    let (_t, d) = setup();
    let base = "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n";
    let cases = [
        (
            "fx_px = 1e308\nfy_px = 500.0\nimage_size_px = [640, 480]\n".to_string(),
            "fx_px = 1e308",
        ),
        (
            format!("{base}[distortion]\nmodel = \"opencv\"\nk1 = 1e308\n"),
            "k1 = 1e308",
        ),
        (
            "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [4000000000, 3000000000]\n".into(),
            "image_size_px = [4000000000, 3000000000]",
        ),
    ];
    for (text, needle) in &cases {
        std::fs::write(d.join("absurd.toml"), text).unwrap();
        for args in [
            &["camera", "convert", "absurd.toml", "out.yaml"][..],
            &["rectify", "a.jpg", "o.tif", "--camera", "absurd.toml"][..],
        ] {
            let out = run(&d, args);
            fails(&out, &["absurd.toml", needle]);
        }
        only(&d, &["absurd.toml"]);
    }
    let out = run(
        &d,
        &[
            "camera",
            "convert",
            "cam.toml",
            "out.toml",
            "--image-size",
            "4000000000x3000000000",
        ],
    );
    fails(
        &out,
        &["--image-size '4000000000x3000000000'", "a side over"],
    );
    only(&d, &["absurd.toml"]);
}

#[test]
fn an_absurd_attitude_sigma_is_refused_naming_it() {
    let (_t, d) = setup();
    // A second photo, not a copy of a.jpg (a copy is refused as the same photo first).
    photo(
        &d,
        "b.jpg",
        r#"drone-dji:AbsoluteAltitude="+311.00" drone-dji:RelativeAltitude="+81.00""#,
    );
    let out = run(
        &d,
        &[
            "batch",
            "a.jpg",
            "b.jpg",
            "--out-dir",
            "out",
            "--camera",
            "cam.toml",
            "--adjust",
            "--attitude-sigma-deg",
            "1e308",
        ],
    );
    fails(&out, &["--attitude-sigma-deg 1e308", "at most 180"]);
    only(&d, &["b.jpg"]);
}
