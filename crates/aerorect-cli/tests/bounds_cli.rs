//! Bounded memory and time on hostile inputs, one rule for duplicate photos, and `--camera` in
//! every camera format (issue 28, items 4, 8 and 9): a YAML alias bomb and `/dev/zero` given as
//! camera files, a small GeoTIFF claiming 30000 x 30000 pixels, `--threads 100000`, a mosaic of
//! two frames 900 km apart, a photo given twice (or copied under another name) to calibrate,
//! batch and mosaic, and a camera converted to each of the eight formats given to `--camera`.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, data, fails, ok};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs the binary, killing it (and failing the test) after `secs` seconds.
fn bounded(args: &[&str], dir: &Path, secs: u64) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > Duration::from_secs(secs) {
            child.kill().unwrap();
            let _ = child.wait();
            panic!("aerorect {args:?} did not finish in {secs} s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// Fails cleanly (exit 1, not a signal or an abort) with every needle in stderr.
fn fails_cleanly(out: &Output, needles: &[&str]) {
    fails(out, needles);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A 324-byte-class alias bomb: nine anchors, each a list of ten aliases of the one before
/// (10^9 scalars once expanded).
fn alias_bomb() -> String {
    let mut s = "a0: &a0 [lol]\n".to_string();
    for i in 1..=9 {
        let refs = vec![format!("*a{}", i - 1); 10].join(",");
        s += &format!("a{i}: &a{i} [{refs}]\n");
    }
    s
}

#[test]
fn a_yaml_alias_bomb_and_an_endless_device_as_camera_files_end_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("bomb.yaml"), alias_bomb()).unwrap();
    std::fs::write(d.join("o.png"), b"not read: the camera fails first").unwrap();
    // OpenCV's layout too (detected by its directive), and through --camera.
    std::fs::write(
        d.join("bomb.yml"),
        format!("%YAML:1.0\n---\n{}", alias_bomb()),
    )
    .unwrap();
    for (args, file) in [
        (
            vec!["camera", "convert", "bomb.yaml", "out.toml"],
            "bomb.yaml",
        ),
        (
            vec!["camera", "convert", "bomb.yml", "out.toml"],
            "bomb.yml",
        ),
        (
            vec![
                "simulate",
                "o.png",
                "f.png",
                "--camera",
                "bomb.yaml",
                "--attitude",
                "azimuth=0,elevation=0,image_rotation=0,pitch=0,roll=0,yaw=0",
            ],
            "bomb.yaml",
        ),
    ] {
        let out = bounded(&args, d, 20);
        fails_cleanly(&out, &[file, "100000 nodes"]);
    }
    #[cfg(unix)]
    {
        let out = bounded(&["camera", "convert", "/dev/zero", "out.toml"], d, 20);
        fails_cleanly(&out, &["/dev/zero", "16 MiB"]);
        let out = bounded(
            &[
                "simulate",
                "o.png",
                "f.png",
                "--camera",
                "/dev/urandom",
                "--attitude",
                "azimuth=0,elevation=0,image_rotation=0,pitch=0,roll=0,yaw=0",
            ],
            d,
            20,
        );
        fails_cleanly(&out, &["/dev/urandom", "16 MiB"]);
    }
    assert!(!d.join("out.toml").exists() && !d.join("f.png").exists());
}

/// A little-endian TIFF of one deflate strip of `strip` bytes (zeros) whose header claims
/// `w` x `h` 8-bit gray pixels, georeferenced (UTM 35N, 1 m pixels) so `overlap` reads it.
fn claimed_tiff(path: &Path, w: u32, h: u32, strip: usize) {
    let doubles = |v: &[f64]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let shorts = |v: &[u16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let data_at = 4096u32;
    // (tag, type, count, value bytes): 3 SHORT, 4 LONG, 12 DOUBLE.
    let entries: Vec<(u16, u16, u32, Vec<u8>)> = vec![
        (256, 4, 1, w.to_le_bytes().to_vec()),
        (257, 4, 1, h.to_le_bytes().to_vec()),
        (258, 3, 1, shorts(&[8])),
        (259, 3, 1, shorts(&[8])),
        (262, 3, 1, shorts(&[1])),
        (273, 4, 1, data_at.to_le_bytes().to_vec()),
        (277, 3, 1, shorts(&[1])),
        (278, 4, 1, h.to_le_bytes().to_vec()),
        (279, 4, 1, (strip as u32).to_le_bytes().to_vec()),
        (33550, 12, 3, doubles(&[1.0, 1.0, 0.0])),
        (
            33922,
            12,
            6,
            doubles(&[0.0, 0.0, 0.0, 500_000.0, 6_000_000.0, 0.0]),
        ),
        (
            34735,
            3,
            16,
            shorts(&[1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 32635]),
        ),
    ];
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&8u32.to_le_bytes());
    let ifd_len = 2 + 12 * entries.len() + 4;
    let mut extra: Vec<u8> = Vec::new();
    let extra_at = 8 + ifd_len;
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for (tag, typ, count, bytes) in &entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&typ.to_le_bytes());
        out.extend_from_slice(&count.to_le_bytes());
        if bytes.len() <= 4 {
            let mut v = bytes.clone();
            v.resize(4, 0);
            out.extend_from_slice(&v);
        } else {
            out.extend_from_slice(&((extra_at + extra.len()) as u32).to_le_bytes());
            extra.extend_from_slice(bytes);
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&extra);
    assert!(out.len() <= data_at as usize);
    out.resize(data_at as usize + strip, 0);
    std::fs::write(path, out).unwrap();
}

#[test]
fn a_small_tiff_claiming_30000_squared_pixels_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    claimed_tiff(&d.join("a.tif"), 30000, 30000, 1 << 20);
    claimed_tiff(&d.join("b.tif"), 30000, 30000, (1 << 20) + 1);
    let needles = [
        "a.tif",
        "30000 x 30000",
        "over the limit of 500000000 pixels",
    ];
    for args in [
        vec!["overlap", "a.tif", "b.tif"],
        vec!["track", "a.tif", "b.tif"],
        vec![
            "calibrate",
            "--model",
            "opencv",
            "--images",
            "a.tif",
            "--board",
            "9x6",
            "--square-m",
            "0.025",
        ],
    ] {
        fails_cleanly(&bounded(&args, d, 30), &needles);
    }
    // The budget is the process's: a lower one refuses a smaller image, naming its size.
    claimed_tiff(&d.join("c.tif"), 3000, 2000, 1 << 10);
    fails_cleanly(
        &bounded(
            &["--max-image-px", "1000000", "track", "c.tif", "c.tif"],
            d,
            30,
        ),
        &["c.tif", "3000 x 2000", "over the limit of 1000000 pixels"],
    );
}

#[test]
fn a_hundred_thousand_threads_are_capped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    let out = bounded(
        &[
            "--threads",
            "100000",
            "camera",
            "convert",
            "cam.toml",
            "cam.yml",
        ],
        d,
        30,
    );
    ok(&out);
    let err = String::from_utf8_lossy(&out.stderr);
    let cores = std::thread::available_parallelism().unwrap().get();
    assert!(
        err.contains("warning: --threads 100000") && err.contains(&format!("using {}", 4 * cores)),
        "{err}"
    );
    // Within the cap: no warning.
    let out = bounded(
        &[
            "--threads",
            "2",
            "camera",
            "convert",
            "cam.toml",
            "cam2.yml",
        ],
        d,
        30,
    );
    ok(&out);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
}

/// The bundled JPEG looking straight down from 80 m at (`lat`, 27.55).
fn photo(dir: &Path, name: &str, lat: &str) -> PathBuf {
    let x = format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="{lat}" drone-dji:GpsLongtitude="+27.550000" drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+0.00" drone-dji:GimbalPitchDegree="-90.00"/></rdf:RDF></x:xmpmeta>"#
    );
    common::jpeg_with_xmp(dir, name, Some(&x))
}

#[test]
fn a_mosaic_of_frames_900_km_apart_is_refused_before_any_frame_is_rendered() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(d, "a.jpg", "+53.900000");
    photo(d, "b.jpg", "+61.990000");
    let base = ["mosaic", "a.jpg", "b.jpg", "--camera", "cam.toml"];
    let t0 = Instant::now();
    let out = bounded(
        &[&base[..], &["--gsd-m", "0.25", "--out", "m.tif"]].concat(),
        d,
        30,
    );
    // 900 km at 0.25 m is 3.6 million rows; the limit is 2 x 64 Mpx.
    fails_cleanly(
        &out,
        &[
            "the mosaic would be",
            "m at 0.25 m/px",
            "over the limit of 128000000 px",
            "A GSD of",
        ],
    );
    assert!(t0.elapsed() < Duration::from_secs(20));
    assert!(!d.join("m.tif").exists());
    // The footprint is the frames' 900 km apart, and the GSD the message names would fit.
    let err = String::from_utf8_lossy(&out.stderr);
    let after = |k: &str| err.split(k).nth(1).unwrap().to_string();
    let px = after("would be ");
    let mut wh = px.split(" px").next().unwrap().split(" x ");
    let (w, h): (f64, f64) = (
        wh.next().unwrap().parse().unwrap(),
        wh.next().unwrap().parse().unwrap(),
    );
    let north_m: f64 = after("px (")
        .split(" m x ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (north_m - h * 0.25).abs() < 1.0 && (890e3..910e3).contains(&north_m),
        "{err}"
    );
    let gsd: f64 = after("A GSD of ")
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let at_gsd = (w * 0.25 / gsd).ceil() * (h * 0.25 / gsd).ceil();
    assert!(at_gsd <= 128e6 && at_gsd > 100e6, "{gsd} m: {at_gsd} px");
}

#[test]
fn a_photo_given_twice_is_refused_by_one_rule_in_calibrate_batch_and_mosaic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Three copies of one chessboard photo under different names, beside two other photos.
    let left = std::fs::read(data("calib-opencv/left01.jpg")).unwrap();
    for n in ["x.jpg", "y.jpg", "z.jpg"] {
        std::fs::write(d.join(n), &left).unwrap();
    }
    let others = [
        data("calib-opencv/left03.jpg"),
        data("calib-opencv/left04.jpg"),
    ];
    let args = [
        "calibrate",
        "--model",
        "opencv",
        "--board",
        "9x6",
        "--square-m",
        "0.025",
        "--images",
        &others[0],
        "x.jpg",
        &others[1],
        "y.jpg",
        "z.jpg",
    ];
    fails_cleanly(
        &bounded(&args, d, 60),
        &[
            "x.jpg and y.jpg hold identical bytes",
            "give each photo once",
        ],
    );
    // mosaic (plain and --adjust) and batch: the same file twice, or a copy.
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(d, "a.jpg", "+53.900000");
    std::fs::copy(d.join("a.jpg"), d.join("copy.jpg")).unwrap();
    let cam = ["--camera", "cam.toml", "--gsd-m", "0.25"];
    for (second, why) in [
        ("./a.jpg", "a.jpg and ./a.jpg name the same file"),
        ("copy.jpg", "a.jpg and copy.jpg hold identical bytes"),
    ] {
        for extra in [&["--out", "m.tif"][..], &["--out", "m.tif", "--adjust"][..]] {
            let args = [&["mosaic", "a.jpg", second][..], &cam, extra].concat();
            fails_cleanly(&bounded(&args, d, 60), &[why, "give each photo once"]);
        }
        let args = [&["batch", "a.jpg", second, "--out-dir", "o"][..], &cam].concat();
        fails_cleanly(&bounded(&args, d, 60), &[why, "give each photo once"]);
    }
    assert!(!d.join("m.tif").exists() && !d.join("o").join("a.tif").exists());
}

/// The planes of an 8-bit image.
fn planes(p: &Path) -> Vec<Vec<u8>> {
    match aerorect::io::read_image(p).unwrap() {
        aerorect::raster::AnyRaster::U8(r) => r.planes().to_vec(),
        _ => panic!("{}: not u8", p.display()),
    }
}

#[test]
fn every_camera_format_works_as_camera_and_gives_the_toml_cameras_result() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(data("aero1.jpg"), d.join("in.jpg")).unwrap();
    let size = aerorect::io::read_image(&d.join("in.jpg")).unwrap().size();
    std::fs::write(
        d.join("cam.toml"),
        format!(
            "fx_px = 900.0\nfy_px = 905.0\ncx_px = {}\ncy_px = {}\nimage_size_px = [{}, {}]\n\
             [distortion]\nmodel = \"opencv\"\nk1 = -0.2\nk2 = 0.05\np1 = 0.001\np2 = -0.0005\n\n",
            size.width as f64 / 2.0 + 3.0,
            size.height as f64 / 2.0 - 2.0,
            size.width,
            size.height
        ),
    )
    .unwrap();
    ok(&aerorect(
        &["undistort", "in.jpg", "ref.png", "--camera", "cam.toml"],
        d,
    ));
    let reference = planes(&d.join("ref.png"));
    let formats = [
        ("opencv-yaml", "cam.yml"),
        ("opencv-xml", "cam.xml"),
        ("colmap", "cameras.txt"),
        ("opensfm", "cameras.json"),
        ("metashape", "meta.xml"),
        ("dji-dewarp", "dewarp.txt"),
        ("orthority", "int_param.yaml"),
    ];
    for (format, name) in formats {
        ok(&aerorect(
            &["camera", "convert", "cam.toml", name, "--to", format],
            d,
        ));
        let out = format!("{format}.png");
        ok(&aerorect(
            &["undistort", "in.jpg", &out, "--camera", name],
            d,
        ));
        let got = planes(&d.join(&out));
        assert_eq!(got.len(), reference.len(), "{format}");
        for (g, r) in got.iter().zip(&reference) {
            assert_eq!(g.len(), r.len(), "{format}: size");
            let worst = g.iter().zip(r).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
            assert!(
                worst <= 1,
                "{format}: {worst} levels from the TOML camera's"
            );
        }
    }
}
