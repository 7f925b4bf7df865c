//! Outputs that land together: each is written to a temporary file beside its target
//! (`.aerorect-*.tmp`) and [`StagedOutputs::commit`] renames them all; a set that is dropped
//! uncommitted removes its temporary files. Every temporary file is also listed in one
//! process-wide register, so a signal handler can remove them with [`remove_pending`] before
//! the process exits.
//!
//! A target that exists and is not a regular file is never replaced: a FIFO or a character
//! device (`/dev/null`, `/dev/stdout` through its link) is staged in the system's temporary
//! folder and copied into the target, opened for writing without a rename, at commit (after the
//! regular files were renamed; opening a FIFO waits for its reader). A directory, a block device
//! or a socket is refused before anything is written.

use crate::{IoError, temp_names};
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
    /// The target is a FIFO or a character device: copied into, never renamed over.
    in_place: bool,
}

impl Drop for StagedFile {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            discard(tmp);
        }
    }
}

/// Unregisters and removes a temporary file, while the register is held so that a signal
/// cannot leave it behind.
fn discard(tmp: NamedTempFile) {
    let mut register = pending();
    register.retain(|p| p != tmp.path());
    let _ = tmp.close();
}

/// How an output reaches its target.
enum Landing {
    /// A regular file, or none yet: renamed over.
    Rename,
    /// A FIFO or a character device: written in place.
    InPlace,
}

/// How `path` is written, or an error when it exists and is neither a regular file, a FIFO nor
/// a character device.
fn landing(path: &Path) -> Result<Landing, IoError> {
    let Ok(meta) = std::fs::metadata(path) else {
        return Ok(Landing::Rename);
    };
    let kind = meta.file_type();
    if kind.is_file() {
        return Ok(Landing::Rename);
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() || kind.is_char_device() {
            return Ok(Landing::InPlace);
        }
    }
    let what = if kind.is_dir() {
        "a directory"
    } else {
        special_kind(&kind)
    };
    Err(IoError::field(
        path.display(),
        format!(
            "is {what}: an output is written to a regular file, a FIFO or a character device, never over anything else; nothing written"
        ),
    ))
}

#[cfg(unix)]
fn special_kind(kind: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if kind.is_block_device() {
        "a block device"
    } else if kind.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "not a regular file"
}

/// A temporary file beside `path` (in the system's temporary folder when `path` is written in
/// place), made and registered under the register's lock.
fn temp_beside(path: &Path, in_place: bool) -> Result<NamedTempFile, IoError> {
    let system = std::env::temp_dir();
    let dir = match path.parent() {
        _ if in_place => system.as_path(),
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let prefix = temp_names::temp_prefix(path);
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // Outputs are ordinary files (rw-r--r-- before the umask), not tempfile's private 0600.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut register = pending();
    if !in_place {
        temp_names::remove_stale(dir, path, &register);
    }
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
        let in_place = matches!(landing(path)?, Landing::InPlace);
        let mut staged = StagedFile {
            tmp: Some(temp_beside(path, in_place)?),
            path: path.to_path_buf(),
            in_place,
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
        self.bytes(path, text.as_bytes())
    }

    /// Stages a file of these bytes (an encoded image, say).
    pub fn bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<(), IoError> {
        self.file(path, |w| {
            w.write_all(bytes).map_err(|e| IoError::io(path, e))
        })
    }

    /// Takes over `other`'s staged files, after this one's: outputs staged apart (one per
    /// frame, frames in parallel) land together.
    pub fn append(&mut self, other: StagedOutputs) {
        let mut other = other;
        self.files.append(&mut other.files);
    }

    /// The targets staged so far, in order.
    pub fn targets(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|f| f.path.as_path())
    }

    /// Renames every staged file into place, then copies those written in place (FIFOs,
    /// character devices) into their targets. When a rename or a copy fails, the files already
    /// renamed are removed (a file they replaced is not brought back) and the rest are
    /// discarded; a device already written to stays written.
    pub fn commit(mut self) -> Result<(), IoError> {
        let mut landed: Vec<PathBuf> = Vec::new();
        let result = self
            .rename_regular(&mut landed)
            .and_then(|()| self.copy_in_place());
        if result.is_err() {
            for p in &landed {
                let _ = std::fs::remove_file(p);
            }
        }
        // The remaining files unregister themselves on drop.
        result
    }

    /// Renames the regular outputs, under the register's lock (a signal handler waits).
    fn rename_regular(&mut self, landed: &mut Vec<PathBuf>) -> Result<(), IoError> {
        let mut register = pending();
        for f in self.files.iter_mut().filter(|f| !f.in_place) {
            let Some(tmp) = f.tmp.take() else { continue };
            let tmp_path = tmp.path().to_path_buf();
            match tmp.persist(&f.path) {
                Ok(_) => {
                    register.retain(|p| *p != tmp_path);
                    landed.push(f.path.clone());
                }
                Err(e) => {
                    f.tmp = Some(e.file);
                    return Err(IoError::io(&f.path, e.error));
                }
            }
        }
        Ok(())
    }

    /// Copies each in-place output into its target, without the register's lock: opening a
    /// FIFO waits for a reader, and a signal meanwhile must still remove the temporary files.
    fn copy_in_place(&mut self) -> Result<(), IoError> {
        use std::io::{Seek, SeekFrom};
        for f in self.files.iter_mut().filter(|f| f.in_place) {
            let Some(tmp) = f.tmp.as_mut() else { continue };
            let path = f.path.as_path();
            let mut target = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .map_err(|e| IoError::io(path, e))?;
            let staged = tmp.as_file_mut();
            staged
                .seek(SeekFrom::Start(0))
                .and_then(|_| std::io::copy(staged, &mut target))
                .map_err(|e| IoError::io(path, e))?;
            if let Some(t) = f.tmp.take() {
                discard(t);
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

    /// Files staged apart and appended land with the rest at the commit; those of a stage
    /// dropped instead (a frame that failed) never land and leave no temporary file.
    #[test]
    fn appended_stages_land_together_and_dropped_ones_leave_nothing() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = |n: &str| dir.path().join(n);
        let mut all = StagedOutputs::new();
        all.text(&path("a.txt"), "A").expect("a");
        let mut own = StagedOutputs::new();
        own.text(&path("b.txt"), "B").expect("b");
        let mut failed = StagedOutputs::new();
        failed.text(&path("c.txt"), "C").expect("c");
        all.append(own);
        drop(failed);
        assert_eq!(names(dir.path()).len(), 2, "a's and b's temporary files");
        assert_eq!(all.targets().count(), 2);
        all.commit().expect("commit");
        assert_eq!(names(dir.path()), ["a.txt", "b.txt"]);
        assert_eq!(std::fs::read_to_string(path("b.txt")).expect("b"), "B");
    }

    #[cfg(unix)]
    #[test]
    fn a_device_is_written_in_place_and_a_directory_is_refused() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().expect("tempdir");
        let null = Path::new("/dev/null");
        if std::fs::metadata(null).is_ok_and(|m| m.file_type().is_char_device()) {
            let mut s = StagedOutputs::new();
            s.text(&dir.path().join("a.txt"), "A").expect("a");
            s.text(null, "to the device").expect("null");
            s.commit().expect("commit");
            assert!(
                std::fs::metadata(null)
                    .expect("null")
                    .file_type()
                    .is_char_device()
            );
            assert_eq!(names(dir.path()), ["a.txt"]);
        }
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).expect("mkdir");
        let e = StagedOutputs::new()
            .text(&sub, "B")
            .expect_err("a directory");
        assert!(e.to_string().contains("is a directory"), "{e}");
        assert_eq!(names(dir.path()), ["a.txt", "sub"]);
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
