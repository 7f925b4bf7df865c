//! `aerorect camera convert`: a chain through every format ends where it started, and bad
//! requests fail naming what is wrong with nothing written.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};
use std::path::Path;

fn toml_values(text: &str) -> Vec<(String, f64)> {
    text.lines()
        .filter_map(|l| l.split_once(" = "))
        .filter_map(|(k, v)| Some((k.to_string(), v.trim().parse::<f64>().ok()?)))
        .collect()
}

#[test]
fn a_chain_through_every_format_returns_the_camera() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_intrinsics.yml");
    let chain = [
        src.to_str().unwrap().to_string(),
        d("start.toml"),
        d("a.xml"),
        d("cameras.txt"),
        d("cameras.json"),
        d("cal.xml"),
        d("dewarp.txt"),
        d("interior.yaml"),
        d("end.toml"),
    ];
    for pair in chain.windows(2) {
        let mut args = vec!["camera", "convert", &pair[0], &pair[1]];
        if pair[1].ends_with("a.xml") {
            args.extend(["--to", "opencv-xml"]);
        }
        if pair[1].ends_with("cal.xml") {
            args.extend(["--to", "metashape"]);
        }
        if pair[1].ends_with("dewarp.txt") {
            args.extend(["--to", "dji-dewarp"]);
        }
        if pair[0].ends_with("dewarp.txt") {
            args.extend(["--image-size", "640x480"]);
        }
        ok(&aerorect(&args, dir.path()));
    }
    let start = toml_values(&std::fs::read_to_string(d("start.toml")).unwrap());
    let end = toml_values(&std::fs::read_to_string(d("end.toml")).unwrap());
    assert_eq!(start.len(), end.len(), "{start:?} vs {end:?}");
    for ((ka, a), (kb, b)) in start.iter().zip(&end) {
        assert_eq!(ka, kb);
        assert!(
            (a - b).abs() <= 1e-9 * a.abs().max(b.abs()),
            "{ka}: {a} vs {b}"
        );
    }
}

#[test]
fn bad_conversions_fail_by_name_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_str().unwrap().to_string();
    let cam = d("skewed.toml");
    std::fs::write(
        &cam,
        "fx_px = 500.0\nfy_px = 500.0\ncx_px = 320.0\ncy_px = 240.0\nskew_px = 0.5\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    let out = d("cameras.txt");
    let run = |args: &[&str]| aerorect(args, dir.path());
    fails(
        &run(&["camera", "convert", &cam, &out]),
        &["skew", "cameras.txt"],
    );
    fails(&run(&["camera", "convert", &cam, &d("x.xml")]), &["--to"]);
    fails(
        &run(&["camera", "convert", &cam, &d("y.txt"), "--to", "fisheye"]),
        &["fisheye", "colmap"],
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}
