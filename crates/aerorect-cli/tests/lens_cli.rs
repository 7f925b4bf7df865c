//! calibrate, undistort, and the camera file's distortion in simulate/rectify/evaluate.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, data, fails, ok};

#[test]
fn calibrate_writes_the_json_keys_and_a_usable_camera_file() {
    let dir = tempfile::tempdir().unwrap();
    let pts = data("calib/left_corners.csv");
    let args = [
        "calibrate",
        "--points",
        &pts,
        "--image-size",
        "640x480",
        "--model",
        "opencv",
        "--fix",
        "k4,k5,k6",
        "--json",
        "c.json",
        "--camera-out",
        "cam.toml",
    ];
    ok(&aerorect(&args, dir.path()));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("c.json")).unwrap()).unwrap();
    for key in [
        "fx",
        "fy",
        "cx",
        "cy",
        "skew",
        "k1",
        "k2",
        "p1",
        "p2",
        "k3",
        "rms_px",
        "views",
        "std",
        "stop_reason",
    ] {
        assert!(!v[key].is_null(), "{key}");
    }
    // OpenCV 5.0 on the same points: fx 536.0734, RMS 0.40869.
    assert!(
        (v["fx"].as_f64().unwrap() - 536.0734).abs() < 0.5
            && (v["rms_px"].as_f64().unwrap() - 0.40869).abs() < 0.01
    );
    assert_eq!(v["views"].as_array().unwrap().len(), 13);
    assert!(v["std"]["fx"].as_f64().unwrap() > 0.0 && v["std"]["skew"].is_null());
    // The camera file drives undistort: a synthetic image keeps its size.
    let img = aerorect::raster::AnyRaster::U8(aerorect_testkit::textured_scene(
        aerorect::core::ImageSize::new(640, 480),
        1,
        255.0,
        2,
    ));
    aerorect::io::write_image(&dir.path().join("in.png"), &img).unwrap();
    let out = ok(&aerorect(
        &["undistort", "in.png", "und.png", "--camera", "cam.toml"],
        dir.path(),
    ));
    assert!(out.contains("640 x 480"), "{out}");
    let out = ok(&aerorect(
        &[
            "undistort",
            "in.png",
            "fit.png",
            "--camera",
            "cam.toml",
            "--fit",
        ],
        dir.path(),
    ));
    let fit = aerorect::io::read_image(&dir.path().join("fit.png")).unwrap();
    assert!(fit.size().width > 640 && fit.size().height > 480, "{out}");
}

#[test]
fn lens_commands_refuse_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let pts = data("calib/left_corners.csv");
    fails(
        &aerorect(
            &[
                "calibrate",
                "--points",
                &pts,
                "--image-size",
                "640x480",
                "--model",
                "fisheye",
            ],
            dir.path(),
        ),
        &["--model 'fisheye'"],
    );
    fails(
        &aerorect(
            &[
                "calibrate",
                "--points",
                &pts,
                "--image-size",
                "640",
                "--model",
                "tsai",
            ],
            dir.path(),
        ),
        &["--image-size '640'"],
    );
    fails(
        &aerorect(
            &[
                "calibrate",
                "--points",
                &pts,
                "--image-size",
                "640x480",
                "--model",
                "tsai",
                "--fix",
                "k7",
            ],
            dir.path(),
        ),
        &["unknown parameter name 'k7'"],
    );
    std::fs::write(dir.path().join("p.csv"), "image,X,Y,Z,u,v\na,0,0,0,1,nan\n").unwrap();
    fails(
        &aerorect(
            &[
                "calibrate",
                "--points",
                "p.csv",
                "--image-size",
                "640x480",
                "--model",
                "tsai",
            ],
            dir.path(),
        ),
        &["p.csv", "line 2: v = NaN"],
    );
    std::fs::write(
        dir.path().join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\n",
    )
    .unwrap();
    let img = aerorect::raster::AnyRaster::U8(aerorect_testkit::textured_scene(
        aerorect::core::ImageSize::new(64, 48),
        1,
        255.0,
        2,
    ));
    aerorect::io::write_image(&dir.path().join("in.png"), &img).unwrap();
    fails(
        &aerorect(
            &["undistort", "in.png", "o.png", "--camera", "cam.toml"],
            dir.path(),
        ),
        &["no [distortion] table"],
    );
    fails(
        &aerorect(
            &["undistort", "in.png", "in.png", "--camera", "cam.toml"],
            dir.path(),
        ),
        &["overwrite the input"],
    );
}

#[test]
fn a_distorting_camera_round_trips_through_simulate_rectify_evaluate() {
    let dir = tempfile::tempdir().unwrap();
    let cam = "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [320, 240]\n[distortion]\nmodel = \"improved\"\nk1 = -0.15\nk2 = 0.03\np1 = 0.001\np2 = -0.0005\n";
    std::fs::write(dir.path().join("cam.toml"), cam).unwrap();
    let att = "azimuth=10,elevation=20,image_rotation=1,pitch=2,roll=-1,yaw=30";
    let scene = data("aero1.jpg");
    ok(&aerorect(
        &[
            "simulate",
            &scene,
            "f.png",
            "--camera",
            "cam.toml",
            "--attitude",
            att,
            "--checkpoints",
            "25",
            "--checkpoints-out",
            "cp.csv",
        ],
        dir.path(),
    ));
    let out = ok(&aerorect(
        &[
            "evaluate",
            "--camera",
            "cam.toml",
            "--attitude",
            att,
            "--checkpoints",
            "cp.csv",
            "--json",
        ],
        dir.path(),
    ));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v["rmse"].as_f64().unwrap() < 0.01, "{out}");
    // Without the lens model the same points are off by pixels: the distortion is really there.
    std::fs::write(
        dir.path().join("plain.toml"),
        cam.split("[distortion]").next().unwrap(),
    )
    .unwrap();
    let out = ok(&aerorect(
        &[
            "evaluate",
            "--camera",
            "plain.toml",
            "--attitude",
            att,
            "--checkpoints",
            "cp.csv",
            "--json",
        ],
        dir.path(),
    ));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(v["rmse"].as_f64().unwrap() > 0.5, "{out}");
    ok(&aerorect(
        &[
            "rectify",
            "f.png",
            "r.tif",
            "--camera",
            "cam.toml",
            "--attitude",
            att,
            "--interp",
            "bicubic",
        ],
        dir.path(),
    ));
}

#[test]
fn undistort_fit_of_a_folding_lens_stops_at_the_fold_without_ghosts() {
    // OpenCV's x (1 + k1 r^2) with k1 = -0.4 folds at ideal r = 1/sqrt(1.2) = 0.9129 (182.6 px
    // at fx = 200), where the observed radius peaks at 121.7 px: the 320 x 240 frame's corners
    // (200 px out) lie beyond every ray, and rays beyond the fold fold back into the frame.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cam.toml"),
        "fx_px = 200.0\nfy_px = 200.0\ncx_px = 159.5\ncy_px = 119.5\nimage_size_px = [320, 240]\n\
         [distortion]\nmodel = \"opencv\"\nk1 = -0.4\n",
    )
    .unwrap();
    let size = aerorect::core::ImageSize::new(320, 240);
    let white = aerorect::raster::Raster::filled(size, 1, 255u8).unwrap();
    aerorect::io::write_image(
        &dir.path().join("in.png"),
        &aerorect::raster::AnyRaster::U8(white),
    )
    .unwrap();
    let args = [
        "undistort",
        "in.png",
        "fit.png",
        "--camera",
        "cam.toml",
        "--fit",
        "--interp",
        "nearest",
    ];
    let out = ok(&aerorect(&args, dir.path()));
    let fit = aerorect::io::read_image(&dir.path().join("fit.png")).unwrap();
    let fold_px = 200.0 / 1.2f64.sqrt();
    // The fitted width spans the fold's circle (the rim meets neither side of the frame).
    let w = fit.size().width as f64;
    assert!((w - 2.0 * fold_px).abs() < 4.0, "{w} {out}");
    // Output pixels are ideal pixels of the same focal length; the principal point sits at the
    // centre of the fitted grid. Nothing is drawn beyond the fold, most within it is.
    let plane = fit.plane_f32(0);
    let (fw, fh) = (fit.size().width, fit.size().height);
    let (cx, cy) = ((fw as f64 - 1.0) / 2.0, (fh as f64 - 1.0) / 2.0);
    let (mut beyond, mut inside, mut inside_drawn) = (0, 0, 0);
    for r in 0..fh {
        for c in 0..fw {
            let radius = (c as f64 - cx).hypot(r as f64 - cy);
            let drawn = plane[r * fw + c] > 0.0;
            if radius > fold_px + 1.5 {
                beyond += usize::from(drawn);
            } else if radius < fold_px - 1.5 && (r as f64 - cy).abs() < 150.0 {
                inside += 1;
                inside_drawn += usize::from(drawn);
            }
        }
    }
    assert_eq!(beyond, 0, "pixels drawn beyond the lens's fold (ghosts)");
    assert!(
        inside_drawn as f64 > 0.95 * inside as f64,
        "{inside_drawn} of {inside}"
    );
}
