//! Outputs that land together: each is written to a temporary file beside its target
//! (`.aerorect-*.tmp`) and [`StagedOutputs::commit`] renames them all; a set that is dropped
//! uncommitted removes its temporary files. Every temporary file is also listed in one
//! process-wide register, so a signal handler can remove them with [`remove_pending`] before
//! the process exits.

use crate::IoError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};
use tempfile::NamedTempFile;

/// Temporary files made and not yet renamed or removed.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn pending() -> MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The register, locked after [`remove_pending`] emptied it: while it is held no temporary
/// file is made or renamed, so hold it until the process exits.
pub struct Abandoned {
    _register: MutexGuard<'static, Vec<PathBuf>>,
    /// How many temporary files were removed.
    pub removed: usize,
}

/// Removes every temporary file not yet renamed (for a signal handler, just before exit) and
/// keeps the register locked: a set being committed either landed before or never lands.
pub fn remove_pending() -> Abandoned {
    let mut register = pending();
    let removed = register
        .drain(..)
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count();
    Abandoned {
        _register: register,
        removed,
    }
}

/// One output written to its temporary file, not yet renamed.
struct StagedFile {
    tmp: Option<NamedTempFile>,
    path: PathBuf,
}

impl Drop for StagedFile {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let mut register = pending();
            register.retain(|p| p != tmp.path());
            // Removed while the register is held, so a signal cannot leave it behind.
            let _ = tmp.close();
        }
    }
}

/// A temporary file beside `path`, made and registered under the register's lock.
fn temp_beside(path: &Path) -> Result<NamedTempFile, IoError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".aerorect-").suffix(".tmp");
    // Outputs are ordinary files (rw-r--r-- before the umask), not tempfile's private 0600.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut register = pending();
    let tmp = builder.tempfile_in(dir).map_err(|e| IoError::io(path, e))?;
    register.push(tmp.path().to_path_buf());
    Ok(tmp)
}

/// Outputs of one command: written one by one to temporary files, renamed together.
#[derive(Default)]
pub struct StagedOutputs {
    files: Vec<StagedFile>,
}

impl StagedOutputs {
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes `path`'s content through `write` into a temporary file beside it. On error the
    /// temporary file is removed (the files staged before stay staged).
    pub fn file(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut BufWriter<&mut File>) -> Result<(), IoError>,
    ) -> Result<(), IoError> {
        let mut staged = StagedFile {
            tmp: Some(temp_beside(path)?),
            path: path.to_path_buf(),
        };
        if let Some(tmp) = staged.tmp.as_mut() {
            let mut w = BufWriter::new(tmp.as_file_mut());
            write(&mut w)?;
            w.flush().map_err(|e| IoError::io(path, e))?;
        }
        self.files.push(staged);
        Ok(())
    }

    /// Stages a text file.
    pub fn text(&mut self, path: &Path, text: &str) -> Result<(), IoError> {
        self.file(path, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| IoError::io(path, e))
        })
    }

    /// The targets staged so far, in order.
    pub fn targets(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|f| f.path.as_path())
    }

    /// Renames every staged file into place. When a rename fails, the files already renamed
    /// are removed (a file they replaced is not brought back) and the rest are discarded.
    pub fn commit(mut self) -> Result<(), IoError> {
        let mut register = pending();
        let mut landed: Vec<PathBuf> = Vec::new();
        for f in &mut self.files {
            let Some(tmp) = f.tmp.take() else { continue };
            let tmp_path = tmp.path().to_path_buf();
            match tmp.persist(&f.path) {
                Ok(_) => {
                    register.retain(|p| *p != tmp_path);
                    landed.push(f.path.clone());
                }
                Err(e) => {
                    f.tmp = Some(e.file);
                    for p in &landed {
                        let _ = std::fs::remove_file(p);
                    }
                    // The remaining files unregister themselves on drop.
                    drop(register);
                    return Err(IoError::io(&f.path, e.error));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .expect("read_dir")
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn nothing_lands_before_commit_and_all_land_after() {
        let dir = tempfile::tempdir().expect("tempdir");
        let (a, b) = (dir.path().join("a.txt"), dir.path().join("b.txt"));
        let mut s = StagedOutputs::new();
        s.text(&a, "A").expect("a");
        s.text(&b, "B").expect("b");
        assert!(!a.exists() && !b.exists());
        s.commit().expect("commit");
        assert_eq!(names(dir.path()), ["a.txt", "b.txt"]);
        assert_eq!(std::fs::read_to_string(&b).expect("b"), "B");
    }

    #[test]
    fn a_failed_write_or_a_drop_leaves_nothing() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut s = StagedOutputs::new();
        s.text(&dir.path().join("a.txt"), "A").expect("a");
        let missing = dir.path().join("no/such/folder/b.txt");
        assert!(s.text(&missing, "B").is_err());
        drop(s);
        assert!(names(dir.path()).is_empty());
    }

    #[test]
    fn temporary_files_are_registered_until_renamed_or_dropped() {
        // (remove_pending itself would remove other tests' files: the CLI signal test runs it.)
        let dir = tempfile::tempdir().expect("tempdir");
        let mut s = StagedOutputs::new();
        s.text(&dir.path().join("a.txt"), "A").expect("a");
        let tmp = dir.path().join(&names(dir.path())[0]);
        assert!(pending().contains(&tmp));
        s.commit().expect("commit");
        assert!(!pending().contains(&tmp));
        let mut s = StagedOutputs::new();
        s.text(&dir.path().join("b.txt"), "B").expect("b");
        let tmp = dir.path().join(names(dir.path()).remove(0));
        assert!(tmp.to_string_lossy().ends_with(".tmp") && pending().contains(&tmp));
        drop(s);
        assert!(!pending().contains(&tmp) && !tmp.exists());
    }
}
