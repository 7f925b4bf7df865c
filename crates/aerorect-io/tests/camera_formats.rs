//! Camera file formats: each writes and reads back our camera to 1e-9 relative, refuses terms it
//! cannot carry by name, and reads an external sample to its known values (OpenCV's own
//! calibration file, Orthority's NGI camera, samples written from each format's documentation).
//! The conventions (pixel origin, normalisation, p1/p2 order) are checked against each format's
//! own projection formula, written out here.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::excessive_precision)]

use aerorect_core::distortion::{Distortion, OpenCv, OpenCvTerms, Tsai};
use aerorect_core::{Camera, ImageSize, Intrinsics};
use aerorect_io::{CameraFormat, camera_from_text, text_from_camera};
use aerorect_testkit::shared_data;
use std::path::Path;

fn lens(terms: OpenCvTerms, c: [f64; 12]) -> Option<Distortion> {
    let mut o = OpenCv::with_terms(terms);
    o.set_coefficients(c);
    Some(Distortion::OpenCv(o))
}

fn camera(fx: f64, fy: f64, cx: f64, cy: f64, skew: f64, d: Option<Distortion>) -> Camera {
    let mut k = Intrinsics::new(fx, fy, cx, cy).unwrap();
    k.skew = skew;
    Camera::new(k, d, ImageSize::new(4000, 3000))
}

const FIVE: [f64; 12] = [
    -0.2653, 0.0467, 1.83e-3, -3.15e-4, 0.2523, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];
const TWELVE: [f64; 12] = [
    -0.2653, 0.0467, 1.83e-3, -3.15e-4, 0.2523, 0.013, -0.021, 4.5e-3, 2e-4, -1e-4, 3e-4, -5e-5,
];

fn coefficients(c: &Camera) -> [f64; 12] {
    match &c.distortion {
        None => [0.0; 12],
        Some(Distortion::OpenCv(o)) => o.coefficients(),
        Some(d) => panic!("{d:?}"),
    }
}

fn assert_same(a: &Camera, b: &Camera, what: &str) {
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) + 1e-300;
    let (ka, kb) = (&a.intrinsics, &b.intrinsics);
    for (n, x, y) in [
        ("fx", ka.fx, kb.fx),
        ("fy", ka.fy, kb.fy),
        ("cx", ka.cx, kb.cx),
        ("cy", ka.cy, kb.cy),
        ("skew", ka.skew, kb.skew),
    ] {
        assert!(close(x, y), "{what}: {n} {x} vs {y}");
    }
    assert_eq!(a.size, b.size, "{what}");
    for (i, (x, y)) in coefficients(a).iter().zip(coefficients(b)).enumerate() {
        assert!(close(*x, y), "{what}: coefficient {i} {x} vs {y}");
    }
    assert_eq!(
        a.distortion.as_ref().map(Distortion::kind),
        b.distortion.as_ref().map(Distortion::kind),
        "{what}"
    );
}

fn round_trip(c: &Camera, format: CameraFormat) -> Camera {
    let text = text_from_camera(c, format, "out").unwrap();
    let size = (format == CameraFormat::DjiDewarp).then_some(c.size);
    camera_from_text(&text, format, size, "out")
        .unwrap_or_else(|e| panic!("{}: {e}\n{text}", format.name()))
}

#[test]
fn every_format_round_trips_the_cameras_it_can_carry() {
    use CameraFormat::*;
    let off = |skew, d| camera(3678.9, 3671.5, 2010.25, 1482.75, skew, d);
    let centred = camera(
        3678.9,
        3678.9,
        1999.5,
        1499.5,
        0.0,
        lens(OpenCvTerms::Standard, {
            let mut c = [0.0; 12];
            (c[0], c[1]) = (-0.12, 0.03);
            c
        }),
    );
    let cases: Vec<(CameraFormat, Camera)> = vec![
        (Toml, off(0.7, lens(OpenCvTerms::RationalThinPrism, TWELVE))),
        (
            OpenCvYaml,
            off(0.7, lens(OpenCvTerms::RationalThinPrism, TWELVE)),
        ),
        (OpenCvYaml, off(0.0, lens(OpenCvTerms::Standard, FIVE))),
        (
            OpenCvXml,
            off(
                0.7,
                lens(OpenCvTerms::Rational, {
                    let mut c = TWELVE;
                    c[8..].fill(0.0);
                    c
                }),
            ),
        ),
        (OpenCvXml, off(0.0, None)),
        (
            Colmap,
            off(
                0.0,
                lens(OpenCvTerms::Rational, {
                    let mut c = TWELVE;
                    c[8..].fill(0.0);
                    c
                }),
            ),
        ),
        (
            Colmap,
            off(
                0.0,
                lens(OpenCvTerms::Standard, {
                    let mut c = FIVE;
                    c[4] = 0.0;
                    c
                }),
            ),
        ),
        (Colmap, off(0.0, None)),
        // k3 needs FULL_OPENCV; the model read back is still the five-term one.
        (Colmap, off(0.0, lens(OpenCvTerms::Standard, FIVE))),
        (OpenSfm, off(0.0, lens(OpenCvTerms::Standard, FIVE))),
        (OpenSfm, centred.clone()),
        (Metashape, off(0.7, lens(OpenCvTerms::Standard, FIVE))),
        (DjiDewarp, off(0.0, lens(OpenCvTerms::Standard, FIVE))),
        (
            Orthority,
            off(0.0, lens(OpenCvTerms::RationalThinPrism, TWELVE)),
        ),
        (Orthority, off(0.0, lens(OpenCvTerms::Standard, FIVE))),
        (Orthority, centred),
        (Orthority, off(0.0, None)),
    ];
    for (format, c) in &cases {
        let back = round_trip(c, *format);
        assert_same(c, &back, format.name());
    }
    // Every format is covered.
    for f in CameraFormat::ALL {
        assert!(cases.iter().any(|(g, _)| *g == f), "{}", f.name());
    }
}

#[test]
fn a_term_a_format_cannot_carry_is_an_error_naming_it() {
    use CameraFormat::*;
    let with = |skew, d| camera(3000.0, 3000.0, 2000.0, 1500.0, skew, d);
    let prism = lens(OpenCvTerms::ThinPrism, {
        let mut c = FIVE;
        c[8] = 1e-3;
        c
    });
    let rational = lens(OpenCvTerms::Rational, {
        let mut c = FIVE;
        c[5] = 0.01;
        c
    });
    let tsai = Some(Distortion::Tsai(Tsai { k1: -0.1, k2: 0.0 }));
    for (format, c, named) in [
        (Colmap, with(0.0, prism.clone()), "s1"),
        (Colmap, with(0.5, None), "skew"),
        (OpenSfm, with(0.0, rational.clone()), "k4"),
        (OpenSfm, with(0.5, None), "skew"),
        (Metashape, with(0.0, rational.clone()), "k4"),
        (DjiDewarp, with(0.0, prism), "s1"),
        (DjiDewarp, with(0.0, rational), "k4"),
        (Orthority, with(0.5, None), "skew"),
        (OpenCvYaml, with(0.0, tsai.clone()), "tsai"),
        (Metashape, with(0.0, tsai), "tsai"),
    ] {
        let e = text_from_camera(&c, format, "out.x")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(named) && e.contains("out.x"),
            "{}: {e}",
            format.name()
        );
    }
}

/// OpenCV's own calibration of its chessboard sample (data/calib/left_intrinsics.yml).
#[test]
fn opencvs_sample_calibration_file_reads_to_its_values() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/calib/left_intrinsics.yml");
    let (c, f) = aerorect_io::read_camera_file(&path, None, None).unwrap();
    assert_eq!(f, CameraFormat::OpenCvYaml);
    let k = &c.intrinsics;
    assert_eq!((c.size.width, c.size.height), (640, 480));
    assert_eq!(
        (k.fx, k.fy, k.cx, k.cy, k.skew),
        (
            5.3591573396163199e+02,
            5.3591573396163199e+02,
            3.4228315473308373e+02,
            2.3557082909788173e+02,
            0.0
        )
    );
    let want = [
        -2.6637260909660682e-01,
        -3.8588898922304653e-02,
        1.7831947042852964e-03,
        -2.8122100441115472e-04,
        2.3839153080878486e-01,
    ];
    assert_eq!(&coefficients(&c)[..5], &want);
    assert_eq!(c.distortion.as_ref().unwrap().kind(), "opencv");
    // The same camera through OpenCV's XML layout.
    let xml = text_from_camera(&c, CameraFormat::OpenCvXml, "x").unwrap();
    assert!(xml.contains("<opencv_storage>") && xml.contains("type_id=\"opencv-matrix\""));
    assert_same(&c, &round_trip(&c, CameraFormat::OpenCvXml), "xml");
}

/// Orthority's NGI camera: pinhole, focal 120 mm, sensor 92.16 x 165.888 mm, 640 x 1152 px,
/// principal point at the centre.
#[test]
fn orthoritys_ngi_camera_reads_to_its_values() {
    let Some(path) = shared_data("ngi/ngi_int_param.yaml") else {
        return;
    };
    let (c, f) = aerorect_io::read_camera_file(&path, None, None).unwrap();
    assert_eq!(f, CameraFormat::Orthority);
    let k = &c.intrinsics;
    let close = |a: f64, b: f64| (a - b).abs() < 1e-9 * b;
    assert!(close(k.fx, 120.0 * 640.0 / 92.16) && close(k.fy, 120.0 * 1152.0 / 165.888));
    assert_eq!((k.cx, k.cy), (319.5, 575.5));
    assert!(c.distortion.is_none());
}

/// COLMAP's documented cameras.txt example (its "Output format" page), camera 3 alone: pixel
/// centres at +0.5, so (1536, 1152) is our (1535.5, 1151.5).
#[test]
fn colmaps_documented_example_reads_with_its_half_pixel_origin() {
    let text = "# Camera list with one line of data per camera:\n\
                #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\
                # Number of cameras: 1\n\
                3 SIMPLE_RADIAL 3072 2304 2559.69 1536 1152 -0.0218531\n";
    assert_eq!(
        CameraFormat::detect(Path::new("cams.txt"), Some(text)),
        Some(CameraFormat::Colmap)
    );
    let c = camera_from_text(text, CameraFormat::Colmap, None, "cameras.txt").unwrap();
    let k = &c.intrinsics;
    assert_eq!((k.fx, k.fy, k.cx, k.cy), (2559.69, 2559.69, 1535.5, 1151.5));
    assert_eq!(coefficients(&c)[0], -0.0218531);
    assert_eq!((c.size.width, c.size.height), (3072, 2304));
    let two = "1 PINHOLE 100 80 90 90 50 40\n2 PINHOLE 100 80 91 90 50 40\n";
    let e = camera_from_text(two, CameraFormat::Colmap, None, "c.txt").unwrap_err();
    assert!(e.to_string().contains("ids 1, 2"), "{e}");
    let e = camera_from_text(
        "1 OPENCV_FISHEYE 100 80 90 90 50 40 0 0 0 0\n",
        CameraFormat::Colmap,
        None,
        "c.txt",
    )
    .unwrap_err();
    assert!(e.to_string().contains("OPENCV_FISHEYE"), "{e}");
}

/// The observed pixel of normalised ideal point q through our camera.
fn our_pixel(c: &Camera, q: [f64; 2]) -> [f64; 2] {
    let d = c
        .distortion
        .as_ref()
        .map_or(q, |d| d.model().observed_from_ideal(q).unwrap());
    let k = &c.intrinsics;
    [k.fx * d[0] + k.skew * d[1] + k.cx, k.fy * d[1] + k.cy]
}

/// Metashape's frame model as its manual writes it (P1 with r^2 + 2x^2 in x, cx from the image
/// centre, pixel centres at +0.5): a hand-made calibration file gives the same pixel through our
/// camera, minus half a pixel.
#[test]
fn metashape_file_projects_as_metashapes_own_formula() {
    let text = r#"<?xml version="1.0" encoding="UTF-8"?>
<calibration>
  <projection>frame</projection>
  <width>5472</width>
  <height>3648</height>
  <f>3684.12</f>
  <cx>-11.25</cx>
  <cy>25.5</cy>
  <b1>-1.5</b1>
  <b2>0.75</b2>
  <k1>-0.0059</k1>
  <k2>0.0112</k2>
  <k3>-0.0143</k3>
  <p1>-0.0021</p1>
  <p2>0.0035</p2>
  <date>2020-01-01T00:00:00Z</date>
</calibration>"#;
    let c = camera_from_text(text, CameraFormat::Metashape, None, "cal.xml").unwrap();
    let (f, cx, cy, b1, b2) = (3684.12, -11.25, 25.5, -1.5, 0.75);
    let (k1, k2, k3, p1, p2) = (-0.0059, 0.0112, -0.0143, -0.0021, 0.0035);
    for q in [[0.3, -0.2], [-0.45, 0.31], [0.05, 0.4]] {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let xd = x * radial + p1 * (r2 + 2.0 * x * x) + 2.0 * p2 * x * y;
        let yd = y * radial + p2 * (r2 + 2.0 * y * y) + 2.0 * p1 * x * y;
        let u = 5472.0 * 0.5 + cx + xd * f + xd * b1 + yd * b2;
        let v = 3648.0 * 0.5 + cy + yd * f;
        let ours = our_pixel(&c, q);
        assert!(
            (ours[0] - (u - 0.5)).abs() < 1e-9 && (ours[1] - (v - 0.5)).abs() < 1e-9,
            "{q:?}: {ours:?} vs Metashape ({u}, {v}) - 0.5"
        );
    }
}

/// OpenSfM's brown camera as its documentation writes it: pixel = normalised coordinate times
/// max(W, H) about the image centre, the first pixel's centre at 0.5.
#[test]
fn opensfm_file_projects_as_opensfms_own_formula() {
    let text = r#"{
    "v2 dji fc6310 5472 3648 brown 0.6666": {
        "projection_type": "brown", "width": 5472, "height": 3648,
        "focal_x": 0.6672, "focal_y": 0.6669, "c_x": 0.0012, "c_y": -0.0021,
        "k1": -0.0031, "k2": 0.0102, "k3": -0.0098, "p1": 0.0003, "p2": -0.0002,
        "focal_x_prior": 0.6666
    }
}"#;
    let c = camera_from_text(text, CameraFormat::OpenSfm, None, "cameras.json").unwrap();
    let (fx, fy, cx, cy) = (0.6672, 0.6669, 0.0012, -0.0021);
    let (k1, k2, k3, p1, p2) = (-0.0031, 0.0102, -0.0098, 0.0003, -0.0002);
    let s = 5472.0;
    for q in [[0.3, -0.2], [-0.45, 0.31]] {
        let [x, y] = q;
        let r2 = x * x + y * y;
        let radial = 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
        let xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
        let yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
        let (xn, yn) = (fx * xd + cx, fy * yd + cy);
        // OpenSfM: normalised = (pixel + 0.5 - size / 2) / max(W, H).
        let u = xn * s - 0.5 + 5472.0 / 2.0;
        let v = yn * s - 0.5 + 3648.0 / 2.0;
        let ours = our_pixel(&c, q);
        assert!(
            (ours[0] - u).abs() < 1e-8 && (ours[1] - v).abs() < 1e-8,
            "{ours:?} vs ({u}, {v})"
        );
    }
    let bad = text.replace("\"brown\"", "\"fisheye\"");
    let e = camera_from_text(&bad, CameraFormat::OpenSfm, None, "cameras.json").unwrap_err();
    assert!(e.to_string().contains("fisheye"), "{e}");
}

/// DJI's DewarpData (the sample of aerorect-io's XMP test) for a 4000 x 3000 image: cx, cy are
/// offsets from ((W - 1) / 2, (H - 1) / 2).
#[test]
fn dji_dewarp_data_reads_as_offsets_from_the_centre() {
    let text = "2018-09-04;3678.9,3671.5,10.5,-17.2,-0.26,0.11,0.001,-0.0003,-0.23";
    assert_eq!(
        CameraFormat::detect(Path::new("dewarp.txt"), Some(text)),
        Some(CameraFormat::DjiDewarp)
    );
    let e = camera_from_text(text, CameraFormat::DjiDewarp, None, "d.txt").unwrap_err();
    assert!(e.to_string().contains("image size"), "{e}");
    let c = camera_from_text(
        text,
        CameraFormat::DjiDewarp,
        Some(ImageSize::new(4000, 3000)),
        "d",
    )
    .unwrap();
    let k = &c.intrinsics;
    assert_eq!((k.fx, k.fy, k.cx, k.cy), (3678.9, 3671.5, 2010.0, 1482.3));
    assert_eq!(
        &coefficients(&c)[..5],
        &[-0.26, 0.11, 0.001, -0.0003, -0.23]
    );
}

#[test]
fn formats_are_told_from_names_and_content() {
    let d = |p: &str, t: Option<&str>| CameraFormat::detect(Path::new(p), t);
    assert_eq!(d("a.toml", None), Some(CameraFormat::Toml));
    assert_eq!(
        d("a.yml", Some("%YAML:1.0\n---\n")),
        Some(CameraFormat::OpenCvYaml)
    );
    assert_eq!(
        d("a.yaml", Some("cam:\n  type: brown\n")),
        Some(CameraFormat::Orthority)
    );
    assert_eq!(
        d("a.xml", Some("<opencv_storage>")),
        Some(CameraFormat::OpenCvXml)
    );
    assert_eq!(
        d("a.xml", Some("<calibration>")),
        Some(CameraFormat::Metashape)
    );
    assert_eq!(d("a.xml", None), None);
    assert_eq!(d("cameras.json", None), Some(CameraFormat::OpenSfm));
    assert_eq!(d("cameras.txt", None), Some(CameraFormat::Colmap));
    // An OpenCV file with 14 coefficients and a tilt is refused by name.
    let tilt = "%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 5., 0., 4.5, 0., 5., 4.5, 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n   rows: 14\n   cols: 1\n   dt: d\n   data: [ 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 1e-3, 0. ]\n";
    let e = camera_from_text(tilt, CameraFormat::OpenCvYaml, None, "t.yml").unwrap_err();
    assert!(e.to_string().contains("tauX"), "{e}");
}
