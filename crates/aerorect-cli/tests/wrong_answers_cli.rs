//! Issue 12: inputs that used to give a wrong answer (or an unreadable message) with exit 0 are
//! refused, each message naming the file, field and value; nothing is written.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, data, fails, ok};

use std::path::{Path, PathBuf};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";
const CAM: &str = "fx_px = 300.0\nfy_px = 300.0\nimage_size_px = [320, 240]\n";

/// The bundled scene, a camera file and a frame simulated from them with check points.
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
            "20",
            "--checkpoints-out",
            "cp.csv",
        ],
        &d,
    ));
    (dir, d)
}

fn files(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn non_finite_distortion_coefficients_are_refused() {
    let (_t, d) = fixture();
    for (value, shown) in [("nan", "NaN"), ("-inf", "-inf"), ("inf", "inf")] {
        std::fs::write(
            d.join("bad.toml"),
            format!("{CAM}[distortion]\nmodel = \"opencv\"\nk1 = {value}\n"),
        )
        .unwrap();
        let before = files(&d);
        let needles = ["bad.toml", "k1", shown];
        let cases: [&[&str]; 3] = [
            &[
                "rectify",
                "frame.png",
                "r.png",
                "--camera",
                "bad.toml",
                "--attitude",
                ATT,
            ],
            &["undistort", "frame.png", "u.png", "--camera", "bad.toml"],
            &[
                "evaluate",
                "--camera",
                "bad.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                "cp.csv",
            ],
        ];
        for args in cases {
            fails(&aerorect(args, &d), &needles);
        }
        assert_eq!(files(&d), before, "nothing written");
    }
}

#[test]
fn absurd_check_points_are_refused() {
    let (_t, d) = fixture();
    let cp = std::fs::read_to_string(d.join("cp.csv")).unwrap();
    let header = cp.lines().next().unwrap();
    let eval = |name: &str| {
        aerorect(
            &[
                "evaluate",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                name,
                "--json",
            ],
            &d,
        )
    };
    // Before the fix: RMS inf, printed as null in JSON, exit 0.
    std::fs::write(d.join("huge.csv"), format!("{header}\n10,10,1e308,20\n")).unwrap();
    fails(
        &eval("huge.csv"),
        &["huge.csv", "line 2", "u_standard = 1e308"],
    );
    // Finite and within the readers' range, but not a pixel of the 320 x 240 frame.
    std::fs::write(
        d.join("out.csv"),
        format!("{header}\n10,10,0,0\n5000,10,0,0\n"),
    )
    .unwrap();
    fails(
        &eval("out.csv"),
        &[
            "out.csv",
            "check point 2",
            "(5000, 10)",
            "outside",
            "320 x 240",
        ],
    );
}

#[test]
fn a_gsd_as_large_as_the_footprint_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    let xmp = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+0.00" drone-dji:GimbalPitchDegree="-90.00" drone-dji:FlightYawDegree="+0.00"/></rdf:RDF></x:xmpmeta>"#;
    common::jpeg_with_xmp(d, "p.jpg", Some(xmp));
    // At nadir from 80 m with fx = 500 px the 640 x 480 frame covers 102.4 x 76.8 m.
    let run = |gsd: &str| {
        aerorect(
            &[
                "rectify", "p.jpg", "o.tif", "--camera", "cam.toml", "--gsd-m", gsd,
            ],
            d,
        )
    };
    // Before the fix: a 2 x 2 px ortho, exit 0. Now beyond the sane range (issue 28).
    fails(&run("1e6"), &["--gsd-m 1000000", "at most 10000 m"]);
    assert!(!d.join("o.tif").exists());
    fails(
        &run("10"),
        &[
            "GSD 10 m gives a 12 x 9 px ortho",
            "103 x 77 m",
            "16 px",
            "a GSD of 4.8",
        ],
    );
    ok(&run("4"));
}

#[test]
fn calibrate_refuses_points_outside_the_image_size() {
    let dir = tempfile::tempdir().unwrap();
    let pts = data("calib/left_corners.csv");
    // The corners reach u = 500 or so: a 320 x 240 image cannot hold them.
    let out = aerorect(
        &[
            "calibrate",
            "--points",
            &pts,
            "--image-size",
            "320x240",
            "--model",
            "opencv",
        ],
        dir.path(),
    );
    fails(&out, &["left_corners.csv", "outside the 320 x 240 image"]);
    ok(&aerorect(
        &[
            "calibrate",
            "--points",
            &pts,
            "--image-size",
            "640x480",
            "--model",
            "opencv",
        ],
        dir.path(),
    ));
}

#[test]
fn brown_on_a_plane_holds_its_affinity_terms_and_finds_the_focal_length() {
    let dir = tempfile::tempdir().unwrap();
    let pts = data("calib/left_corners.csv");
    // Before the fix: a1 and b2 absorbed the focal length, fx = 34 px with exit 0.
    let out = ok(&aerorect(
        &[
            "calibrate",
            "--points",
            &pts,
            "--image-size",
            "640x480",
            "--model",
            "brown",
            "--json",
            "b.json",
        ],
        dir.path(),
    ));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("b.json")).unwrap()).unwrap();
    // OpenCV 5.0 on the same corners: fx 536.07 (its own model; Brown's differs a little).
    let fx = v["fx"].as_f64().unwrap();
    assert!((fx - 536.07).abs() < 10.0, "fx = {fx}");
    let held: Vec<String> = serde_json::from_value(v["held_fixed"].clone()).unwrap();
    for (term, partner) in [("a1", "fx"), ("b2", "fy"), ("dx0", "cx"), ("dy0", "cy")] {
        assert!(
            held.iter()
                .any(|h| h.starts_with(term) && h.contains(partner)),
            "{held:?}"
        );
        assert!(v["std"][term].is_null(), "{term} is held");
        assert!(out.contains(&format!("{term} held at 0")), "{out}");
    }
    // Fixing the intrinsic frees its duplicate.
    let out = ok(&aerorect(
        &[
            "calibrate",
            "--points",
            &pts,
            "--image-size",
            "640x480",
            "--model",
            "brown",
            "--fix",
            "cx,cy",
        ],
        dir.path(),
    ));
    assert!(
        !out.contains("dx0 held") && out.contains("a1 held"),
        "{out}"
    );
}

#[test]
fn simulate_bounds_the_number_of_check_points() {
    let (_t, d) = fixture();
    let run = |n: &str| {
        aerorect(
            &[
                "simulate",
                "scene.jpg",
                "f2.png",
                "--camera",
                "cam.toml",
                "--attitude",
                ATT,
                "--checkpoints",
                n,
                "--checkpoints-out",
                "cp2.csv",
            ],
            &d,
        )
    };
    // Before the fix: 1e9 ran without bound. 320 x 240 / 16 = 4800.
    fails(
        &run("1000000000"),
        &["--checkpoints 1000000000", "1 to 4800", "320 x 240"],
    );
    fails(&run("0"), &["--checkpoints 0", "1 to 4800"]);
    assert!(!d.join("f2.png").exists() && !d.join("cp2.csv").exists());
}

#[test]
fn gcp_grid_respects_the_output_limit() {
    let (_t, d) = fixture();
    let cp = std::fs::read_to_string(d.join("cp.csv")).unwrap();
    let body: Vec<&str> = cp.lines().skip(1).collect();
    std::fs::write(
        d.join("gcps.csv"),
        format!("u_image,v_image,u_ref,v_ref\n{}\n", body.join("\n")),
    )
    .unwrap();
    let run = |grid: &str, limit: &str| {
        let grid = format!("--grid={grid}");
        aerorect(
            &[
                "gcp",
                "frame.png",
                "g.tif",
                "--gcps",
                "gcps.csv",
                &grid,
                "--max-output-px",
                limit,
            ],
            &d,
        )
    };
    // Before the fix: the grid was allocated and written whatever the limit.
    fails(
        &run("0,0,20000,20000", "64000000"),
        &[
            "--grid 20000 x 20000 = 400000000 px",
            "limit of 64000000 px",
        ],
    );
    fails(
        &run(
            "0,0,9223372036854775807,9223372036854775807",
            "18446744073709551615",
        ),
        &["--grid", "more than 2^64"],
    );
    fails(&run("-50,-60,200,100", "10000"), &["200 x 100 = 20000 px"]);
    assert!(!d.join("g.tif").exists());
    ok(&run("-50,-60,200,100", "20000"));
}

#[test]
fn shift_of_a_frame_against_itself_is_zero() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 40 x 32 texture: one-way JTC read up to 0.1 px here.
    let img = aerorect::raster::AnyRaster::U8(aerorect_testkit::textured_scene(
        aerorect::core::ImageSize::new(40, 32),
        1,
        255.0,
        5,
    ));
    aerorect::io::write_image(&d.join("a.png"), &img).unwrap();
    for method in ["jtc", "jtc-centroid", "phase", "xcorr"] {
        let out = ok(&aerorect(
            &["shift", "a.png", "a.png", "--method", method, "--json"],
            d,
        ));
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let (dx, dy) = (v["dx"].as_f64().unwrap(), v["dy"].as_f64().unwrap());
        assert!(dx.abs().max(dy.abs()) < 1e-9, "{method}: {out}");
    }
}

/// A 300 x 300 texture as a GeoTIFF at 0.5 m in UTM 35N with its corner at (x0, y0).
fn geotiff(d: &Path, name: &str, x0: f64, y0: f64) {
    use aerorect::geo::Crs;
    use aerorect::io::GeoReference;
    let img = aerorect::raster::AnyRaster::U8(aerorect_testkit::textured_scene(
        aerorect::core::ImageSize::new(300, 300),
        1,
        250.0,
        3,
    ));
    let geo = GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
        pixel_size: [0.5, 0.5],
        top_left: [x0, y0],
        rotation: [0.0, 0.0],
        nodata: None,
    };
    aerorect::io::write_image_geo(&d.join(name), &img, Some(&geo)).unwrap();
}

#[test]
fn overlap_refuses_grids_offset_by_a_fraction_of_a_pixel() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    geotiff(d, "a.tif", 536000.0, 5972000.0);
    geotiff(d, "b.tif", 536010.0, 5971990.0);
    // Before the fix: half a pixel (0.25 m) off, rounded away and measured as "one grid".
    geotiff(d, "c.tif", 536010.25, 5971990.0);
    let out = ok(&aerorect(
        &["overlap", "a.tif", "b.tif", "--patch", "64"],
        d,
    ));
    assert!(!out.is_empty());
    fails(
        &aerorect(&["overlap", "a.tif", "c.tif", "--patch", "64"], d),
        &[
            "a.tif",
            "c.tif",
            "not on one grid",
            "536000",
            "536010.25",
            "0.5 px",
        ],
    );
}

/// Uniform noise, 320 x 240, from `seed` (an LCG: independent of any library's generator).
fn noise(d: &Path, name: &str, seed: u64) {
    let mut x = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    let v: Vec<u8> = (0..320 * 240)
        .map(|_| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 56) as u8
        })
        .collect();
    let r =
        aerorect::raster::Raster::from_planes(aerorect::core::ImageSize::new(320, 240), vec![v]);
    aerorect::io::write_image(&d.join(name), &aerorect::raster::AnyRaster::U8(r.unwrap())).unwrap();
}

#[test]
fn register_refuses_unrelated_noise_images() {
    let (_t, d) = fixture();
    // Before the fix: 9 of 30 chance matches "registered", exit 0.
    let mut by_peak = 0;
    for seed in 0..4 {
        noise(&d, "n1.png", seed);
        noise(&d, "n2.png", seed + 100);
        let out = aerorect(
            &[
                "register", "n1.png", "n2.png", "r.png", "--report", "r.json",
            ],
            &d,
        );
        fails(&out, &["n1.png", "registration"]);
        by_peak +=
            String::from_utf8_lossy(&out.stderr).contains("median correlation peak") as usize;
        assert!(!d.join("r.png").exists() && !d.join("r.json").exists());
    }
    assert!(by_peak > 0, "no pair reached the peak test");
    // The simulated frame still registers to its scene (see baseline_cli for its accuracy).
    ok(&aerorect(
        &["register", "frame.png", "scene.jpg", "r.png"],
        &d,
    ));
}

/// A little-endian, uncompressed, single-strip 16 x 4 gray TIFF of `bits` per sample.
fn tiny_tiff(bits: u16) -> Vec<u8> {
    let (w, h) = (16u32, 4u32);
    let data_len = (w * u32::from(bits)).div_ceil(8) * h;
    let entries: [(u16, u16, u32); 9] = [
        (256, 4, w),                  // ImageWidth
        (257, 4, h),                  // ImageLength
        (258, 3, bits as u32),        // BitsPerSample
        (259, 3, 1),                  // Compression: none
        (262, 3, 1),                  // Photometric: black is zero
        (273, 4, 8 + 2 + 9 * 12 + 4), // StripOffsets: after the IFD
        (277, 3, 1),                  // SamplesPerPixel
        (278, 4, h),                  // RowsPerStrip
        (279, 4, data_len),           // StripByteCounts
    ];
    let mut b = b"II*\0".to_vec();
    b.extend(8u32.to_le_bytes());
    b.extend((entries.len() as u16).to_le_bytes());
    for (tag, kind, value) in entries {
        b.extend(tag.to_le_bytes());
        b.extend(kind.to_le_bytes());
        b.extend(1u32.to_le_bytes());
        if kind == 3 {
            b.extend((value as u16).to_le_bytes());
            b.extend([0, 0]);
        } else {
            b.extend(value.to_le_bytes());
        }
    }
    b.extend(0u32.to_le_bytes());
    b.extend((0..data_len).map(|i| (i * 37) as u8));
    b
}

#[test]
fn unreadable_tiffs_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = tiny_tiff(8);
    std::fs::write(d.join("good.tif"), &good).unwrap();
    let img = aerorect::io::read_image(&d.join("good.tif")).unwrap();
    assert_eq!((img.size().width, img.size().height), (16, 4));
    // Before: "failed to fill whole buffer".
    std::fs::write(d.join("cut.tif"), &good[..good.len() - 20]).unwrap();
    fails(
        &aerorect(&["shift", "cut.tif", "good.tif"], d),
        &["cut.tif", "truncated"],
    );
    // Before: "buffer holds 512 samples, ...".
    std::fs::write(d.join("bits.tif"), tiny_tiff(1)).unwrap();
    fails(
        &aerorect(&["shift", "bits.tif", "good.tif"], d),
        &["bits.tif", "unsupported 1-bit samples"],
    );
}

#[test]
fn register_names_only_the_option_out_of_range() {
    let (_t, d) = fixture();
    let run = |opt: &str| aerorect(&["register", "frame.png", "scene.jpg", "r.png", opt], &d);
    // Before: every message listed --patch, --ransac-px and --max-scale together, and a
    // --max-scale of 1e300 was accepted (and searched for minutes).
    for (opt, named, others) in [
        ("--patch=8", "--patch 8", ["--ransac-px", "--max-scale"]),
        (
            "--ransac-px=-1",
            "--ransac-px -1",
            ["--patch", "--max-scale"],
        ),
        (
            "--max-scale=1e300",
            "--max-scale 1e300: must be from 1 to 10",
            ["--patch", "--ransac-px"],
        ),
        (
            "--max-scale=0.5",
            "--max-scale 0.5",
            ["--patch", "--ransac-px"],
        ),
    ] {
        let out = run(opt);
        fails(&out, &[named]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(others.iter().all(|o| !err.contains(o)), "{err}");
    }
}

#[test]
fn absurd_counts_and_sizes_are_refused_before_any_work() {
    let (_t, d) = fixture();
    let before = files(&d);
    // Before: `--size 100000` planned 10^10-pixel transforms and aborted (exit 134) on the
    // allocation; `--trials 0` wrote an empty table; `--threads 0` meant all cores.
    let sim = |extra: &[&str]| {
        let mut args = vec!["motion-sim", "scene.jpg", "--plot", "p.svg"];
        args.extend_from_slice(extra);
        aerorect(&args, &d)
    };
    fails(
        &sim(&["--size", "100000"]),
        &[
            "scene",
            "too small for 100000 x 100000",
            "give a smaller --size",
        ],
    );
    fails(
        &sim(&["--trials", "0"]),
        &["--trials 0", "at least one trial"],
    );
    fails(
        &sim(&["--threads", "0"]),
        &["--threads", "at least one thread"],
    );
    assert_eq!(files(&d), before);
}
