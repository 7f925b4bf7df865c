//! Helpers shared by the CLI tests: run the binary, expect success or a failure naming things.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::Path;
use std::process::{Command, Output};

pub fn aerorect(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// The path of a bundled file under the repository's data/ folder.
pub fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name)
        .to_str()
        .unwrap()
        .to_string()
}

/// Asserts success and returns stdout.
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Asserts failure with every needle in stderr.
pub fn fails(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "should have failed; stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    for n in needles {
        assert!(err.contains(n), "stderr lacks '{n}': {err}");
    }
}

/// The bundled JPEG (data/aero1.jpg) with an APP1 XMP packet inserted after SOI, written to
/// `dir/name`.
pub fn jpeg_with_xmp(dir: &Path, name: &str, xmp: Option<&str>) -> std::path::PathBuf {
    let jpeg =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg")).unwrap();
    let mut out = jpeg[..2].to_vec();
    if let Some(x) = xmp {
        let mut payload = b"http://ns.adobe.com/xap/1.0/\0".to_vec();
        payload.extend_from_slice(x.as_bytes());
        out.extend_from_slice(&[0xff, 0xe1]);
        out.extend_from_slice(&((payload.len() + 2) as u16).to_be_bytes());
        out.extend_from_slice(&payload);
    }
    out.extend_from_slice(&jpeg[2..]);
    let p = dir.join(name);
    std::fs::write(&p, out).unwrap();
    p
}

/// The angle (deg) between two omega-phi-kappa attitudes (degrees).
pub fn angle_opk_deg(a: &[f64], b: &[f64]) -> f64 {
    let r = |o: &[f64]| {
        aerorect::core::CameraRotation::omega_phi_kappa(o[0], o[1], o[2])
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

/// A rendered flight's frames (`sim/frames`, aerorect's `examples/simulate_flight.rs`), sorted.
pub fn rendered_frames(sim: &Path) -> Vec<std::path::PathBuf> {
    let mut frames: Vec<_> = std::fs::read_dir(sim.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    frames.sort();
    frames
}

/// `batch --adjust` of a rendered flight's `frames` (aerorect's `examples/simulate_flight.rs`,
/// its `cam.toml` and `dem.tif` in `sim`) into `out`, the positions from `source`
/// (`["--poses", "pert.csv"]` or `["--geo", "geo.txt"]`, the file in `sim`), at 0.25 m and an
/// attitude prior of 1 deg; its `adjustment.json`.
pub fn batch_adjust_rendered(
    frames: &[std::path::PathBuf],
    sim: &Path,
    source: [&str; 2],
    out: &Path,
) -> serde_json::Value {
    let dem = sim.join("dem.tif");
    let ground = ["--dem".as_ref(), dem.as_os_str()];
    batch_adjust_over(
        frames,
        sim,
        source,
        &ground,
        &["--attitude-sigma-deg", "1"],
        out,
    )
}

/// [`batch_adjust_rendered`] over the `ground` given (`--dem FILE` or `--ground-height-m H`),
/// with `extra` arguments (no attitude prior of its own).
pub fn batch_adjust_over(
    frames: &[std::path::PathBuf],
    sim: &Path,
    source: [&str; 2],
    ground: &[&std::ffi::OsStr],
    extra: &[&str],
    out: &Path,
) -> serde_json::Value {
    let status = Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .arg("batch")
        .args(frames)
        .arg("--out-dir")
        .arg(out)
        .arg(source[0])
        .arg(sim.join(source[1]))
        .arg("--camera")
        .arg(sim.join("cam.toml"))
        .args(ground)
        .args(["--gsd-m", "0.25", "--adjust"])
        .args(extra)
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    serde_json::from_str(&std::fs::read_to_string(out.join("adjustment.json")).unwrap()).unwrap()
}

/// `batch --adjust` of a rendered flight's `frames` (see [`batch_adjust_rendered`]) into `out`
/// with no DEM (level ground at 25 m, the hills' mean), the positions from the pose table
/// `poses` (in `sim`) and the simulation's ground control (`gcp_list.txt`, its
/// `checkpoints.txt` kept out): its `accuracy.json` and `adjustment.json`.
pub fn batch_adjust_controlled(
    frames: &[std::path::PathBuf],
    sim: &Path,
    poses: &str,
    out: &Path,
) -> (serde_json::Value, serde_json::Value) {
    let checks = std::fs::read_to_string(sim.join("checkpoints.txt")).unwrap();
    let status = Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .arg("batch")
        .args(frames)
        .arg("--out-dir")
        .arg(out)
        .args(["--poses", poses, "--camera", "cam.toml"])
        .args(["--ground-height-m", "25", "--gsd-m", "0.25", "--adjust"])
        .args(["--attitude-sigma-deg", "1", "--gcps", "gcp_list.txt"])
        .args(["--checkpoints", checks.trim()])
        .current_dir(sim)
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success());
    let read = |name: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join(name)).unwrap()).unwrap()
    };
    (read("accuracy.json"), read("adjustment.json"))
}

/// A pose table (`filename,x,y,z,omega,phi,kappa`): file name (without folders) -> the
/// numbers after it.
pub fn pose_table(path: &Path) -> std::collections::BTreeMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let name = f[0].rsplit('/').next().unwrap().to_string();
            let v = f[1..].iter().map(|s| s.trim().parse().unwrap()).collect();
            (name, v)
        })
        .collect()
}
