//! The readers each input goes through, every call under `catch_unwind`, with the properties
//! checked: no panic, an error names the file (or argument) it is about, the allocation peak
//! stays within the readers' limits.

use super::alloc;
use super::seeds::{self, Kind};
use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::metadata::{dji_number, dji_tags, xmp_packet};
use aerorect_io::{CameraFile, IoError};
use std::cell::RefCell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::Instant;

/// A peak above this (bytes) for one reader call is a finding: the readers' own limit is
/// 4 GiB of decoded samples, and every seed decodes to a few kilobytes.
pub const ABSURD_PEAK: usize = 1 << 30;

/// What one reader call did.
pub enum Verdict {
    Ok,
    Err,
    /// A property broken: what and where.
    Finding(String),
}

pub struct Call {
    pub reader: &'static str,
    pub verdict: Verdict,
    pub peak: usize,
    pub seconds: f64,
}

thread_local! {
    /// Set while a reader runs under the harness: the panic hook records instead of printing.
    static CAPTURE: RefCell<Option<Option<String>>> = const { RefCell::new(None) };
}

/// Installs (once) a panic hook that, on a harness thread inside a reader call, records the
/// message and location instead of printing them; elsewhere it prints as usual.
pub fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let captured = CAPTURE.with(|c| {
                let mut c = c.borrow_mut();
                match c.as_mut() {
                    Some(slot) => {
                        let loc = info
                            .location()
                            .map(|l| format!("{}:{}", l.file(), l.line()))
                            .unwrap_or_default();
                        let msg = info
                            .payload()
                            .downcast_ref::<&str>()
                            .map(|s| s.to_string())
                            .or_else(|| info.payload().downcast_ref::<String>().cloned())
                            .unwrap_or_default();
                        *slot = Some(format!("panic at {loc}: {msg}"));
                        true
                    }
                    None => false,
                }
            });
            if !captured {
                default(info);
            }
        }));
    });
}

/// Runs one reader call. `name` is what its error must mention (None: no file to name).
fn call<T>(
    out: &mut Vec<Call>,
    reader: &'static str,
    name: Option<&str>,
    f: impl FnOnce() -> Result<T, IoError>,
) -> Option<T> {
    CAPTURE.with(|c| *c.borrow_mut() = Some(None));
    let base = alloc::reset();
    let t0 = Instant::now();
    let r = catch_unwind(AssertUnwindSafe(f));
    let seconds = t0.elapsed().as_secs_f64();
    let (peak, _) = alloc::measured(base);
    let hooked = CAPTURE.with(|c| c.borrow_mut().take()).flatten();
    let (verdict, value) = match r {
        Err(_) => (
            Verdict::Finding(hooked.unwrap_or_else(|| "panic".into())),
            None,
        ),
        Ok(Err(e)) => {
            let msg = e.to_string();
            match name {
                Some(n) if !msg.contains(n) => (
                    Verdict::Finding(format!("error does not name {n}: {msg}")),
                    None,
                ),
                _ => (Verdict::Err, None),
            }
        }
        Ok(Ok(v)) => (Verdict::Ok, Some(v)),
    };
    let verdict = match verdict {
        Verdict::Finding(_) => verdict,
        _ if peak > ABSURD_PEAK => Verdict::Finding(format!("allocated {peak} bytes at peak")),
        v => v,
    };
    out.push(Call {
        reader,
        verdict,
        peak,
        seconds,
    });
    value
}

/// The file names camera files are read under (the format is detected from name and content).
const CAMERA_NAMES: [&str; 7] = [
    "camera.toml",
    "camera.yml",
    "camera.yaml",
    "camera.xml",
    "cameras.json",
    "cameras.txt",
    "camera.txt",
];

/// Every reader that takes this kind of input; `dir` is this worker's scratch folder.
pub fn run(kind: Kind, bytes: &[u8], dir: &Path) -> Vec<Call> {
    let mut out = Vec::new();
    let text = String::from_utf8_lossy(bytes);
    let file = |name: &str| {
        let p = dir.join(name);
        std::fs::write(&p, bytes).expect("write input");
        p
    };
    match kind {
        Kind::Image => {
            let p = file("input.img");
            let n = Some("input.img");
            call(&mut out, "read_image", n, || aerorect_io::read_image(&p));
            call(&mut out, "decode_image_bytes", Some("input-bytes"), || {
                aerorect_io::decode_image_bytes(bytes, "input-bytes")
            });
            call(&mut out, "read_photo_metadata", n, || {
                aerorect_io::read_photo_metadata(&p)
            });
            call(&mut out, "read_georeference", n, || {
                aerorect_io::read_georeference(&p)
            });
            call(&mut out, "read_dem", n, || aerorect_io::read_dem(&p));
        }
        Kind::Xmp => {
            call(&mut out, "xmp_packet+dji_tags", None, || {
                let x = xmp_packet(bytes).unwrap_or(&text);
                if let Ok(tags) = dji_tags(x) {
                    for (k, v) in &tags {
                        let _ = dji_number(k, v);
                    }
                }
                Ok::<_, IoError>(())
            });
            static JPEG: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
            let jpeg = JPEG.get_or_init(|| {
                let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg");
                std::fs::read(p).expect("data/aero1.jpg")
            });
            let p = dir.join("xmp.jpg");
            let photo = seeds::with_app1(jpeg, false, Some(bytes));
            std::fs::write(&p, photo).expect("write input");
            call(
                &mut out,
                "read_photo_metadata(xmp)",
                Some("xmp.jpg"),
                || aerorect_io::read_photo_metadata(&p),
            );
        }
        Kind::CameraToml => {
            let size = ImageSize::new(640, 480);
            let cam = call(&mut out, "CameraFile::parse", Some("camera.toml"), || {
                CameraFile::parse(&text, "camera.toml")
            });
            if let Some(cam) = cam {
                call(&mut out, "CameraFile::camera", Some("camera.toml"), || {
                    cam.camera(Some(size))
                });
                call(
                    &mut out,
                    "CameraFile::camera(None)",
                    Some("camera.toml"),
                    || cam.camera(None),
                );
            }
            let p = file("camera-file.toml");
            call(
                &mut out,
                "CameraFile::read",
                Some("camera-file.toml"),
                || CameraFile::read(&p),
            );
        }
        Kind::CameraFormat | Kind::HostileCamera => {
            // The file readers, under each name the formats are detected by (as `--camera`
            // and `camera convert` read them), then every format's reader on the text.
            // A text over the cap is refused before its name matters: one name is enough.
            let over = bytes.len() as u64 > aerorect_io::MAX_TEXT_BYTES;
            for &name in &CAMERA_NAMES[..if over { 1 } else { CAMERA_NAMES.len() }] {
                let p = file(name);
                call(&mut out, name, Some(name), || CameraFile::read(&p));
                call(&mut out, "read_camera_file", Some(name), || {
                    aerorect_io::read_camera_file(&p, None, Some(ImageSize::new(640, 480)))
                });
            }
            if over {
                return out;
            }
            for f in aerorect_io::CameraFormat::ALL {
                call(&mut out, f.name(), Some("camera.fmt"), || {
                    // Only DewarpData needs the size (another would resize the camera).
                    let size = (f == aerorect_io::CameraFormat::DjiDewarp)
                        .then_some(ImageSize::new(640, 480));
                    aerorect_io::camera_from_text(&text, f, size, "camera.fmt")
                });
            }
        }
        Kind::AttitudeToml => {
            let p = file("attitude.toml");
            let arg = p.display().to_string();
            call(
                &mut out,
                "read_attitude(file)",
                Some("attitude.toml"),
                || aerorect_io::read_attitude(&arg),
            );
        }
        Kind::AttitudeInline => {
            call(&mut out, "read_attitude(inline)", Some("attitude"), || {
                aerorect_io::read_attitude(&text)
            });
        }
        Kind::Checkpoints | Kind::Gcps | Kind::ControlPoints | Kind::Poses => {
            let p = file("table.csv");
            let n = Some("table.csv");
            call(&mut out, "read_checkpoints", n, || {
                aerorect_io::read_checkpoints(&p)
            });
            call(&mut out, "read_gcps", n, || aerorect_io::read_gcps(&p));
            call(&mut out, "read_control_points", n, || {
                aerorect_io::read_control_points(&p)
            });
            call(&mut out, "read_poses", n, || aerorect_io::read_poses(&p));
        }
        Kind::Crs => {
            let crs = call(&mut out, "Crs::parse", None, || Ok(Crs::parse(&text)?));
            if let Some(c) = crs {
                call(&mut out, "Crs::to_wkt", None, || Ok(c.to_wkt()?));
                call(&mut out, "Crs::from_lon_lat", None, || {
                    Ok(c.from_lon_lat(24.4, -33.7)?)
                });
            }
        }
    }
    out
}
