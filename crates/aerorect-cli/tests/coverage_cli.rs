//! `calibrate --coverage-svg`: the report's heat map counts the points of each cell (checked
//! against a direct count of the CSV), and the SVG has one labelled cell per count.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, ok};
use std::path::Path;

#[test]
fn calibration_report_has_the_coverage_heat_map() {
    let dir = tempfile::tempdir().unwrap();
    let pts = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_corners.csv");
    let pts = pts.to_str().unwrap();
    ok(&aerorect(
        &[
            "calibrate",
            "--points",
            pts,
            "--image-size",
            "640x480",
            "--model",
            "opencv",
            "--json",
            "r.json",
            "--coverage-svg",
            "cov.svg",
        ],
        dir.path(),
    ));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("r.json")).unwrap()).unwrap();
    let counts: Vec<u64> = r["coverage"]["counts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(
        (
            r["coverage"]["cols"].as_u64(),
            r["coverage"]["rows"].as_u64()
        ),
        (Some(8), Some(6))
    );
    // A direct count: 80-pixel cells of the image's extent -0.5 .. 639.5 x -0.5 .. 479.5.
    let mut direct = vec![0u64; 48];
    let text = std::fs::read_to_string(pts).unwrap();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (u, v): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let (c, r) = (((u + 0.5) / 80.0) as usize, ((v + 0.5) / 80.0) as usize);
        direct[r.min(5) * 8 + c.min(7)] += 1;
    }
    assert_eq!(counts, direct);
    assert!(
        r["coverage"]["empty_corners"]
            .as_array()
            .unwrap()
            .is_empty()
    );
    let svg = std::fs::read_to_string(dir.path().join("cov.svg")).unwrap();
    for n in &counts {
        assert!(
            svg.contains(&format!(">\n{n}\n</text>")),
            "no cell labelled {n}"
        );
    }
    assert_eq!(svg.matches("<text").count(), 48 + 1);
}
