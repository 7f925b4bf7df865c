//! Names of the temporary files of [`crate::StagedOutputs`], and the removal of those a killed
//! run left behind.
//!
//! A temporary file for the target `DIR/NAME` is `DIR/.aerorect-NAME.PID.XXXXXX.tmp` (PID the
//! writing process's id, XXXXXX random letters and digits). Before a new one is made for NAME,
//! the others for the same NAME whose process is gone are removed: a SIGKILL (which no handler
//! sees) leaves its file behind, the next run for that target cleans it. A file of a running
//! process, or of this one and still registered, is kept. Whether a process is gone is read
//! from `/proc`; where there is no `/proc`, nothing is removed.

use std::path::{Path, PathBuf};

/// The longest target name kept in a temporary file's name (bytes, cut at a character).
const NAME_BYTES: usize = 120;

/// The target's file name as it appears in its temporary files' names.
fn target_name(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".to_string());
    let mut end = name.len().min(NAME_BYTES);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    name[..end].to_string()
}

/// The prefix of this process's temporary files for `path` (tempfile adds the random part and
/// the `.tmp` suffix).
pub(crate) fn temp_prefix(path: &Path) -> String {
    format!(".aerorect-{}.{}.", target_name(path), std::process::id())
}

/// Whether the process `pid` has ended (never for a running one; `false` when unknown).
fn process_gone(pid: u32) -> bool {
    if pid == std::process::id() {
        // Ours: kept only while registered, which the caller checks.
        return true;
    }
    let proc = Path::new("/proc");
    proc.join("self").exists() && !proc.join(pid.to_string()).exists()
}

/// The writing process's id when `file` is a temporary file for the target named `name`.
fn writer_of(file: &str, name: &str) -> Option<u32> {
    let rest = file
        .strip_prefix(".aerorect-")?
        .strip_prefix(name)?
        .strip_prefix('.')?
        .strip_suffix(".tmp")?;
    let (pid, random) = rest.split_once('.')?;
    if random.is_empty() || random.contains('.') {
        // Another target whose name starts with `name.`.
        return None;
    }
    pid.parse().ok()
}

/// Removes the temporary files in `dir` for `path`'s name whose process has ended, except those
/// in `registered` (this process's own, still being written). Returns how many were removed.
///
/// A folder is listed once per process ([`temporary_files`]): a batch of a thousand frames
/// listed its output folder, thousands of files, once per output. A file a killed process
/// leaves there after that listing is removed by the next run instead.
pub(crate) fn remove_stale(dir: &Path, path: &Path, registered: &[PathBuf]) -> usize {
    let name = target_name(path);
    let Ok(mut listed) = LISTED.lock() else {
        return 0;
    };
    let files = listed
        .entry(dir.to_path_buf())
        .or_insert_with(|| temporary_files(dir));
    let mut removed = 0;
    files.retain(|file| {
        let stale = writer_of(file, &name).is_some_and(process_gone)
            && !registered.contains(&dir.join(file));
        let gone = stale && std::fs::remove_file(dir.join(file)).is_ok();
        removed += usize::from(gone);
        !gone
    });
    removed
}

/// Each folder's temporary files (of any target) when [`remove_stale`] first listed it.
static LISTED: std::sync::Mutex<std::collections::BTreeMap<PathBuf, Vec<String>>> =
    std::sync::Mutex::new(std::collections::BTreeMap::new());

/// The names in `dir` of the form of a temporary file (see the module); none when it cannot
/// be read.
fn temporary_files(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|f| f.starts_with(".aerorect-") && f.ends_with(".tmp"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_temporary_name_is_told_from_another_targets() {
        let dir = Path::new("d");
        let prefix = temp_prefix(&dir.join("out.tif"));
        let mine = format!("{prefix}Ab12Cd.tmp");
        assert_eq!(writer_of(&mine, "out.tif"), Some(std::process::id()));
        assert_eq!(
            writer_of(".aerorect-out.tif.5.7.Ab12Cd.tmp", "out.tif"),
            None
        );
        assert_eq!(
            writer_of(".aerorect-out.tif.5.7.Ab12Cd.tmp", "out.tif.5"),
            Some(7)
        );
        assert_eq!(writer_of(".aerorect-out.tif.x.Ab12Cd.tmp", "out.tif"), None);
        assert_eq!(writer_of(".aerorect-Ab12Cd.tmp", "out.tif"), None);
        assert_eq!(writer_of("out.tif", "out.tif"), None);
        let long = "é".repeat(100);
        let cut = target_name(Path::new(&long));
        assert!(cut.len() <= NAME_BYTES && long.starts_with(&cut) && !cut.is_empty());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn only_the_same_targets_files_of_ended_processes_are_removed() {
        let dir = tempfile::tempdir().expect("tempdir");
        // A process that has ended: a child that was waited for (its id is not reused so soon).
        let mut child = std::process::Command::new("true").spawn().expect("true");
        let dead = child.id();
        child.wait().expect("wait");
        let alive = 1; // init
        let target = dir.path().join("out.tif");
        let name = |pid: u32, t: &str| format!(".aerorect-{t}.{pid}.Zz9Zz9.tmp");
        let files = [
            name(dead, "out.tif"),
            name(alive, "out.tif"),
            name(dead, "other.tif"),
            name(std::process::id(), "out.tif"),
        ];
        for f in &files {
            std::fs::write(dir.path().join(f), "x").expect("write");
        }
        let registered = [dir.path().join(&files[3])];
        assert_eq!(remove_stale(dir.path(), &target, &registered), 1);
        let left: Vec<bool> = files.iter().map(|f| dir.path().join(f).exists()).collect();
        assert_eq!(left, [false, true, true, true]);
        assert_eq!(
            remove_stale(dir.path(), &target, &[]),
            1,
            "ours, unregistered"
        );
    }
}
