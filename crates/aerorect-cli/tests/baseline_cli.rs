//! `gcp`, `register` and `compare` end to end: reports checked against the numbers they
//! claim, and refusals of bad input.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";
const CAM: &str = "fx_px = 300.0\nfy_px = 300.0\nimage_size_px = [320, 240]\n";

/// The bundled scene, a simulated frame and its check points turned into GCPs (the standard
/// frame as the reference).
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
            "30",
            "--checkpoints-out",
            "cp.csv",
        ],
        &d,
    ));
    let cp = std::fs::read_to_string(d.join("cp.csv")).unwrap();
    let body: Vec<&str> = cp.lines().skip(1).collect();
    std::fs::write(
        d.join("gcps.csv"),
        format!("u_image,v_image,u_ref,v_ref\n{}\n", body.join("\n")),
    )
    .unwrap();
    (dir, d)
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn gcp_report_is_consistent_with_its_residuals_and_coefficients() {
    let (_t, d) = fixture();
    for model in ["projective", "quadratic", "bilinear", "cubic"] {
        ok(&aerorect(
            &[
                "gcp",
                "frame.png",
                "out.tif",
                "--gcps",
                "gcps.csv",
                "--model",
                model,
                "--report",
                "r.json",
            ],
            &d,
        ));
        let r = json(&d.join("r.json"));
        let res = r["residuals"].as_array().unwrap();
        assert_eq!(res.len(), 30);
        let ms: f64 = res
            .iter()
            .map(|g| g["du"].as_f64().unwrap().powi(2) + g["dv"].as_f64().unwrap().powi(2))
            .sum::<f64>()
            / 30.0;
        let rms = r["residual_rms_px"].as_f64().unwrap();
        assert!((rms - ms.sqrt()).abs() < 1e-12, "{model}");
        // The coefficients, evaluated by hand at each GCP's reference position, give its
        // measured image position minus the residual.
        let c = &r["coefficients"];
        for g in res {
            let (u, v) = (g["u_ref"].as_f64().unwrap(), g["v_ref"].as_f64().unwrap());
            let (pu, pv) = if model == "projective" {
                let m: Vec<Vec<f64>> = serde_json::from_value(c["matrix"].clone()).unwrap();
                let w = m[2][0] * u + m[2][1] * v + m[2][2];
                (
                    (m[0][0] * u + m[0][1] * v + m[0][2]) / w,
                    (m[1][0] * u + m[1][1] * v + m[1][2]) / w,
                )
            } else {
                let terms: Vec<String> = serde_json::from_value(c["terms"].clone()).unwrap();
                let eval = |k: &str| -> f64 {
                    let a: Vec<f64> = serde_json::from_value(c[k].clone()).unwrap();
                    terms
                        .iter()
                        .zip(&a)
                        .map(|(t, a)| {
                            let pu = t.matches('u').count() as i32
                                + t.find("u^")
                                    .map_or(0, |i| t[i + 2..i + 3].parse::<i32>().unwrap() - 1);
                            let pv = t.matches('v').count() as i32
                                + t.find("v^")
                                    .map_or(0, |i| t[i + 2..i + 3].parse::<i32>().unwrap() - 1);
                            a * u.powi(pu) * v.powi(pv)
                        })
                        .sum()
                };
                (eval("u"), eval("v"))
            };
            let du = g["u_image"].as_f64().unwrap() - pu;
            let dv = g["v_image"].as_f64().unwrap() - pv;
            assert!(
                (du - g["du"].as_f64().unwrap()).abs() < 1e-6,
                "{model}: {du}"
            );
            assert!(
                (dv - g["dv"].as_f64().unwrap()).abs() < 1e-6,
                "{model}: {dv}"
            );
        }
        if model == "projective" {
            assert!(rms < 1e-6, "exact GCPs of a homography: {rms}");
        }
        assert!(d.join("out.tif").is_file());
    }
}

#[test]
fn gcp_refuses_bad_tables_and_models() {
    let (_t, d) = fixture();
    std::fs::write(
        d.join("few.csv"),
        "u_image,v_image,u_ref,v_ref\n1,2,3,4\n5,6,7,9\n9,1,2,8\n",
    )
    .unwrap();
    fails(
        &aerorect(
            &[
                "gcp",
                "frame.png",
                "o.tif",
                "--gcps",
                "few.csv",
                "--model",
                "bilinear",
            ],
            &d,
        ),
        &["few.csv", "3 point pairs given, at least 4 needed"],
    );
    std::fs::write(
        d.join("line.csv"),
        "u_image,v_image,u_ref,v_ref\n1,1,1,1\n2,2,2,2\n3,3,3,3\n4,4,4,4\n5,5,5,5\n",
    )
    .unwrap();
    fails(
        &aerorect(
            &[
                "gcp",
                "frame.png",
                "o.tif",
                "--gcps",
                "line.csv",
                "--model",
                "bilinear",
            ],
            &d,
        ),
        &["degenerate"],
    );
    std::fs::write(d.join("hdr.csv"), "u,v,x,y\n1,2,3,4\n").unwrap();
    fails(
        &aerorect(&["gcp", "frame.png", "o.tif", "--gcps", "hdr.csv"], &d),
        &["hdr.csv", "header is 'u,v,x,y'"],
    );
    fails(
        &aerorect(
            &[
                "gcp",
                "frame.png",
                "o.tif",
                "--gcps",
                "gcps.csv",
                "--model",
                "spline",
            ],
            &d,
        ),
        &["--model 'spline'"],
    );
    fails(
        &aerorect(&["gcp", "frame.png", "frame.png", "--gcps", "gcps.csv"], &d),
        &["overwrite the input"],
    );
    assert!(!d.join("o.tif").exists());
}

#[test]
fn register_writes_the_reference_grid_and_reports_its_ties() {
    let (_t, d) = fixture();
    ok(&aerorect(
        &[
            "register",
            "frame.png",
            "scene.jpg",
            "reg.png",
            "--report",
            "reg.json",
        ],
        &d,
    ));
    let r = json(&d.join("reg.json"));
    let ties = r["ties"].as_array().unwrap();
    let inliers = ties
        .iter()
        .filter(|t| t["inlier"].as_bool().unwrap())
        .count();
    assert_eq!(inliers as u64, r["inliers"].as_u64().unwrap());
    assert_eq!(ties.len() as u64, r["tie_points"].as_u64().unwrap());
    assert!(inliers >= 20, "{inliers}");
    assert!(r["inlier_rms_px"].as_f64().unwrap() < 0.5);
    let img = aerorect::io::read_image(&d.join("reg.png")).unwrap();
    assert_eq!((img.size().width, img.size().height), (640, 480));
    fails(
        &aerorect(&["register", "frame.png", "scene.jpg", "scene.jpg"], &d),
        &["overwrite the input"],
    );
    fails(
        &aerorect(
            &[
                "register",
                "frame.png",
                "scene.jpg",
                "x.png",
                "--model",
                "tps",
            ],
            &d,
        ),
        &["unknown registration model 'tps'"],
    );
}

#[test]
fn compare_prints_four_rows_and_writes_json() {
    let (_t, d) = fixture();
    let out = ok(&aerorect(
        &[
            "compare",
            "scene.jpg",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--json",
            "t.json",
        ],
        &d,
    ));
    let r = json(&d.join("t.json"));
    let rows = r["rows"].as_array().unwrap();
    let methods: Vec<&str> = rows.iter().map(|x| x["method"].as_str().unwrap()).collect();
    assert_eq!(
        methods,
        ["registration", "quadratic", "bilinear", "six-angle"]
    );
    for row in rows {
        let (u, v, e) = (
            row["urms"].as_f64().unwrap(),
            row["vrms"].as_f64().unwrap(),
            row["rmse"].as_f64().unwrap(),
        );
        assert!((u.hypot(v) - e).abs() < 1e-12);
        assert!(out.contains(row["method"].as_str().unwrap()));
    }
}
