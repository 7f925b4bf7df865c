//! `mosaic` and `--cog` end to end on two overlapping synthetic DJI frames (the bundled photo
//! with two XMP packets, one 16.7 m north of the other): the mosaic lies on the frames' shared
//! grid and, where one frame alone covers the ground, equals that frame's ortho from `rectify`
//! (read back pixel by pixel at the same ground position); `--cog` writes the COG layout
//! (header, tiled first IFD, overviews); bad `--out` and `--blend` are refused.
#![allow(clippy::unwrap_used, clippy::needless_range_loop)]

mod common;
use aerorect::io::GeoReference;
use aerorect::raster::AnyRaster;
use common::{aerorect, fails, ok};
use std::path::{Path, PathBuf};

/// The bundled JPEG looking straight down from 80 m, at latitude `lat`.
fn photo(dir: &Path, name: &str, lat: &str) -> PathBuf {
    let x = format!(
        r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:GpsLatitude="{lat}" drone-dji:GpsLongtitude="+27.550000" drone-dji:AbsoluteAltitude="+310.00" drone-dji:RelativeAltitude="+80.00" drone-dji:GimbalRollDegree="+0.00" drone-dji:GimbalYawDegree="+0.00" drone-dji:GimbalPitchDegree="-90.00"/></rdf:RDF></x:xmpmeta>"#
    );
    common::jpeg_with_xmp(dir, name, Some(&x))
}

fn setup() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_path_buf();
    std::fs::write(
        d.join("cam.toml"),
        "fx_px = 500.0\nfy_px = 500.0\nimage_size_px = [640, 480]\n",
    )
    .unwrap();
    photo(&d, "a.jpg", "+53.900000");
    photo(&d, "b.jpg", "+53.900150");
    (dir, d)
}

/// A u8 GeoTIFF's planes and georeference.
fn read(p: &Path) -> (Vec<Vec<u8>>, usize, usize, GeoReference) {
    let AnyRaster::U8(r) = aerorect::io::read_image(p).unwrap() else {
        panic!("{}: not u8", p.display());
    };
    let geo = aerorect::io::read_georeference(p).unwrap().unwrap();
    (r.planes().to_vec(), r.width(), r.height(), geo)
}

/// The pixel of `g` whose centre is the ground point (x, y); `None` outside, and a panic when
/// the point is not a pixel centre of `g`'s grid (the grids must be shared).
fn pixel_at(g: &GeoReference, w: usize, h: usize, x: f64, y: f64) -> Option<usize> {
    let c = (x - g.top_left[0]) / g.pixel_size[0] - 0.5;
    let r = (g.top_left[1] - y) / g.pixel_size[1] - 0.5;
    assert!(
        (c - c.round()).abs() < 1e-6 && (r - r.round()).abs() < 1e-6,
        "({x}, {y}) is not a pixel centre of {:?}",
        g.top_left
    );
    let (c, r) = (c.round(), r.round());
    (c >= 0.0 && r >= 0.0 && c < w as f64 && r < h as f64).then(|| r as usize * w + c as usize)
}

#[test]
fn mosaic_equals_each_frames_ortho_where_it_alone_covers() {
    let (_t, d) = setup();
    let cam = ["--camera", "cam.toml", "--gsd-m", "0.25"];
    for (i, o) in [("a.jpg", "ra.tif"), ("b.jpg", "rb.tif")] {
        ok(&aerorect(
            &[&["rectify", i, o, "--alpha"][..], &cam].concat(),
            &d,
        ));
    }
    let out = ok(&aerorect(
        &[&["mosaic", "a.jpg", "b.jpg", "--out", "m.tif"][..], &cam].concat(),
        &d,
    ));
    assert!(
        out.contains("2 frames -> m.tif") && out.contains("0.250 m/px"),
        "{out}"
    );
    let (m, mw, mh, mg) = read(&d.join("m.tif"));
    let frames = [read(&d.join("ra.tif")), read(&d.join("rb.tif"))];
    let bands = m.len() - 1;
    assert_eq!(bands + 1, frames[0].0.len(), "image bands + alpha");
    assert_eq!(mg.pixel_size, [0.25, 0.25]);
    let (mut compared, mut both) = ([0usize; 2], 0);
    for (k, (planes, w, h, g)) in frames.iter().enumerate() {
        let other = &frames[1 - k];
        for i in 0..w * h {
            if planes[bands][i] == 0 {
                continue;
            }
            let x = g.top_left[0] + (i % w) as f64 * 0.25 + 0.125;
            let y = g.top_left[1] - (i / w) as f64 * 0.25 - 0.125;
            let j = pixel_at(&mg, mw, mh, x, y).expect("the mosaic covers every frame");
            assert_eq!(
                m[bands][j], 255,
                "covered by frame {k}, empty in the mosaic"
            );
            let covered_by_other =
                pixel_at(&other.3, other.1, other.2, x, y).is_some_and(|o| other.0[bands][o] != 0);
            if covered_by_other {
                both += 1;
                continue;
            }
            for b in 0..bands {
                assert_eq!(
                    m[b][j], planes[b][i],
                    "band {b} at ({x}, {y}): mosaic vs frame {k}"
                );
            }
            compared[k] += 1;
        }
    }
    assert!(
        compared[0] > 5_000 && compared[1] > 5_000 && both > 50_000,
        "{compared:?} {both}"
    );
}

/// Tags of each IFD of a little-endian classic TIFF, following the chain from the header.
fn ifds(bytes: &[u8]) -> (u32, Vec<Vec<(u16, u32)>>) {
    assert_eq!(&bytes[..4], b"II*\0", "classic little-endian TIFF");
    let u16_at = |o: usize| u16::from_le_bytes([bytes[o], bytes[o + 1]]);
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let first = u32_at(4);
    let (mut at, mut out) = (first as usize, Vec::new());
    while at != 0 {
        let n = u16_at(at) as usize;
        let tags = (0..n)
            .map(|e| {
                let o = at + 2 + 12 * e;
                let value = match u16_at(o + 2) {
                    3 => u16_at(o + 8) as u32,
                    _ => u32_at(o + 8),
                };
                (u16_at(o), value)
            })
            .collect();
        out.push(tags);
        at = u32_at(at + 2 + 12 * n) as usize;
    }
    (first, out)
}

fn tag(ifd: &[(u16, u32)], t: u16) -> Option<u32> {
    ifd.iter().find(|e| e.0 == t).map(|e| e.1)
}

#[test]
fn cog_outputs_have_the_cog_layout_and_the_mosaics_pixels() {
    let (_t, d) = setup();
    // 0.1 m: the mosaic is about 1000 px across, more than one 512 px tile, so it has overviews.
    let cam = ["--camera", "cam.toml", "--gsd-m", "0.1"];
    let run = |extra: &[&str]| {
        ok(&aerorect(
            &[&["mosaic", "a.jpg", "b.jpg"][..], &cam, extra].concat(),
            &d,
        ))
    };
    let out = run(&["--out", "cog.tif", "--cog"]);
    assert!(out.contains("cloud-optimised"), "{out}");
    run(&["--out", "tiled.tif"]);
    ok(&aerorect(
        &[&["rectify", "a.jpg", "ra.tif", "--cog"][..], &cam].concat(),
        &d,
    ));
    for name in ["cog.tif", "ra.tif"] {
        let (first, ifds) = ifds(&std::fs::read(d.join(name)).unwrap());
        assert_eq!(first, 8, "{name}: the first IFD follows the header");
        let full = &ifds[0];
        let (w, h) = (tag(full, 256).unwrap(), tag(full, 257).unwrap());
        assert!(w > 512 || h > 512, "{name}: {w} x {h}");
        assert_eq!(tag(full, 322), Some(512), "{name}: tiled");
        assert!(
            tag(full, 324).is_some() && tag(full, 273).is_none(),
            "{name}"
        );
        assert!(tag(full, 33922).is_some(), "{name}: georeferenced");
        // NewSubfileType 1: a reduced-resolution image (an overview).
        let overviews = ifds.iter().filter(|i| tag(i, 254) == Some(1)).count();
        assert!(overviews >= 1, "{name}: no overview");
        assert!(
            ifds.iter().all(|i| tag(i, 322) == Some(512)),
            "{name}: every IFD tiled"
        );
    }
    // The COG holds the tiled mosaic's pixels; its alpha band became the internal mask.
    let (tiled, _, _, tg) = read(&d.join("tiled.tif"));
    let (cog, _, _, cg) = read(&d.join("cog.tif"));
    assert_eq!((tg.top_left, tg.pixel_size), (cg.top_left, cg.pixel_size));
    let bands = tiled.len() - 1;
    assert_eq!(cog.len(), bands, "the alpha band is the COG's mask");
    for i in 0..tiled[0].len() {
        if tiled[bands][i] != 0 {
            for b in 0..bands {
                assert_eq!(cog[b][i], tiled[b][i], "band {b} pixel {i}");
            }
        }
    }
}

#[test]
fn bad_outputs_and_blends_are_refused_and_nothing_is_written() {
    let (_t, d) = setup();
    let base = [
        "mosaic", "a.jpg", "b.jpg", "--camera", "cam.toml", "--gsd-m", "0.25",
    ];
    ok(&aerorect(
        &["rectify", "a.jpg", "ra.tif", "--camera", "cam.toml"],
        &d,
    ));
    let before = std::fs::read(d.join("ra.tif")).unwrap();
    let refused = |extra: &[&str], needles: &[&str]| {
        fails(&aerorect(&[&base[..], extra].concat(), &d), needles);
    };
    // An --out naming an input (a photo, here also given as a .tif) is refused before any work.
    refused(
        &["ra.tif", "--out", "./ra.tif"],
        &[
            "--out",
            "would overwrite the input PHOTOS",
            "nothing written",
        ],
    );
    assert_eq!(std::fs::read(d.join("ra.tif")).unwrap(), before);
    refused(&["--out", "a.jpg"], &["--out a.jpg", "would overwrite"]);
    refused(
        &["--out", "m.tif", "--blend", "soft"],
        &["unknown blend 'soft'", "feather or none"],
    );
    refused(&["--out", "m.png"], &["--out m.png", ".tif"]);
    assert!(!d.join("m.tif").exists() && !d.join("m.png").exists());
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(left.is_empty());
}
