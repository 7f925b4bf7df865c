//! Issue 12: inputs that used to give a wrong answer (or an unreadable message) with exit 0 are
//! refused, each message naming the file, field and value; nothing is written.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";
const CAM: &str = "fx_px = 300.0\nfy_px = 300.0\nimage_size_px = [320, 240]\n";

/// The bundled scene, a camera file and a frame simulated from them with check points.
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg");
    std::fs::copy(scene, d.join("scene.jpg")).unwrap();
    std::fs::write(d.join("cam.toml"), CAM).unwrap();
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
            "20",
            "--checkpoints-out",
            "cp.csv",
        ],
        &d,
    ));
    (dir, d)
}

fn files(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn non_finite_distortion_coefficients_are_refused() {
    let (_t, d) = fixture();
    for (value, shown) in [("nan", "NaN"), ("-inf", "-inf"), ("inf", "inf")] {
        std::fs::write(
            d.join("bad.toml"),
            format!("{CAM}[distortion]\nmodel = \"opencv\"\nk1 = {value}\n"),
        )
        .unwrap();
        let before = files(&d);
        let needles = ["bad.toml", "k1", shown];
        let cases: [&[&str]; 3] = [
            &[
                "rectify",
                "frame.png",
                "r.png",
                "--camera",
                "bad.toml",
                "--attitude",
                ATT,
            ],
            &["undistort", "frame.png", "u.png", "--camera", "bad.toml"],
            &[
                "evaluate",
                "--camera",
                "bad.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                "cp.csv",
            ],
        ];
        for args in cases {
            fails(&aerorect(args, &d), &needles);
        }
        assert_eq!(files(&d), before, "nothing written");
    }
}
