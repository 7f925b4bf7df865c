//! `calibrate --images`: chessboard photos (OpenCV's left*.jpg in data/calib-opencv).
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, data, fails, ok};
use std::path::Path;

fn photos(names: &[&str]) -> Vec<String> {
    names
        .iter()
        .map(|n| data(&format!("calib-opencv/{n}")))
        .collect()
}

/// The rows of an `image,X,Y,Z,u,v` file (plain CSV: no quoted fields).
fn rows(path: &Path) -> Vec<(String, [f64; 5])> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("image,X,Y,Z,u,v"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let v = |i: usize| f[i].parse::<f64>().unwrap();
            (f[0].to_string(), [v(1), v(2), v(3), v(4), v(5)])
        })
        .collect()
}

/// A photo without a board is listed and skipped; the saved corners are OpenCV's (its CSV) and
/// give the same calibration through --points.
#[test]
fn saved_corners_are_opencvs_and_calibrate_alike_through_points() {
    let dir = tempfile::tempdir().unwrap();
    let mut args: Vec<String> = ["calibrate", "--model", "opencv", "--images"]
        .map(String::from)
        .to_vec();
    args.extend(photos(&[
        "left01.jpg",
        "left03.jpg",
        "left04.jpg",
        "left05.jpg",
    ]));
    args.push(data("aero1.jpg"));
    args.extend(
        [
            "--board",
            "9x6",
            "--square-m",
            "0.025",
            "--save-corners",
            "c.csv",
            "--json",
            "a.json",
        ]
        .map(String::from),
    );
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = ok(&aerorect(&argv, dir.path()));
    assert!(
        out.lines()
            .any(|l| l.contains("aero1.jpg") && l.contains("skipped")),
        "{out}"
    );
    let ours = rows(&dir.path().join("c.csv"));
    assert_eq!(ours.len(), 4 * 54);
    let theirs = rows(Path::new(&data("calib/left_corners.csv")));
    for img in ["left01.jpg", "left03.jpg", "left04.jpg", "left05.jpg"] {
        let of = |r: &[(String, [f64; 5])]| -> Vec<[f64; 5]> {
            r.iter()
                .filter(|(i, _)| i == img)
                .map(|(_, v)| *v)
                .collect()
        };
        let (a, b) = (of(&ours), of(&theirs));
        assert_eq!(a.len(), b.len(), "{img}");
        for (k, (p, q)) in a.iter().zip(&b).enumerate() {
            assert!(
                (p[0] - q[0]).abs() < 1e-9 && (p[1] - q[1]).abs() < 1e-9,
                "{img} {k}"
            );
            assert!(
                (p[3] - q[3]).hypot(p[4] - q[4]) < 0.01,
                "{img} corner {k}: {p:?} vs {q:?}"
            );
        }
    }
    let again = [
        "calibrate",
        "--model",
        "opencv",
        "--points",
        "c.csv",
        "--image-size",
        "640x480",
        "--json",
        "b.json",
    ];
    ok(&aerorect(&again, dir.path()));
    let fx = |f: &str| {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.path().join(f)).unwrap()).unwrap();
        v["fx"].as_f64().unwrap()
    };
    assert!((fx("a.json") - fx("b.json")).abs() < 1e-6);
}

#[test]
fn bad_requests_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let left = photos(&["left01.jpg", "left03.jpg"]);
    let base = [
        "calibrate",
        "--model",
        "opencv",
        "--board",
        "9x6",
        "--square-m",
        "0.025",
    ];
    let run = |extra: &[&str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        a.extend(["--save-corners", "c.csv"]);
        aerorect(&a, dir.path())
    };
    // Too few boards: one photo has none.
    let aero = data("aero1.jpg");
    fails(
        &run(&["--images", &left[0], &aero]),
        &["only 1 of 2 photos", "at least 3"],
    );
    // Different sizes: the error names the photo.
    let tiny = data("fixtures/strips_lzw_gray8.tif");
    fails(
        &run(&["--images", &left[0], &left[1], &tiny]),
        &["strips_lzw_gray8.tif", "one size"],
    );
    // --points and --images together, and a bad board.
    let pts = data("calib/left_corners.csv");
    fails(
        &run(&["--images", &left[0], "--points", &pts]),
        &["cannot be used with"],
    );
    let out = aerorect(
        &[
            "calibrate",
            "--model",
            "opencv",
            "--images",
            &left[0],
            "--board",
            "9",
            "--square-m",
            "0.025",
        ],
        dir.path(),
    );
    fails(&out, &["--board '9'"]);
    assert!(!dir.path().join("c.csv").exists());
}
