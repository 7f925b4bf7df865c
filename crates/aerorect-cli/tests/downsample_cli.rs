//! `--interp average` and `--no-prefilter` through the binary: a frame rectified 4x smaller
//! (altitude normalisation H1 / H = 1/4) and at its own scale.
#![allow(clippy::unwrap_used)]

mod common;
use aerorect::raster::AnyRaster;
use common::{aerorect, data, ok};

const ATT: &str = "azimuth=10,elevation=25,image_rotation=1,pitch=2,roll=-1,yaw=30";

fn rectify(d: &std::path::Path, out: &str, extra: &[&str]) -> (AnyRaster, serde_json::Value) {
    let mut args = vec![
        "rectify",
        "scene.jpg",
        out,
        "--camera",
        "cam.toml",
        "--attitude",
        ATT,
        "--report",
        "r.json",
    ];
    args.extend_from_slice(extra);
    ok(&aerorect(&args, d));
    let report = std::fs::read_to_string(d.join("r.json")).unwrap();
    (
        aerorect::io::read_image(&d.join(out)).unwrap(),
        serde_json::from_str(&report).unwrap(),
    )
}

/// The scene (aero1.jpg) and a 640 x 480 camera in `d`.
fn scene_and_camera(d: &std::path::Path) {
    std::fs::copy(data("aero1.jpg"), d.join("scene.jpg")).unwrap();
    std::fs::write(
        d.join("cam.toml"),
        "focal_length_mm = 6.0\npixel_pitch_um = [15.0, 15.0]\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
}

/// Sum of |difference| between horizontal neighbours of band 0: aliasing adds false detail.
fn roughness(img: &AnyRaster) -> f64 {
    let w = img.size().width;
    let p = img.plane_f32(0);
    p.chunks(w)
        .flat_map(|row| row.windows(2).map(|v| (v[1] - v[0]).abs() as f64))
        .sum()
}

#[test]
fn average_and_the_prefilter_reach_the_warp() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_and_camera(d);
    let small = ["--altitude-m", "25", "--base-altitude-m", "100"];
    let (avg, r) = rectify(
        d,
        "avg.png",
        &[&["--interp", "average"][..], &small].concat(),
    );
    assert_eq!(r["interp"], "average");
    let (pf, _) = rectify(d, "pf.png", &small);
    let (plain, _) = rectify(d, "plain.png", &[&["--no-prefilter"][..], &small].concat());
    assert_ne!(pf, plain, "the prefilter acts at 4x");
    // The prefiltered and averaged frames are smoother than plain bilinear's aliased one.
    let (ra, rp, rn) = (roughness(&avg), roughness(&pf), roughness(&plain));
    assert!(
        ra < 0.8 * rn && rp < 0.8 * rn,
        "average {ra}, prefiltered {rp}, plain {rn}"
    );
    // At the frame's own scale the flag changes nothing.
    let (a, _) = rectify(d, "a.png", &[]);
    let (b, _) = rectify(d, "b.png", &["--no-prefilter"]);
    assert_eq!(a, b);
}

#[test]
fn exact_coordinates_reach_the_warp_and_change_at_most_one_level() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    scene_and_camera(d);
    for interp in ["nearest", "bilinear", "bicubic"] {
        let (fast, _) = rectify(d, "fast.png", &["--interp", interp]);
        let exact_args = ["--interp", interp, "--exact-coordinates"];
        let (exact, _) = rectify(d, "exact.png", &exact_args);
        let (AnyRaster::U8(fast), AnyRaster::U8(exact)) = (fast, exact) else {
            panic!("the JPEG's frame is u8");
        };
        // Fast positions are within 5e-4 px of exact ones: nearest picks another pixel only
        // where a position lies that close to a pixel edge; bilinear and bicubic round one level
        // off at most (Keys' weights sum to at most 1.25 in magnitude and their slopes to 3, so a
        // bicubic value moves by < 255 x 3 x 1.25 x (5e-4 + 5e-4) < 1).
        let (mut differ, mut total) = (0usize, 0usize);
        for b in 0..fast.bands() {
            for (x, y) in fast.plane(b).iter().zip(exact.plane(b)) {
                total += 1;
                differ += usize::from(x != y);
                if interp != "nearest" {
                    assert!(x.abs_diff(*y) <= 1, "{interp}: {x} vs {y}");
                }
            }
        }
        assert!(
            differ * 500 < total,
            "{interp}: {differ} of {total} samples differ"
        );
        if interp != "nearest" {
            // The flag reaches the warp: a few samples (54 of 2.3 million for bilinear) round
            // the other way.
            assert!(differ > 0, "--exact-coordinates changed nothing");
        }
    }
}
