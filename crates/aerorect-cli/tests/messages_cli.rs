//! Messages a user reads (issue 12, item 11): batch names a failed frame once and prints each
//! frame's warnings on the terminal; motion-sim's default frame size fits the scenes.
#![allow(clippy::unwrap_used)]

mod common;
use common::{aerorect, fails, jpeg_with_xmp, ok};

const XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="+53.900000" drone-dji:GpsLongtitude="+27.550000" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+30.00" drone-dji:GimbalPitchDegree="-80.00"/></rdf:RDF></x:xmpmeta>"#;

#[test]
fn batch_names_a_failed_frame_once_and_prints_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    let a = jpeg_with_xmp(d, "a.jpg", Some(XMP));
    std::fs::write(d.join("broken.jpg"), &std::fs::read(&a).unwrap()[..3000]).unwrap();
    let out = aerorect(
        &[
            "batch",
            "a.jpg",
            "broken.jpg",
            "--out-dir",
            "out",
            "--camera",
            "cam.toml",
            "--gsd-m",
            "0.5",
        ],
        d,
    );
    fails(&out, &["broken.jpg"]);
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    for line in text
        .lines()
        .filter(|l| l.contains("broken.jpg") && l.contains("FAILED"))
    {
        assert_eq!(line.matches("broken.jpg").count(), 1, "{line}");
    }
    assert!(
        text.lines().any(|l| l.contains("failed: broken.jpg")),
        "{text}"
    );
    // The metadata frame's warning (height from RelativeAltitude) is on the terminal.
    assert!(
        text.contains("warning: height from RelativeAltitude"),
        "{text}"
    );
}

#[test]
fn motion_sim_default_size_fits_small_scenes() {
    use aerorect::core::ImageSize;
    use aerorect::raster::{AnyRaster, Raster};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene: Raster<u8> = aerorect_testkit::textured_scene(ImageSize::new(100, 100), 1, 200.0, 3);
    aerorect::io::write_image(&d.join("s.png"), &AnyRaster::U8(scene)).unwrap();
    // 100 px scenes hold 64 px frames with a 2.5 px shift margin (64 + 2 x 5 <= 100).
    let stdout = ok(&aerorect(
        &[
            "motion-sim",
            "s.png",
            "--trials",
            "2",
            "--snr-db",
            "10",
            "--method",
            "phase",
        ],
        d,
    ));
    assert!(stdout.contains("64 x 64 frames"), "{stdout}");
    let out = aerorect(
        &[
            "motion-sim",
            "s.png",
            "--trials",
            "2",
            "--size",
            "128",
            "--plot",
            "p.svg",
        ],
        d,
    );
    fails(&out, &["100 x 100", "128 x 128", "smaller --size"]);
}
