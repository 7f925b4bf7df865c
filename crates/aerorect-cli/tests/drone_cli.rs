//! `rectify` from metadata and `batch` on photos made here: the bundled JPEG with a DJI XMP
//! packet inserted (GPS from XMP, the camera from a camera file).
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};

fn xmp(yaw: f64, pitch: f64) -> String {
    format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="{yaw:+.2}" drone-dji:GimbalPitchDegree="{pitch:+.2}" drone-dji:FlightYawDegree="+12.00"/></rdf:RDF></x:xmpmeta>"#
    )
}

/// The bundled JPEG with an APP1 XMP segment after SOI.
fn photo(dir: &Path, name: &str, xmp: Option<String>) -> PathBuf {
    common::jpeg_with_xmp(dir, name, xmp.as_deref())
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(&d, "a.jpg", Some(xmp(30.0, -70.0)));
    photo(&d, "b.jpg", Some(xmp(35.0, -90.0)));
    photo(&d, "noxmp.jpg", None);
    std::fs::write(
        d.join("broken.jpg"),
        &std::fs::read(d.join("a.jpg")).unwrap()[..5000],
    )
    .unwrap();
    (dir, d)
}

#[test]
fn rectify_from_metadata_writes_a_geotiff_and_a_world_file() {
    let (_t, d) = setup();
    ok(&aerorect(
        &[
            "rectify", "a.jpg", "a.tif", "--camera", "cam.toml", "--gsd-m", "0.5", "--report",
            "a.json",
        ],
        &d,
    ));
    let geo = aerorect::io::read_georeference(&d.join("a.tif"))
        .unwrap()
        .unwrap();
    assert_eq!(geo.crs.epsg(), Some(32635));
    assert_eq!(geo.pixel_size, [0.5, 0.5]);
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("a.json")).unwrap()).unwrap();
    assert_eq!(
        r["info"]["geo"]["top_left"][0].as_f64().unwrap(),
        geo.top_left[0]
    );
    assert_eq!(r["info"]["height_m"].as_f64().unwrap(), 80.0);
    ok(&aerorect(
        &[
            "rectify", "b.jpg", "b.png", "--camera", "cam.toml", "--gsd-m", "0.5",
        ],
        &d,
    ));
    let w = std::fs::read_to_string(d.join("b.pgw")).unwrap();
    assert_eq!(w.lines().count(), 6);
    fails(
        &aerorect(
            &["rectify", "noxmp.jpg", "n.tif", "--camera", "cam.toml"],
            &d,
        ),
        &["noxmp.jpg", "GimbalYawDegree"],
    );
    assert!(!d.join("n.tif").exists());
    fails(
        &aerorect(
            &[
                "rectify",
                "a.jpg",
                "n.tif",
                "--camera",
                "cam.toml",
                "--gsd-m=-1",
            ],
            &d,
        ),
        &["--gsd-m -1"],
    );
}

#[test]
fn batch_lists_failures_skips_existing_and_reports() {
    let (_t, d) = setup();
    let args = [
        "batch",
        "a.jpg",
        "b.jpg",
        "noxmp.jpg",
        "broken.jpg",
        "--camera",
        "cam.toml",
        "--out-dir",
        "out",
        "--gsd-m",
        "0.5",
        "--report-html",
        "r.html",
    ];
    let out = aerorect(&args, &d);
    fails(
        &out,
        &[
            "2 of 4 frames failed",
            "noxmp.jpg",
            "GimbalYawDegree",
            "broken.jpg",
        ],
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("4 frames: 2 rectified, 0 skipped, 2 failed"),
        "{stdout}"
    );
    let (ga, gb) = (
        aerorect::io::read_georeference(&d.join("out/a.tif"))
            .unwrap()
            .unwrap(),
        aerorect::io::read_georeference(&d.join("out/b.tif"))
            .unwrap()
            .unwrap(),
    );
    // One ground grid: corners on multiples of the GSD in both.
    for v in ga.top_left.iter().chain(&gb.top_left) {
        assert!((v / 0.5 - (v / 0.5).round()).abs() < 1e-6);
    }
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    for needle in [
        "<svg",
        "data:image/png;base64,",
        "a.jpg",
        "b.jpg",
        "GimbalYawDegree",
        "broken.jpg",
        "EPSG:32635",
    ] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    // A second run skips what exists and leaves it untouched; --force rewrites.
    let before = std::fs::metadata(d.join("out/a.tif"))
        .unwrap()
        .modified()
        .unwrap();
    let again = aerorect(
        &[
            "batch",
            "a.jpg",
            "b.jpg",
            "--camera",
            "cam.toml",
            "--out-dir",
            "out",
            "--gsd-m",
            "0.5",
        ],
        &d,
    );
    assert!(ok(&again).contains("2 frames: 0 rectified, 2 skipped, 0 failed"));
    assert_eq!(
        std::fs::metadata(d.join("out/a.tif"))
            .unwrap()
            .modified()
            .unwrap(),
        before
    );
    let forced = aerorect(
        &[
            "batch",
            "a.jpg",
            "--camera",
            "cam.toml",
            "--out-dir",
            "out",
            "--gsd-m",
            "0.5",
            "--force",
        ],
        &d,
    );
    assert!(ok(&forced).contains("1 rectified"));
    // An output that would overwrite an input is refused before anything runs.
    std::fs::copy(d.join("out/a.tif"), d.join("c.tif")).unwrap();
    fails(
        &aerorect(
            &["batch", "c.tif", "--out-dir", ".", "--camera", "cam.toml"],
            &d,
        ),
        &["overwrite the input"],
    );
    let leftovers: Vec<_> = std::fs::read_dir(d.join("out"))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}
