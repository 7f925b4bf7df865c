//! The `aerorect` binary end to end: the round trip, the report, and refusals of bad input.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";

/// A scene, a camera file and a simulated frame with check points in a fresh folder.
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg");
    std::fs::copy(scene, d.join("scene.jpg")).unwrap();
    std::fs::write(
        d.join("cam.toml"),
        "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [320, 240]\n",
    )
    .unwrap();
    ok(&aerorect(
        &[
            "simulate",
            "scene.jpg",
            "frame.png",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--checkpoints",
            "25",
            "--checkpoints-out",
            "cp.csv",
        ],
        &d,
    ));
    (dir, d)
}

#[test]
fn simulate_rectify_evaluate_round_trip() {
    let (_t, d) = fixture();
    let out = ok(&aerorect(
        &[
            "evaluate",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--checkpoints",
            "cp.csv",
            "--json",
        ],
        &d,
    ));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    for key in ["du_max", "dv_max", "urms", "vrms", "rmse"] {
        assert!(v[key].is_number(), "{key} in {out}");
    }
    assert!(v["rmse"].as_f64().unwrap() < 0.01);
    let wrong = "azimuth=10,elevation=25.1,image_rotation=1,pitch=2,roll=-1,yaw=30";
    let out = ok(&aerorect(
        &[
            "evaluate",
            "--camera",
            "cam.toml",
            "--attitude",
            wrong,
            "--checkpoints",
            "cp.csv",
            "--json",
        ],
        &d,
    ));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(
        v["rmse"].as_f64().unwrap() > 0.3,
        "a 0.1 degree error shows: {out}"
    );

    ok(&aerorect(
        &[
            "rectify",
            "frame.png",
            "rect.tif",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--interp",
            "bicubic",
            "--alpha",
            "--report",
            "r.json",
        ],
        &d,
    ));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    for key in [
        "homography_output_to_input",
        "output_size",
        "standard_origin",
        "clipped",
        "interp",
        "warp_seconds",
        "attitude_deg",
        "intrinsics_px",
    ] {
        assert!(!r[key].is_null(), "report lacks {key}");
    }
    assert_eq!(r["interp"], "bicubic");
    assert_eq!(r["clipped"], false);
    // The report's two homographies agree: output (c, r) -> input -> standard = (c, r) + origin.
    let m = |k: &str| -> Vec<Vec<f64>> { serde_json::from_value(r[k].clone()).unwrap() };
    let (g, f) = (
        m("homography_output_to_input"),
        m("homography_input_to_standard"),
    );
    let apply = |h: &Vec<Vec<f64>>, p: [f64; 2]| {
        let w = h[2][0] * p[0] + h[2][1] * p[1] + h[2][2];
        [
            (h[0][0] * p[0] + h[0][1] * p[1] + h[0][2]) / w,
            (h[1][0] * p[0] + h[1][1] * p[1] + h[1][2]) / w,
        ]
    };
    let origin: [f64; 2] = serde_json::from_value(r["standard_origin"].clone()).unwrap();
    for p in [[0.0, 0.0], [100.0, 50.0], [200.0, 150.0]] {
        let s = apply(&f, apply(&g, p));
        assert!((s[0] - p[0] - origin[0]).abs() < 1e-8 && (s[1] - p[1] - origin[1]).abs() < 1e-8);
    }
    let size: [usize; 2] = serde_json::from_value(r["output_size"].clone()).unwrap();
    let img = aerorect::io::read_image(&d.join("rect.tif")).unwrap();
    assert_eq!(
        (img.size().width, img.size().height, img.bands()),
        (size[0], size[1], 4),
        "RGB + alpha"
    );
}

#[test]
fn bad_camera_and_attitude_files_name_the_field() {
    let (_t, d) = fixture();
    let cases: &[(&str, &[&str])] = &[
        (
            "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nfocal = 3\n",
            &["bad.toml", "unknown field `focal`"],
        ),
        (
            "pixel_pitch_um = [15.0, 15.0]\n",
            &["bad.toml", "missing key focal_length_mm"],
        ),
        (
            "focal_length_mm = 0.0\npixel_pitch_um = [15.0, 15.0]\n",
            &["bad.toml", "focal_length_mm = 0"],
        ),
        (
            "focal_length_mm = 6.0\npixel_pitch_um = [-15.0, 15.0]\n",
            &["bad.toml", "pixel_pitch_um[0] = -15"],
        ),
        (
            "focal_length_mm = inf\npixel_pitch_um = [15.0, 15.0]\n",
            &["bad.toml", "focal_length_mm = inf"],
        ),
    ];
    for (text, needles) in cases {
        std::fs::write(d.join("bad.toml"), text).unwrap();
        fails(
            &aerorect(
                &[
                    "rectify",
                    "frame.png",
                    "o.tif",
                    "--camera",
                    "bad.toml",
                    "--attitude",
                    ATT,
                ],
                &d,
            ),
            needles,
        );
        assert!(!d.join("o.tif").exists());
    }
    let bad_att: &[(&str, &[&str])] = &[
        (
            "azimuth=1,elevation=2,image_rotation=0,pitch=0,roll=0",
            &["missing key yaw"],
        ),
        (
            "azimuth=1,elevation=2,image_rotation=0,pitch=0,roll=0,yaw=0,heading=4",
            &["unknown key 'heading'"],
        ),
        (
            "azimuth=1,elevation=NaN,image_rotation=0,pitch=0,roll=0,yaw=0",
            &["elevation = NaN"],
        ),
        (
            "azimuth=1,elevation=2,image_rotation=0,pitch=120,roll=0,yaw=0",
            &["pitch = 120"],
        ),
        ("no-such-file.toml", &["no-such-file.toml"]),
    ];
    for (att, needles) in bad_att {
        fails(
            &aerorect(
                &[
                    "rectify",
                    "frame.png",
                    "o.tif",
                    "--camera",
                    "cam.toml",
                    "--attitude",
                    att,
                ],
                &d,
            ),
            needles,
        );
        assert!(!d.join("o.tif").exists());
    }
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--altitude-m",
                "0",
                "--base-altitude-m",
                "100",
            ],
            &d,
        ),
        &["altitude_m = 0"],
    );
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.png",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--nodata",
                "300",
            ],
            &d,
        ),
        &["--nodata 300"],
    );
}

#[test]
fn bad_images_and_outputs_are_refused_and_nothing_is_written() {
    let (_t, d) = fixture();
    let before = std::fs::read(d.join("frame.png")).unwrap();
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "./frame.png",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
            ],
            &d,
        ),
        &["frame.png", "overwrite the input"],
    );
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--report",
                "frame.png",
            ],
            &d,
        ),
        &["overwrite the input"],
    );
    assert_eq!(
        std::fs::read(d.join("frame.png")).unwrap(),
        before,
        "input untouched"
    );

    std::fs::write(d.join("cut.png"), &before[..before.len() / 2]).unwrap();
    fails(
        &aerorect(
            &[
                "rectify",
                "cut.png",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
            ],
            &d,
        ),
        &["cut.png"],
    );
    std::fs::write(d.join("text.tif"), "II*\0 this is not really a tiff").unwrap();
    fails(
        &aerorect(
            &[
                "rectify",
                "text.tif",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
            ],
            &d,
        ),
        &["text.tif"],
    );

    let sky = "azimuth=0,elevation=90,image_rotation=0,pitch=0,roll=40,yaw=0";
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                sky,
            ],
            &d,
        ),
        &["frame.png", "sees no ground"],
    );
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--max-output-px",
                "1000",
            ],
            &d,
        ),
        &["exceeds the limit of 1000 px"],
    );
    // A camera of another aspect ratio is refused (a resized frame is scaled, see below).
    let other =
        "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [640, 640]\n";
    std::fs::write(d.join("cam640.toml"), other).unwrap();
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.tif",
                "--camera",
                "cam640.toml",
                "--attitude",
                ATT,
            ],
            &d,
        ),
        &[
            "cam640.toml",
            "image_size_px = [640, 640] but the image is 320 x 240",
        ],
    );
    fails(
        &aerorect(
            &[
                "rectify",
                "frame.png",
                "o.jpg",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
            ],
            &d,
        ),
        &["o.jpg", "unknown output format"],
    );
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with("o.") || n.ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// A camera file written for twice the frame's size (half the pixel pitch) rectifies the frame
/// exactly like the camera file of its own size: fx = 6 mm / 7.5 um / 2 = 6 mm / 15 um and
/// cx = (319.5 + 0.5) / 2 - 0.5 = 159.5.
#[test]
fn a_camera_for_a_larger_image_of_the_same_aspect_is_scaled() {
    let (_t, d) = fixture();
    let big = "focal_length_mm = 6.0\npixel_pitch_um = [7.5, 7.5]\nimage_size_px = [640, 480]\n";
    std::fs::write(d.join("cam640.toml"), big).unwrap();
    let report = |cam: &str, out: &str| -> serde_json::Value {
        let json = format!("{out}.json");
        ok(&aerorect(
            &[
                "rectify",
                "frame.png",
                out,
                "--camera",
                cam,
                "--attitude",
                ATT,
                "--report",
                &json,
            ],
            &d,
        ));
        serde_json::from_str(&std::fs::read_to_string(d.join(&json)).unwrap()).unwrap()
    };
    let (own, scaled) = (
        report("cam.toml", "own.tif"),
        report("cam640.toml", "big.tif"),
    );
    for key in ["intrinsics_px", "output_size", "homography_output_to_input"] {
        assert_eq!(own[key], scaled[key], "{key}");
    }
    assert_eq!(scaled["intrinsics_px"]["fx"], 400.0);
    assert_eq!(scaled["intrinsics_px"]["cx"], 159.5);
}

#[test]
fn a_frame_across_the_horizon_is_clipped_and_says_so() {
    let (_t, d) = fixture();
    // Top edge at 80 + 16.7 degrees from nadir: above the horizon.
    let att = "azimuth=0,elevation=80,image_rotation=0,pitch=0,roll=0,yaw=0";
    ok(&aerorect(
        &[
            "rectify",
            "frame.png",
            "o.tif",
            "--camera",
            "cam.toml",
            "--attitude",
            att,
            "--max-output-px",
            "4000000",
            "--report",
            "r.json",
        ],
        &d,
    ));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    assert_eq!(r["clipped"], true);
    let s: [u64; 2] = serde_json::from_value(r["output_size"].clone()).unwrap();
    assert!(s[0] * s[1] <= 4_000_000 && s[0] * s[1] > 3_000_000, "{s:?}");
}

#[test]
fn demo_writes_its_files_and_reports() {
    let dir = tempfile::tempdir().unwrap();
    let out = ok(&aerorect(&["demo", "--out-dir", "demo"], dir.path()));
    assert!(out.contains("demo/oblique.png"), "{out}");
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("demo/summary.json")).unwrap(),
    )
    .unwrap();
    for f in s["files"].as_array().unwrap() {
        assert!(
            dir.path().join("demo").join(f.as_str().unwrap()).is_file(),
            "{f}"
        );
    }
    assert!(s["exact"]["rmse"].as_f64().unwrap() < 0.01);
    assert!(s["psnr_bicubic_db"][0].as_f64().unwrap() > 30.0);
}
