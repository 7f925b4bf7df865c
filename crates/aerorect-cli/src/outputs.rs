//! What a command reads and writes, checked in one place before any work: no output may name
//! an input (the camera file, the points, the image, the DEM, ...) or another output, and
//! every output can be written: its folder exists (or is one the command creates), is a
//! folder and can be written in, and the output itself is not a folder.

use anyhow::{Result, bail};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// A command's files, each with the flag (or argument name) that gave it.
#[derive(Default)]
pub(crate) struct Files {
    inputs: Vec<(String, PathBuf)>,
    outputs: Vec<(String, PathBuf)>,
    /// Folders the command creates when missing and writes outputs into.
    folders: Vec<(String, PathBuf)>,
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

    /// Every path of a list argument.
    pub(crate) fn inputs(self, flag: &str, paths: &[PathBuf]) -> Self {
        paths.iter().fold(self, |f, p| f.input(flag, Some(p)))
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

    /// A folder the command creates (with its parents) when missing, and writes into.
    pub(crate) fn folder(mut self, flag: &str, path: Option<&Path>) -> Self {
        if let Some(p) = path {
            self.folders.push((flag.to_string(), p.to_path_buf()));
        }
        self
    }

    /// Refuses an output that names an input or another output, or that cannot be written
    /// (see [`Files::check_writable`]).
    pub(crate) fn check(&self) -> Result<()> {
        self.check_distinct()?;
        self.check_writable()
    }

    /// Refuses an output that is a folder, whose folder is missing (and is not made by the
    /// command), is not a folder, or cannot be written in; and a folder of the command that
    /// is not one or cannot be made. Each folder is tried once, by making and removing a
    /// temporary file in it.
    fn check_writable(&self) -> Result<()> {
        let mut tried = HashSet::new();
        for (flag, dir) in &self.folders {
            if dir.exists() && !dir.is_dir() {
                bail!(
                    "{flag} {}: exists and is not a folder; nothing written",
                    dir.display()
                );
            }
            let existing = dir
                .ancestors()
                .find(|a| a.exists())
                .unwrap_or(Path::new("."));
            let existing = if existing.as_os_str().is_empty() {
                Path::new(".")
            } else {
                existing
            };
            if !existing.is_dir() {
                bail!(
                    "{flag} {}: cannot be made: {} is not a folder; nothing written",
                    dir.display(),
                    existing.display()
                );
            }
            try_writing(flag, dir, existing, &mut tried)?;
        }
        for (flag, p) in &self.outputs {
            self.check_output(flag, p, &mut tried)?;
        }
        Ok(())
    }

    fn check_output(&self, flag: &str, p: &Path, tried: &mut HashSet<PathBuf>) -> Result<()> {
        let shown = p.display();
        if p.is_dir() {
            bail!("{flag} {shown}: is a folder, not a file; nothing written");
        }
        // A device or FIFO is not staged beside: its folder need not be writable.
        if p.exists() && !p.is_file() {
            return Ok(());
        }
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !parent.exists() {
            if self.folders.iter().any(|(_, f)| parent.starts_with(f)) {
                return Ok(());
            }
            bail!(
                "{flag} {shown}: the folder {} does not exist; nothing written",
                parent.display()
            );
        }
        if !parent.is_dir() {
            bail!(
                "{flag} {shown}: {} is not a folder; nothing written",
                parent.display()
            );
        }
        try_writing(flag, p, parent, tried)
    }

    /// Refuses an output that names an input or another output.
    fn check_distinct(&self) -> Result<()> {
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

/// Makes and removes a temporary file in `dir` (once per folder), refusing `target` of
/// `flag` when that fails.
fn try_writing(flag: &str, target: &Path, dir: &Path, tried: &mut HashSet<PathBuf>) -> Result<()> {
    if !tried.insert(key(dir)) {
        return Ok(());
    }
    let probe = tempfile::Builder::new()
        .prefix(".aerorect-probe-")
        .tempfile_in(dir);
    match probe {
        Ok(f) => {
            let _ = f.close();
            Ok(())
        }
        Err(e) => {
            // The OS error alone: tempfile's own message names its temporary file.
            let why = e.raw_os_error().map_or(e.to_string(), |c| {
                std::io::Error::from_raw_os_error(c).to_string()
            });
            bail!(
                "{flag} {}: cannot write in the folder {}: {why}; nothing written",
                target.display(),
                dir.display()
            )
        }
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

    #[test]
    fn an_output_that_cannot_be_written_is_refused_naming_it() {
        let dir = tempfile::tempdir().expect("tempdir");
        let d = dir.path();
        let file = d.join("plain.txt");
        std::fs::write(&file, "x").expect("write");
        let refused = |f: Files| f.check().expect_err("refused").to_string();
        let e = refused(Files::new().output("--report", Some(d)));
        assert!(e.contains("--report") && e.contains("is a folder"), "{e}");
        let missing = d.join("no/r.json");
        let e = refused(Files::new().output("--json", Some(&missing)));
        assert!(e.contains("--json") && e.contains("does not exist"), "{e}");
        let e = refused(Files::new().output("OUTPUT", Some(&file.join("o.tif"))));
        assert!(e.contains("plain.txt is not a folder"), "{e}");
        let e = refused(Files::new().folder("--out-dir", Some(&file)));
        assert!(e.contains("--out-dir") && e.contains("not a folder"), "{e}");
        let e = refused(Files::new().folder("--out-dir", Some(&file.join("sub"))));
        assert!(e.contains("cannot be made"), "{e}");
        // Outputs inside a folder the command makes are fine; nothing is left behind.
        let made = d.join("out/deeper");
        let fine = Files::new()
            .folder("--out-dir", Some(&made))
            .output("--out-dir", Some(&made.join("a.tif")))
            .output("--report", Some(&d.join("r.json")));
        assert!(fine.check().is_ok());
        let left: Vec<_> = std::fs::read_dir(d).expect("read_dir").collect();
        assert_eq!(left.len(), 1, "{left:?}");
    }
}
