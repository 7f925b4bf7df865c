//! Helpers shared by the CLI tests: run the binary, expect success or a failure naming things.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::Path;
use std::process::{Command, Output};

pub fn aerorect(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// The path of a bundled file under the repository's data/ folder.
pub fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name)
        .to_str()
        .unwrap()
        .to_string()
}

/// Asserts success and returns stdout.
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Asserts failure with every needle in stderr.
pub fn fails(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "should have failed; stdout: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    for n in needles {
        assert!(err.contains(n), "stderr lacks '{n}': {err}");
    }
}

/// The bundled JPEG (data/aero1.jpg) with an APP1 XMP packet inserted after SOI, written to
/// `dir/name`.
pub fn jpeg_with_xmp(dir: &Path, name: &str, xmp: Option<&str>) -> std::path::PathBuf {
    let jpeg =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/aero1.jpg")).unwrap();
    let mut out = jpeg[..2].to_vec();
    if let Some(x) = xmp {
        let mut payload = b"http://ns.adobe.com/xap/1.0/\0".to_vec();
        payload.extend_from_slice(x.as_bytes());
        out.extend_from_slice(&[0xff, 0xe1]);
        out.extend_from_slice(&((payload.len() + 2) as u16).to_be_bytes());
        out.extend_from_slice(&payload);
    }
    out.extend_from_slice(&jpeg[2..]);
    let p = dir.join(name);
    std::fs::write(&p, out).unwrap();
    p
}
