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
