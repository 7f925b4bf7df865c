//! Issue 28, items 2, 3 and 9: a closed or full stdout, FIFOs and devices as outputs, signals'
//! exit codes, the temporary files a killed run left, existing outputs that are not whole, and
//! `overlap` on batch's PNG frames.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, ok};

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";
const XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-90.00" drone-dji:FlightYawDegree="+12.00"/></rdf:RDF></x:xmpmeta>"#;

/// A folder with a simulated oblique frame (frame.png, cam.toml), a drone photo (photo.jpg,
/// drone.toml) and four 64 x 64 track frames (t0.tif .. t3.tif).
fn fixture() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::copy(common::data("aero1.jpg"), d.join("scene.jpg")).unwrap();
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
    common::jpeg_with_xmp(&d, "photo.jpg", Some(XMP));
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
    let scene =
        aerorect_testkit::textured_scene::<f32>(aerorect::core::ImageSize::new(96, 96), 1, 1.0, 5);
    for k in 0..4 {
        let frame = aerorect::raster::shift::sim::shifted_linear(
            &scene,
            10.0,
            10.0,
            aerorect::core::ImageSize::new(64, 64),
            0.7 * k as f64,
            -0.4 * k as f64,
        );
        let size = aerorect::core::ImageSize::new(64, 64);
        let img = aerorect::raster::AnyRaster::F32(
            aerorect::raster::Raster::from_planes(size, vec![frame]).unwrap(),
        );
        aerorect::io::write_image(&d.join(format!("t{k}.tif")), &img).unwrap();
    }
    (dir, d)
}

fn rectify_args<'a>(output: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "rectify",
        "frame.png",
        output,
        "--camera",
        "cam.toml",
        "--attitude",
        ATT,
    ];
    v.extend_from_slice(extra);
    v
}

fn command(args: &[&str], dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_aerorect"));
    c.args(args).current_dir(dir);
    c
}

/// Runs with stdout a pipe whose reading end is closed before the child starts (`| head -0`).
///
/// The reading end is dropped before the spawn, not after: a test thread forking at the same
/// moment holds a copy of every open descriptor until its exec, and a reading end that lived
/// through this child's start could be alive in such a fork when a quick command (`camera
/// convert`) prints, which then succeeds instead of meeting EPIPE.
fn with_closed_stdout(args: &[&str], dir: &Path) -> (Option<i32>, String) {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = command(args, dir)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn no_temporaries(d: &Path) {
    let left: Vec<String> = names(d)
        .into_iter()
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[cfg(unix)]
#[test]
fn a_closed_stdout_ends_quietly_with_141_and_keeps_the_outputs() {
    let (_t, d) = fixture();
    let (code, err) = with_closed_stdout(&rectify_args("out.tif", &["--report", "r.json"]), &d);
    assert_eq!(code, Some(141), "{err}");
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe"),
        "{err}"
    );
    let img = aerorect::io::read_image(&d.join("out.tif")).unwrap();
    assert!(img.size().pixels() > 0);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    assert!(report.is_object());
    no_temporaries(&d);
    // batch: every frame is still written and committed.
    // A second photo, not a byte copy (a copy is refused as the same photo given twice): the
    // same JPEG with bytes after its end-of-image marker, which decoders ignore.
    let mut second = std::fs::read(d.join("photo.jpg")).unwrap();
    second.extend_from_slice(b"second photo");
    std::fs::write(d.join("photo2.jpg"), second).unwrap();
    let batch = [
        "batch",
        "photo.jpg",
        "photo2.jpg",
        "--out-dir",
        "out",
        "--camera",
        "drone.toml",
        "--gsd-m",
        "0.1",
    ];
    let (code, err) = with_closed_stdout(&batch, &d);
    assert_eq!(code, Some(141), "{err}");
    assert_eq!(names(&d.join("out")), ["photo.tif", "photo2.tif"]);
    aerorect::io::check_image_whole(&d.join("out/photo2.tif")).unwrap();
    // track and camera convert: no panic either.
    let (code, err) = with_closed_stdout(&["track", "t0.tif", "t1.tif", "t2.tif", "t3.tif"], &d);
    assert_eq!(code, Some(141), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let (code, err) = with_closed_stdout(&["camera", "convert", "drone.toml", "cam.yaml"], &d);
    assert_eq!(code, Some(141), "{err}");
    assert!(d.join("cam.yaml").is_file());
}

#[cfg(target_os = "linux")]
#[test]
fn a_full_stdout_is_an_error_with_a_message() {
    let (_t, d) = fixture();
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("SKIP: no /dev/full");
        return;
    };
    let out = command(&rectify_args("out.tif", &[]), &d)
        .stdout(full)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("stdout") && err.contains("No space left") && !err.contains("panicked"),
        "{err}"
    );
}

/// Reads a FIFO to its end in a thread (the writer's open waits for it); the bytes, or `None`
/// after a minute.
#[cfg(unix)]
fn read_fifo(path: &Path) -> std::sync::mpsc::Receiver<Vec<u8>> {
    let (tx, rx) = std::sync::mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let bytes = std::fs::read(&p).unwrap();
        let _ = tx.send(bytes);
    });
    rx
}

#[cfg(unix)]
#[test]
fn a_fifo_is_written_in_place_and_stays_a_fifo() {
    use std::os::unix::fs::FileTypeExt;
    let (_t, d) = fixture();
    let fifo = d.join("pipe.tif");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("SKIP: no mkfifo");
        return;
    }
    let reader = read_fifo(&fifo);
    ok(&aerorect(
        &rectify_args("pipe.tif", &["--report", "r.json"]),
        &d,
    ));
    let bytes = reader.recv_timeout(Duration::from_secs(60)).unwrap();
    assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    // The same image as written to a regular file.
    ok(&aerorect(&rectify_args("plain.tif", &[]), &d));
    assert_eq!(bytes, std::fs::read(d.join("plain.tif")).unwrap());
    no_temporaries(&d);
}

#[cfg(unix)]
#[test]
fn dev_null_stays_a_character_device() {
    use std::os::unix::fs::FileTypeExt;
    let (_t, d) = fixture();
    let null = Path::new("/dev/null");
    if !std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
        eprintln!("SKIP: no /dev/null");
        return;
    }
    // As the report (any name), and as the image through a link (the format is the extension).
    ok(&aerorect(
        &rectify_args("out.tif", &["--report", "/dev/null"]),
        &d,
    ));
    assert!(
        std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device()
    );
    aerorect::io::check_image_whole(&d.join("out.tif")).unwrap();
    std::os::unix::fs::symlink(null, d.join("null.tif")).unwrap();
    ok(&aerorect(&rectify_args("null.tif", &[]), &d));
    assert!(
        std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device()
    );
    let link = std::fs::symlink_metadata(d.join("null.tif")).unwrap();
    assert!(link.file_type().is_symlink());
    assert_eq!(std::fs::read_link(d.join("null.tif")).unwrap(), null);
    no_temporaries(&d);
}

#[test]
fn a_directory_as_an_output_is_refused_and_nothing_is_written() {
    let (_t, d) = fixture();
    std::fs::create_dir(d.join("adir.json")).unwrap();
    let out = aerorect(&rectify_args("out.tif", &["--report", "adir.json"]), &d);
    // Refused up front by the output checks, before any decoding (staged.rs refuses it again
    // at commit time if a folder appears there meanwhile: its unit test).
    fails(
        &out,
        &["adir.json", "is a folder, not a file", "nothing written"],
    );
    assert!(!d.join("out.tif").exists());
    assert!(names(&d.join("adir.json")).is_empty());
    no_temporaries(&d);
}

#[cfg(target_os = "linux")]
#[test]
fn a_killed_runs_temporary_file_is_removed_by_the_next_run_for_that_target() {
    let (_t, d) = fixture();
    let mut child = Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let stale = format!(".aerorect-out.tif.{dead}.Xy12Zw.tmp");
    let other = format!(".aerorect-other.tif.{dead}.Xy12Zw.tmp");
    let running = ".aerorect-out.tif.1.Xy12Zw.tmp".to_string(); // init's: still running
    for f in [&stale, &other, &running] {
        std::fs::write(d.join(f), "partial").unwrap();
    }
    ok(&aerorect(&rectify_args("out.tif", &[]), &d));
    let left = names(&d);
    assert!(!left.contains(&stale), "{left:?}");
    assert!(left.contains(&other) && left.contains(&running), "{left:?}");
}

/// Sends `signal` once a temporary file exists, and returns the exit code.
#[cfg(unix)]
fn code_after(signal: &str) -> Option<i32> {
    let (_t, d) = fixture();
    // A 16x altitude scale: about 60 Mpx of RGB, written for a good part of a second.
    let args = rectify_args("big.tif", &["--altitude-m", "16", "--base-altitude-m", "1"]);
    let mut child = command(&args, &d)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !names(&d).iter().any(|n| n.ends_with(".tmp")) {
        assert!(t.elapsed() < Duration::from_secs(120), "never wrote");
        assert!(child.try_wait().unwrap().is_none(), "finished first");
        std::thread::sleep(Duration::from_millis(1));
    }
    let kill = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status();
    assert!(kill.unwrap().success());
    let status = child.wait().unwrap();
    no_temporaries(&d);
    assert!(!d.join("big.tif").exists());
    status.code()
}

#[cfg(unix)]
#[test]
fn sigterm_exits_143_and_sigint_130() {
    assert_eq!(code_after("-TERM"), Some(143));
    assert_eq!(code_after("-INT"), Some(130));
}

#[test]
fn an_existing_output_that_is_not_whole_is_rectified_again() {
    let (_t, d) = fixture();
    let batch = [
        "batch",
        "photo.jpg",
        "--out-dir",
        "out",
        "--camera",
        "drone.toml",
        "--gsd-m",
        "0.1",
    ];
    ok(&aerorect(&batch, &d));
    let out = d.join("out/photo.tif");
    let whole = std::fs::read(&out).unwrap();
    std::fs::write(&out, &whole[..whole.len() / 2]).unwrap();
    let again = ok(&aerorect(&batch, &d));
    assert!(
        again.contains("not a whole image") && again.contains("rectified again"),
        "{again}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), whole);
    let third = ok(&aerorect(&batch, &d));
    assert!(third.contains("skipped"), "{third}");
}

#[test]
fn overlap_reads_batchs_png_frames() {
    let (_t, d) = fixture();
    let batch = |format: &str, dir: &str| {
        let args = [
            "batch",
            "photo.jpg",
            "--out-dir",
            dir,
            "--camera",
            "drone.toml",
            "--gsd-m",
            "0.1",
            "--format",
            format,
        ];
        ok(&aerorect(&args, &d));
    };
    batch("png", "png");
    batch("tif", "tif");
    // The PNG's sidecars give the GeoTIFF's grid.
    let gp = aerorect::io::read_georeference(&d.join("png/photo.png"))
        .unwrap()
        .unwrap();
    let gt = aerorect::io::read_georeference(&d.join("tif/photo.tif"))
        .unwrap()
        .unwrap();
    assert!(gp.crs.same_as(&gt.crs), "{} / {}", gp.crs, gt.crs);
    for (a, b) in gp.geotransform().iter().zip(gt.geotransform()) {
        assert!(
            (a - b).abs() < 1e-6,
            "{:?} / {:?}",
            gp.geotransform(),
            gt.geotransform()
        );
    }
    // One frame against itself, as PNG and as GeoTIFF: no misalignment.
    let out = ok(&aerorect(
        &[
            "overlap",
            "png/photo.png",
            "tif/photo.tif",
            "--patch",
            "64",
            "--json",
        ],
        &d,
    ));
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(r["patches"].as_u64().unwrap() > 0, "{out}");
    for v in r["median_px"].as_array().unwrap() {
        assert!(v.as_f64().unwrap().abs() < 0.01, "{out}");
    }
}
