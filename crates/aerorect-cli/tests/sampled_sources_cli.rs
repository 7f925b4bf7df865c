//! A rendered flight over its DEM (aerorect's `examples/simulate_flight.rs`: 5 x 4 nadir
//! frames 130 m over hills, every attitude recorded N(0, 1 deg) off): `batch --adjust` over
//! the DEM weighs the two tie sources in the features round, on a correlated sample of its
//! pairs. SIFT's ties on these frames agree better than correlation's on the rendered grid,
//! so the rounds end with the features round, no correlation round is run, and the last
//! solve takes the features' spare ties; the frames end near the truth.
#![allow(clippy::unwrap_used)]

#[path = "../../aerorect/examples/simulate_flight.rs"]
#[allow(dead_code)]
mod simulate_flight;

use aerorect::core::CameraRotation;
use std::collections::BTreeMap;
use std::process::Command;

/// filename -> (omega, phi, kappa) degrees of a pose table.
fn attitudes(path: &std::path::Path) -> BTreeMap<String, [f64; 3]> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let name = f[0].rsplit('/').next().unwrap().to_string();
            let v = |k: usize| f[k].trim().parse::<f64>().unwrap();
            (name, [v(4), v(5), v(6)])
        })
        .collect()
}

/// The angle (deg) between two omega-phi-kappa attitudes.
fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let r = |o: [f64; 3]| {
        CameraRotation::omega_phi_kappa(o[0], o[1], o[2])
            .unwrap()
            .ground_from_camera()
            .to_owned()
    };
    let d = r(a) * r(b).transpose();
    ((d.trace() - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

#[test]
fn features_that_agree_better_than_a_correlated_sample_end_the_rounds() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(5, 4, &sim, 1.0, false);
    let mut frames: Vec<_> = std::fs::read_dir(sim.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    frames.sort();
    let out = tmp.path().join("out");
    let status = Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .arg("batch")
        .args(&frames)
        .arg("--out-dir")
        .arg(&out)
        .arg("--poses")
        .arg(sim.join("pert.csv"))
        .arg("--camera")
        .arg(sim.join("cam.toml"))
        .arg("--dem")
        .arg(sim.join("dem.tif"))
        .args(["--gsd-m", "0.25", "--adjust", "--attitude-sigma-deg", "1"])
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("adjustment.json")).unwrap())
            .unwrap();
    let rounds = r["rounds"].as_array().unwrap();
    let first = &rounds[0];
    eprintln!("{} round(s); the first: {first}", rounds.len());
    let sources = &first["sources"];
    let (sampled, weight) = (
        sources["sampled_pairs"].as_u64().unwrap(),
        sources["feature_weight"].as_f64().unwrap(),
    );
    // The weight is the squared ratio of the sample's two median gaps.
    let (fg, cg) = (
        sources["feature_gap_m"].as_f64().unwrap(),
        sources["correlation_gap_m"].as_f64().unwrap(),
    );
    assert!(
        ((cg / fg).powi(2) - weight).abs() < 1e-9 * weight,
        "{sources}"
    );
    assert!(sampled >= 1 && weight >= 1.0, "{sources}");
    assert_eq!(first["held_by_features"], true);
    assert_eq!(rounds.len(), 1, "a correlation round was run: {rounds:?}");
    assert!(
        first["final_solve"]["tie_points"].as_u64().unwrap()
            > first["tie_points"].as_u64().unwrap()
    );
    assert_eq!(r["settled"], true);
    // Against the truth: every frame recorded about 1.7 deg off (three axes of 1 deg) ends
    // within a twentieth of a degree.
    let truth = attitudes(&sim.join("truth.csv"));
    let adjusted = attitudes(&out.join("adjusted_poses.csv"));
    let recorded = attitudes(&sim.join("pert.csv"));
    let mut errors: Vec<f64> = Vec::new();
    for (name, t) in &truth {
        let (a, p) = (adjusted[name], recorded[name]);
        errors.push(angle_deg(a, *t));
        assert!(
            angle_deg(p, *t) > 0.1,
            "{name}: recorded too close to the truth"
        );
    }
    errors.sort_by(f64::total_cmp);
    eprintln!(
        "attitude error median {:.4} max {:.4} deg",
        errors[errors.len() / 2],
        errors[errors.len() - 1]
    );
    assert_eq!(errors.len(), 20);
    assert!(errors[errors.len() - 1] < 0.05, "{errors:?}");
}
