//! shift, velocity, track and motion-sim end to end.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use aerorect::core::ImageSize;
use aerorect::io::{read_image, write_image};
use aerorect::raster::{AnyRaster, Raster};
use std::path::Path;

/// 160 x 120 windows of the bundled photo's green band, the content moved by whole pixels.
fn write_frames(dir: &Path, shifts: &[(i64, i64)]) {
    let scene =
        read_image(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg")).unwrap();
    let AnyRaster::U8(scene) = scene else {
        panic!("u8 expected")
    };
    for (k, &(dx, dy)) in shifts.iter().enumerate() {
        let plane: Vec<u8> = (0..160 * 120)
            .map(|i| {
                let (x, y) = ((i % 160) as i64 + 200 - dx, (i / 160) as i64 + 150 - dy);
                scene.get(1, x as usize, y as usize).unwrap()
            })
            .collect();
        let img =
            AnyRaster::U8(Raster::from_planes(ImageSize::new(160, 120), vec![plane]).unwrap());
        write_image(&dir.join(format!("f{k}.png")), &img).unwrap();
    }
}

#[test]
fn shift_reports_the_moved_content_with_the_documented_sign() {
    let dir = tempfile::tempdir().unwrap();
    write_frames(dir.path(), &[(0, 0), (3, -2)]);
    for method in ["jtc", "xcorr", "phase"] {
        let out = ok(&aerorect(
            &["shift", "f0.png", "f1.png", "--method", method, "--json"],
            dir.path(),
        ));
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v.as_object().unwrap().len(), 3, "{out}");
        let (dx, dy) = (v["dx"].as_f64().unwrap(), v["dy"].as_f64().unwrap());
        let tol = if method == "jtc" { 0.15 } else { 0.05 };
        assert!(
            (dx - 3.0).abs() < tol && (dy + 2.0).abs() < tol,
            "{method}: {out}"
        );
        assert!(v["confidence"].as_f64().unwrap() > 0.3);
    }
}

#[test]
fn shift_refuses_bad_pairs() {
    let dir = tempfile::tempdir().unwrap();
    write_frames(dir.path(), &[(0, 0)]);
    let flat = AnyRaster::U8(Raster::filled(ImageSize::new(160, 120), 1, 7u8).unwrap());
    write_image(&dir.path().join("flat.png"), &flat).unwrap();
    fails(
        &aerorect(&["shift", "f0.png", "flat.png"], dir.path()),
        &["current frame is constant"],
    );
    let small = AnyRaster::U8(Raster::filled(ImageSize::new(16, 16), 1, 7u8).unwrap());
    write_image(&dir.path().join("small.png"), &small).unwrap();
    fails(
        &aerorect(&["shift", "f0.png", "small.png"], dir.path()),
        &["small.png is 16 x 16"],
    );
    fails(
        &aerorect(
            &["shift", "f0.png", "f0.png", "--method", "fast"],
            dir.path(),
        ),
        &["unknown method 'fast'"],
    );
}

#[test]
fn velocity_json_matches_the_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "velocity",
        "--focal-length-mm",
        "200",
        "--height-m",
        "4000",
        "--speed-mps",
        "100",
        "--swing-deg",
        "20",
        "--swing-rate-dps",
        "10",
        "--roll-rate-dps",
        "2",
        "--sigma-height-m",
        "40",
        "--json",
    ];
    let v: serde_json::Value = serde_json::from_str(&ok(&aerorect(&args, dir.path()))).unwrap();
    let a = 20f64.to_radians();
    let vf = 100.0 * a.cos() / 4000.0 * 200.0;
    assert!((v["v_forward_mm_s"].as_f64().unwrap() - vf).abs() < 1e-9);
    assert!((v["v_swing_mm_s"].as_f64().unwrap() - 8f64.to_radians() * 200.0).abs() < 1e-9);
    assert!((v["mirror_rate_dps"].as_f64().unwrap() - (vf / 400.0).to_degrees()).abs() < 1e-9);
    // the only non-zero term of dV_F: dH * f V cos a / H^2
    let rss = v["forward_budget"]["rss_mm_s"].as_f64().unwrap();
    assert!((rss - 40.0 * 200.0 * 100.0 * a.cos() / 4000f64.powi(2)).abs() < 1e-9);
    fails(
        &aerorect(
            &[
                "velocity",
                "--focal-length-mm",
                "200",
                "--height-m",
                "0",
                "--speed-mps",
                "1",
                "--swing-deg",
                "0",
                "--swing-rate-dps",
                "0",
            ],
            dir.path(),
        ),
        &["--height-m 0"],
    );
    fails(
        &aerorect(
            &[
                "velocity",
                "--focal-length-mm",
                "200",
                "--height-m",
                "10",
                "--speed-mps",
                "1",
                "--swing-deg",
                "95",
                "--swing-rate-dps",
                "0",
            ],
            dir.path(),
        ),
        &["--swing-deg 95"],
    );
}

#[test]
fn track_prints_each_step_and_the_corrected_velocities() {
    let dir = tempfile::tempdir().unwrap();
    write_frames(dir.path(), &[(0, 0), (2, 1), (3, -1)]);
    let args = [
        "track",
        "f0.png",
        "f1.png",
        "f2.png",
        "--method",
        "xcorr",
        "--frame-period-s",
        "0.002",
        "--pixel-pitch-um",
        "10",
        "--focal-length-mm",
        "100",
        "--height-m",
        "1000",
        "--speed-mps",
        "50",
        "--swing-deg",
        "0",
        "--swing-rate-dps",
        "0",
    ];
    let out = ok(&aerorect(&args, dir.path()));
    let lines: Vec<Vec<f64>> = out
        .lines()
        .skip(1)
        .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(lines.len(), 2, "{out}");
    for (l, (dx, dy)) in lines.iter().zip([(2.0, 1.0), (1.0, -2.0)]) {
        assert!(
            (l[0] - dx).abs() < 0.05 && (l[1] - dy).abs() < 0.05,
            "{out}"
        );
        // x = swing, y = forward; V_F = 50/1000*100 = 5 mm/s; each pixel is 0.01 mm in 0.002 s.
        assert!((l[4] - (0.0 + l[0] * 0.01 / 0.002)).abs() < 1e-3, "{out}");
        assert!((l[5] - (5.0 + l[1] * 0.01 / 0.002)).abs() < 1e-3, "{out}");
    }
    std::fs::write(dir.path().join("bad.png"), "not a png").unwrap();
    let out = aerorect(
        &["track", "f0.png", "bad.png", "f1.png", "--method", "xcorr"],
        dir.path(),
    );
    fails(&out, &["1 frame(s) skipped: bad.png"]);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().count(),
        2,
        "the good pair is still reported"
    );
}

#[test]
fn motion_sim_prints_the_table_and_writes_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg");
    let args = [
        "motion-sim",
        scene.to_str().unwrap(),
        "--size",
        "64",
        "--trials",
        "4",
        "--snr-db=-2,20",
        "--plot",
        "p.svg",
        "--json",
        "t.json",
    ];
    let out = ok(&aerorect(&args, dir.path()));
    assert!(out.contains("aero1") && out.contains("xcorr"), "{out}");
    assert!(
        std::fs::read_to_string(dir.path().join("p.svg"))
            .unwrap()
            .contains("<svg")
    );
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("t.json")).unwrap()).unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 2 * 4, "2 SNRs x the 4 default methods");
    for r in rows {
        assert!(
            r["error_rms_px"].as_f64().unwrap() >= 0.0 && r["crlb_rms_px"].as_f64().unwrap() > 0.0
        );
    }
    // More noise, a larger bound.
    assert!(rows[0]["crlb_rms_px"].as_f64().unwrap() > rows[4]["crlb_rms_px"].as_f64().unwrap());
}
