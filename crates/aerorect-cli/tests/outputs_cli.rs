//! Nothing lost (issue 12, items 3-5, 7-9): no output may replace an input or another output,
//! the outputs of one command land together or not at all, batch refuses name collisions and
//! keeps its report, and a signal leaves no temporary or partial file behind.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";
const XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-90.00" drone-dji:FlightYawDegree="+12.00"/></rdf:RDF></x:xmpmeta>"#;

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name)
}

/// The bundled JPEG with a DJI XMP packet (nadir, yaw 30 degrees, 80 m up).
fn drone_photo(path: &Path) {
    let (dir, name) = (path.parent().unwrap(), path.file_name().unwrap());
    common::jpeg_with_xmp(dir, name.to_str().unwrap(), Some(XMP));
}

/// A folder with a scene, camera files, an attitude file, a simulated frame, GCPs, control
/// points, a drone photo and a pose table.
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::copy(bundled("aero1.jpg"), d.join("scene.jpg")).unwrap();
    std::fs::copy(bundled("calib/left_corners.csv"), d.join("pts.csv")).unwrap();
    std::fs::write(
        d.join("cam.toml"),
        "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [320, 240]\n",
    )
    .unwrap();
    std::fs::write(
        d.join("drone.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    std::fs::write(d.join("att.toml"), ATT.replace(',', "\n")).unwrap();
    std::fs::write(
        d.join("gcps.csv"),
        "u_image,v_image,u_ref,v_ref\n10,10,12,11\n300,12,303,14\n12,220,13,222\n310,230,312,233\n160,120,162,122\n80,200,81,203\n",
    )
    .unwrap();
    std::fs::write(d.join("poses.csv"), "filename,x,y,z,omega,phi,kappa\n").unwrap();
    std::fs::write(d.join("dem.tif"), "not read: refused first").unwrap();
    drone_photo(&d.join("photo.jpg"));
    ok(&aerorect(
        &[
            "simulate",
            "scene.jpg",
            "frame.png",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
        ],
        &d,
    ));
    (dir, d)
}

/// Every file in `d` (recursively) with its bytes.
fn snapshot(d: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(d).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(snapshot(&p));
        } else {
            v.push((p.clone(), std::fs::read(&p).unwrap()));
        }
    }
    v.sort();
    v
}

/// Runs the command, expects a refusal naming `needles`, and nothing changed in the folder.
fn refused_and_untouched(d: &Path, args: &[&str], needles: &[&str]) {
    let before = snapshot(d);
    fails(&aerorect(args, d), needles);
    let after = snapshot(d);
    let names = |s: &[(PathBuf, Vec<u8>)]| s.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&after),
        names(&before),
        "files added or removed by {args:?}"
    );
    assert!(after == before, "a file changed under {args:?}");
}

#[test]
fn side_outputs_aimed_at_any_input_are_refused() {
    let (_t, d) = fixture();
    let rect = ["rectify", "frame.png", "o.tif", "--camera", "cam.toml"];
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        (
            [&rect[..], &["--attitude", ATT, "--report", "cam.toml"]].concat(),
            "--report",
            "--camera",
        ),
        (
            [
                &rect[..],
                &["--attitude", "att.toml", "--report", "att.toml"],
            ]
            .concat(),
            "--report",
            "--attitude",
        ),
        (
            vec![
                "simulate",
                "scene.jpg",
                "f.png",
                "--camera",
                "cam.toml",
                "--attitude",
                "att.toml",
                "--checkpoints",
                "5",
                "--checkpoints-out",
                "att.toml",
            ],
            "--checkpoints-out",
            "--attitude",
        ),
        (
            vec![
                "simulate",
                "scene.jpg",
                "f.png",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                "5",
                "--checkpoints-out",
                "cam.toml",
            ],
            "--checkpoints-out",
            "--camera",
        ),
        (
            vec![
                "calibrate",
                "--points",
                "pts.csv",
                "--image-size",
                "640x480",
                "--model",
                "opencv",
                "--json",
                "pts.csv",
            ],
            "--json",
            "--points",
        ),
        (
            vec![
                "calibrate",
                "--points",
                "pts.csv",
                "--image-size",
                "640x480",
                "--model",
                "opencv",
                "--camera-out",
                "./pts.csv",
            ],
            "--camera-out",
            "--points",
        ),
        (
            vec![
                "gcp",
                "frame.png",
                "o.tif",
                "--gcps",
                "gcps.csv",
                "--report",
                "gcps.csv",
            ],
            "--report",
            "--gcps",
        ),
        (
            vec![
                "register",
                "frame.png",
                "scene.jpg",
                "o.tif",
                "--report",
                "scene.jpg",
            ],
            "--report",
            "REFERENCE",
        ),
        (
            vec![
                "compare",
                "scene.jpg",
                "--camera",
                "cam.toml",
                "--frame-out",
                "cam.toml",
            ],
            "--frame-out",
            "--camera",
        ),
        (
            vec![
                "compare",
                "scene.jpg",
                "--attitude",
                "att.toml",
                "--json",
                "att.toml",
            ],
            "--json",
            "--attitude",
        ),
        (
            vec!["motion-sim", "scene.jpg", "--plot", "scene.jpg"],
            "--plot",
            "IMAGES",
        ),
        (
            vec!["motion-sim", "scene.jpg", "--json", "scene.jpg"],
            "--json",
            "IMAGES",
        ),
        (
            vec!["undistort", "frame.png", "cam.toml", "--camera", "cam.toml"],
            "OUTPUT",
            "--camera",
        ),
        (
            vec![
                "rectify",
                "photo.jpg",
                "o.tif",
                "--camera",
                "drone.toml",
                "--report",
                "drone.toml",
            ],
            "--report",
            "--camera",
        ),
        (
            vec![
                "rectify",
                "photo.jpg",
                "o.tif",
                "--dem",
                "dem.tif",
                "--report",
                "dem.tif",
            ],
            "--report",
            "--dem",
        ),
        (
            vec![
                "batch",
                "photo.jpg",
                "--out-dir",
                "out",
                "--camera",
                "drone.toml",
                "--report-html",
                "drone.toml",
            ],
            "--report-html",
            "--camera",
        ),
        (
            vec![
                "batch",
                "photo.jpg",
                "--out-dir",
                "out",
                "--poses",
                "poses.csv",
                "--crs",
                "EPSG:32635",
                "--report-html",
                "poses.csv",
            ],
            "--report-html",
            "--poses",
        ),
    ];
    for (args, out_flag, in_flag) in &cases {
        refused_and_untouched(&d, args, &[out_flag, in_flag, "overwrite"]);
    }
    // A georeferenced PNG's .prj beside the output would replace the pose table's .prj.
    std::fs::write(d.join("photo.prj"), "EPSG:32635").unwrap();
    std::fs::copy(d.join("poses.csv"), d.join("photo.csv")).unwrap();
    refused_and_untouched(
        &d,
        &[
            "batch",
            "photo.jpg",
            "--out-dir",
            ".",
            "--format",
            "png",
            "--poses",
            "photo.csv",
        ],
        &["photo.prj", "overwrite the input --poses"],
    );
}

#[test]
fn a_side_output_aimed_at_another_output_is_refused() {
    let (_t, d) = fixture();
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "rectify",
            "frame.png",
            "o.tif",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--report",
            "./o.tif",
        ],
        vec![
            "rectify",
            "photo.jpg",
            "o.tif",
            "--camera",
            "drone.toml",
            "--report",
            "o.tif",
        ],
        vec![
            "rectify",
            "photo.jpg",
            "o.png",
            "--camera",
            "drone.toml",
            "--report",
            "o.pgw",
        ],
        vec![
            "simulate",
            "scene.jpg",
            "f.png",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--checkpoints",
            "5",
            "--checkpoints-out",
            "f.png",
        ],
        vec![
            "gcp",
            "frame.png",
            "o.tif",
            "--gcps",
            "gcps.csv",
            "--report",
            "o.tif",
        ],
        vec![
            "register",
            "frame.png",
            "scene.jpg",
            "o.tif",
            "--report",
            "o.tif",
        ],
        vec![
            "compare",
            "scene.jpg",
            "--json",
            "t.json",
            "--frame-out",
            "t.json",
        ],
        vec![
            "calibrate",
            "--points",
            "pts.csv",
            "--image-size",
            "640x480",
            "--model",
            "opencv",
            "--json",
            "c.toml",
            "--camera-out",
            "c.toml",
        ],
        vec![
            "motion-sim",
            "scene.jpg",
            "--plot",
            "p.svg",
            "--json",
            "p.svg",
        ],
        vec![
            "batch",
            "photo.jpg",
            "--out-dir",
            "out",
            "--camera",
            "drone.toml",
            "--report-html",
            "out/photo.tif",
        ],
    ];
    for args in &cases {
        refused_and_untouched(&d, args, &["same file"]);
    }
}

/// No `.aerorect-*.tmp` left in `d`.
fn no_temporaries(d: &Path) {
    let left: Vec<_> = snapshot(d)
        .into_iter()
        .filter(|(p, _)| p.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(
        left.is_empty(),
        "left behind: {:?}",
        left.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
}

#[test]
fn when_one_output_fails_none_is_written() {
    let (_t, d) = fixture();
    // An earlier result stays as it was.
    std::fs::write(d.join("old.tif"), "earlier result").unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "rectify",
                "frame.png",
                "old.tif",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--report",
                "missing/r.json",
            ],
            "missing/r.json",
        ),
        (
            vec![
                "rectify",
                "photo.jpg",
                "o.tif",
                "--camera",
                "drone.toml",
                "--report",
                "missing/r.json",
            ],
            "missing/r.json",
        ),
        (
            vec![
                "simulate",
                "scene.jpg",
                "f.png",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                "5",
                "--checkpoints-out",
                "missing/cp.csv",
            ],
            "missing/cp.csv",
        ),
        (
            vec![
                "gcp",
                "frame.png",
                "o.tif",
                "--gcps",
                "gcps.csv",
                "--report",
                "missing/r.json",
            ],
            "missing/r.json",
        ),
        (
            vec![
                "calibrate",
                "--points",
                "pts.csv",
                "--image-size",
                "640x480",
                "--model",
                "opencv",
                "--fix",
                "k4,k5,k6",
                "--json",
                "r.json",
                "--camera-out",
                "missing/c.toml",
            ],
            "missing/c.toml",
        ),
        (
            vec![
                "motion-sim",
                "scene.jpg",
                "--size",
                "64",
                "--trials",
                "2",
                "--snr-db",
                "10",
                "--method",
                "phase",
                "--json",
                "m.json",
                "--plot",
                "missing/p.svg",
            ],
            "missing/p.svg",
        ),
    ];
    for (args, needle) in &cases {
        refused_and_untouched(&d, args, &[needle]);
    }
    no_temporaries(&d);
}

/// Appends `k + 1` bytes after the JPEG's end, so copies of one photo are distinct files
/// (batch refuses identical ones); decoders stop at the end-of-image marker.
fn distinct(photo: &Path, k: usize) {
    let mut bytes = std::fs::read(photo).unwrap();
    bytes.extend(std::iter::repeat_n(0u8, k + 1));
    std::fs::write(photo, bytes).unwrap();
}

#[test]
fn batch_refuses_two_photos_with_one_output_name() {
    let (_t, d) = fixture();
    for (k, sub) in ["a", "b"].into_iter().enumerate() {
        std::fs::create_dir(d.join(sub)).unwrap();
        drone_photo(&d.join(sub).join("X.JPG"));
        // Two photos, not one copied (a copy is refused as the same photo given twice).
        distinct(&d.join(sub).join("X.JPG"), k);
    }
    refused_and_untouched(
        &d,
        &[
            "batch",
            "a/X.JPG",
            "b/X.JPG",
            "--out-dir",
            "out",
            "--camera",
            "drone.toml",
        ],
        &["a/X.JPG", "b/X.JPG", "out/X.tif"],
    );
    assert!(!d.join("out").exists(), "nothing made before the refusal");
}

#[test]
fn rerunning_batch_with_every_frame_skipped_keeps_the_report() {
    let (_t, d) = fixture();
    let args = [
        "batch",
        "photo.jpg",
        "--out-dir",
        "out",
        "--camera",
        "drone.toml",
        "--gsd-m",
        "0.5",
        "--report-html",
        "r.html",
    ];
    ok(&aerorect(&args, &d));
    let first = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(first.contains("photo.jpg"));
    let again = ok(&aerorect(&args, &d));
    assert!(again.contains("1 skipped"), "{again}");
    assert!(
        again.contains("r.html") && again.contains("kept"),
        "{again}"
    );
    assert_eq!(std::fs::read_to_string(d.join("r.html")).unwrap(), first);
}

/// Sends `signal` to the child once `ready` holds (polled every millisecond), then waits.
fn signal_when(
    child: &mut std::process::Child,
    signal: &str,
    ready: impl Fn() -> bool,
) -> std::process::ExitStatus {
    let t = Instant::now();
    while !ready() {
        assert!(t.elapsed() < Duration::from_secs(120), "never ready");
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the signal"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    let pid = child.id().to_string();
    let kill = std::process::Command::new("kill")
        .args([signal, &pid])
        .status();
    assert!(kill.unwrap().success());
    child.wait().unwrap()
}

fn names_ending(d: &Path, end: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().ends_with(end))
        .collect();
    v.sort();
    v
}

fn spawn(args: &[&str], dir: &Path) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .args(args)
        .current_dir(dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap()
}

#[cfg(unix)]
#[test]
fn sigterm_during_a_long_write_leaves_nothing() {
    let (_t, d) = fixture();
    // A 16x altitude scale: about 60 Mpx of RGB, written for a good part of a second.
    let mut child = spawn(
        &[
            "rectify",
            "frame.png",
            "big.tif",
            "--camera",
            "cam.toml",
            "--attitude",
            ATT,
            "--altitude-m",
            "16",
            "--base-altitude-m",
            "1",
            "--report",
            "big.json",
        ],
        &d,
    );
    let status = signal_when(&mut child, "-TERM", || !names_ending(&d, ".tmp").is_empty());
    assert!(!status.success());
    no_temporaries(&d);
    assert!(!d.join("big.tif").exists() && !d.join("big.json").exists());
}

#[cfg(unix)]
#[test]
fn sigint_during_batch_keeps_finished_frames_and_no_partial_ones() {
    let (_t, d) = fixture();
    std::fs::create_dir(d.join("in")).unwrap();
    let n = 40;
    for k in 0..n {
        let p = d.join(format!("in/p{k:02}.jpg"));
        std::fs::copy(d.join("photo.jpg"), &p).unwrap();
        distinct(&p, k);
    }
    let mut args = vec![
        "batch".to_string(),
        "--out-dir".into(),
        "out".into(),
        "--camera".into(),
        "drone.toml".into(),
        "--gsd-m".into(),
        "0.04".into(),
        "--jobs".into(),
        "1".into(),
        "--report-html".into(),
        "r.html".into(),
    ];
    args.extend((0..n).map(|k| format!("in/p{k:02}.jpg")));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut child = spawn(&args, &d);
    let out = d.join("out");
    let status = signal_when(&mut child, "-INT", || {
        // Two frames finished and a third being written.
        out.is_dir()
            && names_ending(&out, ".tif").len() >= 2
            && !names_ending(&out, ".tmp").is_empty()
    });
    assert!(!status.success());
    no_temporaries(&d);
    let frames = names_ending(&out, ".tif");
    assert!(
        frames.len() >= 2 && frames.len() < n,
        "{} frames",
        frames.len()
    );
    let size = aerorect::io::read_image(&frames[0]).unwrap().size();
    for f in &frames {
        let img = aerorect::io::read_image(f).unwrap();
        assert_eq!(img.size(), size, "{} is whole", f.display());
    }
    assert!(
        !d.join("r.html").exists(),
        "no report of a run that was cut short"
    );
}
