//! What a command reads and writes, checked in one place before any work: no output may name
//! an input (the camera file, the points, the image, the DEM, ...) or another output.

use anyhow::{Result, bail};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A command's files, each with the flag (or argument name) that gave it.
#[derive(Default)]
pub(crate) struct Files {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<(String, PathBuf)>,
}

impl Files {
    pub(crate) fn new() -> Self {
        Self::default()
    }

    pub(crate) fn input(mut self, flag: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.inputs.push((flag.to_string(), p.to_path_buf()));
        }
        self
    }

    /// An attitude (or other) argument that is either inline text or a file: a file when one
    /// exists by that name.
    pub(crate) fn input_if_file(self, flag: &str, text: Option<&str>) -> Self {
        let file = text.map(Path::new).filter(|p| p.is_file());
        self.input(flag, file)
    }

    pub(crate) fn output(mut self, flag: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.outputs.push((flag.to_string(), p.to_path_buf()));
        }
        self
    }

    /// Refuses an output that names an input or another output.
    pub(crate) fn check(&self) -> Result<()> {
        let inputs: HashMap<PathBuf, &(String, PathBuf)> =
            self.inputs.iter().map(|f| (key(&f.1), f)).collect();
        let mut outputs: HashMap<PathBuf, &(String, PathBuf)> = HashMap::new();
        for out in &self.outputs {
            let k = key(&out.1);
            if let Some((flag, p)) = inputs.get(&k) {
                bail!(
                    "{} {}: would overwrite the input {flag} {}; nothing written",
                    out.0,
                    out.1.display(),
                    p.display()
                );
            }
            if let Some((flag, p)) = outputs.insert(k, out) {
                bail!(
                    "{} {} and {flag} {} are the same file: one output would replace the other; nothing written",
                    out.0,
                    out.1.display(),
                    p.display()
                );
            }
        }
        Ok(())
    }
}

/// The resolved path (links followed) when its folder exists, else the path as given.
fn key(p: &Path) -> PathBuf {
    aerorect::io::resolved_path(p).unwrap_or_else(|| p.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_naming_an_input_or_another_output_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let cam = dir.path().join("cam.toml");
        std::fs::write(&cam, "x").expect("write");
        let out = dir.path().join("out.tif");
        let dotted = dir.path().join(".").join("out.tif");
        let refused = |f: Files| f.check().expect_err("refused").to_string();
        let e = refused(
            Files::new()
                .input("--camera", Some(&cam))
                .output("--report", Some(&dir.path().join("./cam.toml"))),
        );
        assert!(e.contains("--report") && e.contains("--camera") && e.contains("overwrite"));
        let e = refused(
            Files::new()
                .output("OUTPUT", Some(&out))
                .output("--report", Some(&dotted)),
        );
        assert!(e.contains("OUTPUT") && e.contains("--report") && e.contains("same file"));
        let fine = Files::new()
            .input("--camera", Some(&cam))
            .input_if_file("--attitude", Some("yaw=3"))
            .output("OUTPUT", Some(&out))
            .output("--report", None);
        assert!(fine.check().is_ok());
    }
}
