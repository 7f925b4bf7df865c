//! Photos that are not DJI gimbal frames: senseFly and Pix4D XMP body angles, external-
//! orientation files (`--geo`), GPS-only photos, and their bad inputs. The bundled JPEG with
//! an XMP packet inserted; the oracle is the DJI gimbal adapter, which puts a camera at the
//! equivalent angles (Pix4D pitch = DJI pitch + 90 at roll 0) on the same ground grid.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, jpeg_with_xmp, ok};

use std::path::{Path, PathBuf};

fn rdf(body: &str) -> String {
    format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">{body}</rdf:RDF></x:xmpmeta>"#
    )
}

/// A DJI packet: position, height, and gimbal angles when given.
fn dji(lat: f64, lon: f64, gimbal: Option<(f64, f64)>) -> String {
    let angles = gimbal.map_or(String::new(), |(y, p)| {
        format!(r#"drone-dji:GimbalRollDegree="0" drone-dji:GimbalYawDegree="{y}" drone-dji:GimbalPitchDegree="{p}""#)
    });
    rdf(&format!(
        r#"<rdf:Description xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="{lat}" drone-dji:GpsLongtitude="{lon}" drone-dji:AbsoluteAltitude="300" drone-dji:RelativeAltitude="80" {angles}/>"#
    ))
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    (dir, d)
}

fn georef(p: &Path) -> aerorect::io::GeoReference {
    aerorect::io::read_georeference(p).unwrap().unwrap()
}

fn report(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn rectify(d: &Path, input: &str, output: &str, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "rectify",
        input,
        output,
        "--camera",
        "cam.toml",
        "--gsd-m",
        "0.5",
        "--ground-height-m",
        "220",
    ];
    args.extend_from_slice(extra);
    aerorect(&args, d)
}

#[test]
fn sensefly_and_pix4d_xmp_angles_land_where_the_equivalent_gimbal_does() {
    let (_t, d) = setup();
    // Positions and heights from a Pix4D CSV without angles; angles from each photo's XMP.
    std::fs::write(
        d.join("gps.csv"),
        "imagename,latitude,longitude,altitude\nsf.jpg,37.5,139.04,300\np4.jpg,37.5,139.04,300\n",
    )
    .unwrap();
    let sf = rdf(
        r#"<rdf:Description xmlns:sensefly="http://ns.sensefly.com/sensefly/1.0/"><sensefly:Roll>0</sensefly:Roll><sensefly:Pitch>12</sensefly:Pitch><sensefly:Yaw>304.5</sensefly:Yaw></rdf:Description>"#,
    );
    let p4 = rdf(
        r#"<rdf:Description xmlns:Cam="http://pix4d.com/camera/1.0/" Cam:Yaw="304.5" Cam:Pitch="12" Cam:Roll="0"/>"#,
    );
    jpeg_with_xmp(&d, "sf.jpg", Some(&sf));
    jpeg_with_xmp(&d, "p4.jpg", Some(&p4));
    jpeg_with_xmp(
        &d,
        "dji.jpg",
        Some(&dji(37.5, 139.04, Some((304.5, 12.0 - 90.0)))),
    );
    ok(&rectify(
        &d,
        "sf.jpg",
        "sf.tif",
        &["--geo", "gps.csv", "--report", "sf.json"],
    ));
    ok(&rectify(
        &d,
        "p4.jpg",
        "p4.tif",
        &["--geo", "gps.csv", "--report", "p4.json"],
    ));
    ok(&rectify(&d, "dji.jpg", "dji.tif", &[]));
    let want = georef(&d.join("dji.tif"));
    for name in ["sf", "p4"] {
        let g = georef(&d.join(format!("{name}.tif")));
        assert_eq!(
            (g.top_left, g.pixel_size),
            (want.top_left, want.pixel_size),
            "{name}"
        );
    }
    let r = report(&d.join("sf.json"));
    assert_eq!(r["info"]["attitude"]["source"]["Body"], "Sensefly");
    assert_eq!(
        report(&d.join("p4.json"))["info"]["attitude"]["source"]["Body"],
        "Pix4d"
    );
}

#[test]
fn geo_txt_alone_places_a_photo_without_metadata() {
    let (_t, d) = setup();
    std::fs::write(
        d.join("geo.txt"),
        "EPSG:4326\nbare.jpg 139.04 37.5 300 304.5 12 0\n",
    )
    .unwrap();
    jpeg_with_xmp(&d, "bare.jpg", None);
    jpeg_with_xmp(
        &d,
        "dji.jpg",
        Some(&dji(37.5, 139.04, Some((304.5, -78.0)))),
    );
    ok(&rectify(
        &d,
        "bare.jpg",
        "bare.tif",
        &["--geo", "geo.txt", "--report", "b.json"],
    ));
    ok(&rectify(&d, "dji.jpg", "dji.tif", &[]));
    let (g, want) = (georef(&d.join("bare.tif")), georef(&d.join("dji.tif")));
    assert_eq!(g.top_left, want.top_left);
    assert_eq!(
        report(&d.join("b.json"))["info"]["attitude"]["source"]["Body"],
        "OdmGeoTxt"
    );
}

#[test]
fn gps_only_photos_start_at_nadir_along_their_track() {
    let (_t, d) = setup();
    // Three photos flown due east, DJI positions and heights, no angles.
    for (i, lon) in [27.5500, 27.5505, 27.5510].iter().enumerate() {
        jpeg_with_xmp(&d, &format!("g{i}.jpg"), Some(&dji(53.9, *lon, None)));
    }
    jpeg_with_xmp(
        &d,
        "east.jpg",
        Some(&dji(53.9, 27.5505, Some((90.0, -90.0)))),
    );
    let out = aerorect(
        &[
            "batch",
            "g0.jpg",
            "g1.jpg",
            "g2.jpg",
            "--camera",
            "cam.toml",
            "--out-dir",
            "out",
            "--gsd-m",
            "0.5",
        ],
        &d,
    );
    let said = ok(&out) + &String::from_utf8_lossy(&out.stderr);
    assert!(
        said.contains("no attitude recorded: nadir, heading 90.0 deg"),
        "{said}"
    );
    ok(&aerorect(
        &[
            "rectify", "east.jpg", "east.tif", "--camera", "cam.toml", "--gsd-m", "0.5",
        ],
        &d,
    ));
    assert_eq!(
        georef(&d.join("out/g1.tif")).top_left,
        georef(&d.join("east.tif")).top_left
    );
    // Alone, a GPS-only photo has no track.
    fails(
        &aerorect(&["rectify", "g1.jpg", "g1.tif", "--camera", "cam.toml"], &d),
        &["g1.jpg", "no attitude", "no neighbouring photo"],
    );
    assert!(!d.join("g1.tif").exists());
}

#[test]
fn bad_inputs_name_the_photos_and_write_nothing() {
    let (_t, d) = setup();
    jpeg_with_xmp(&d, "a.jpg", Some(&dji(53.9, 27.55, Some((0.0, -90.0)))));
    jpeg_with_xmp(&d, "b.jpg", Some(&dji(53.9, 27.551, Some((0.0, -90.0)))));
    let batch = |extra: &[&str]| {
        let mut args = vec![
            "batch",
            "a.jpg",
            "b.jpg",
            "--camera",
            "cam.toml",
            "--out-dir",
            "out",
        ];
        args.extend_from_slice(extra);
        aerorect(&args, &d)
    };
    // A geo.txt that misses a photo.
    std::fs::write(
        d.join("geo.txt"),
        "EPSG:4326\na.jpg 27.55 53.9 300\nz.jpg 27.6 53.9 300\n",
    )
    .unwrap();
    fails(
        &batch(&["--geo", "geo.txt"]),
        &["geo.txt", "1 of the 2 photos are not listed: b.jpg"],
    );
    assert!(!d.join("out").join("a.tif").exists());
    // One that names a photo not given: a warning naming it.
    std::fs::write(
        d.join("geo2.txt"),
        "EPSG:4326\na.jpg 27.55 53.9 300\nb.jpg 27.551 53.9 300\nz.jpg 27.6 53.9 300\n",
    )
    .unwrap();
    let out = batch(&["--geo", "geo2.txt", "--ground-height-m", "220"]);
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("1 listed photos are not among the inputs (not used): z.jpg"),
        "{err}"
    );
    // A photo listed twice in the file, and one given twice.
    std::fs::write(
        d.join("geo3.txt"),
        "EPSG:4326\na.jpg 1 2 3\nb.jpg 1 2 3\na.jpg 1 2 3\n",
    )
    .unwrap();
    fails(
        &batch(&["--geo", "geo3.txt"]),
        &["geo3.txt", "'a.jpg' is listed twice (lines 2 and 4)"],
    );
    fails(
        &aerorect(
            &[
                "batch",
                "a.jpg",
                "./a.jpg",
                "--camera",
                "cam.toml",
                "--out-dir",
                "o2",
            ],
            &d,
        ),
        &["a.jpg", "given twice"],
    );
    // GPS in EXIF-like tags but an XMP packet that is not XML.
    let broken = dji(53.9, 27.55, Some((0.0, -90.0))).replace("</rdf:RDF>", "</rdf:RDX>");
    jpeg_with_xmp(&d, "bad.jpg", Some(&broken));
    fails(
        &aerorect(
            &["rectify", "bad.jpg", "bad.tif", "--camera", "cam.toml"],
            &d,
        ),
        &["bad.jpg", "XMP packet is not valid XML"],
    );
    assert!(!d.join("bad.tif").exists());
    // Neither attitude nor GPS.
    jpeg_with_xmp(&d, "none.jpg", None);
    fails(
        &aerorect(
            &["rectify", "none.jpg", "none.tif", "--camera", "cam.toml"],
            &d,
        ),
        &[
            "none.jpg",
            "no attitude",
            "no GPS position",
            "not in --geo or --poses",
            "give --attitude, --geo or --poses",
        ],
    );
}
