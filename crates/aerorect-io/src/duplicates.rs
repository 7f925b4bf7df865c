//! One rule for a photo given twice (batch, mosaic, calibrate): two inputs are the same photo
//! when they name the same file (links resolved) or their files hold the same bytes. Files are
//! compared by length first; only files of equal length are hashed (SipHash of the whole file)
//! and, when the hashes agree, compared byte for byte, so a run of photos of distinct lengths
//! reads nothing.

use crate::error::IoError;
use crate::image_file::resolved_path;
use std::collections::HashMap;
use std::hash::Hasher;
use std::path::{Path, PathBuf};

/// How two inputs are the same photo.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sameness {
    /// Both name one file.
    SameFile,
    /// Two files with identical bytes.
    SameBytes,
}

/// The first pair of `paths` (earlier, later) that are the same photo, and how.
pub fn first_duplicate(paths: &[PathBuf]) -> Result<Option<(usize, usize, Sameness)>, IoError> {
    let mut by_path: HashMap<PathBuf, usize> = HashMap::new();
    let mut by_len: HashMap<u64, Vec<usize>> = HashMap::new();
    for (k, p) in paths.iter().enumerate() {
        let key = resolved_path(p).unwrap_or_else(|| p.clone());
        if let Some(&first) = by_path.get(&key) {
            return Ok(Some((first, k, Sameness::SameFile)));
        }
        by_path.insert(key, k);
        let meta = std::fs::metadata(p).map_err(|e| IoError::io(p, e))?;
        // Only regular files are read (a device such as /dev/zero has no end).
        if meta.is_file() {
            by_len.entry(meta.len()).or_default().push(k);
        }
    }
    let mut found: Option<(usize, usize, Sameness)> = None;
    for group in by_len.values().filter(|g| g.len() > 1) {
        if let Some((a, b)) = same_bytes_in(paths, group)?
            && found.is_none_or(|(_, fb, _)| b < fb)
        {
            found = Some((a, b, Sameness::SameBytes));
        }
    }
    Ok(found)
}

/// The first pair among `group` (files of one length) whose bytes are identical.
fn same_bytes_in(paths: &[PathBuf], group: &[usize]) -> Result<Option<(usize, usize)>, IoError> {
    let mut by_hash: HashMap<u64, Vec<usize>> = HashMap::new();
    for &k in group {
        let bytes = read_all(&paths[k])?;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        h.write(&bytes);
        let earlier = by_hash.entry(h.finish()).or_default();
        for &j in earlier.iter() {
            if read_all(&paths[j])? == bytes {
                return Ok(Some((j, k)));
            }
        }
        earlier.push(k);
    }
    Ok(None)
}

fn read_all(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|e| IoError::io(path, e))
}

/// Refuses a photo given twice (see [`first_duplicate`]): the error names both inputs.
pub fn refuse_duplicate_photos(paths: &[PathBuf]) -> Result<(), IoError> {
    let Some((a, b, how)) = first_duplicate(paths)? else {
        return Ok(());
    };
    let why = match how {
        Sameness::SameFile => "name the same file",
        Sameness::SameBytes => "hold identical bytes",
    };
    Err(IoError::field(
        paths[b].display(),
        format!(
            "{} and {} {why}: the same photo given twice would count twice; give each photo once",
            paths[a].display(),
            paths[b].display()
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_and_links_are_found_and_distinct_files_are_not() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = |n: &str| dir.path().join(n);
        std::fs::write(p("a.jpg"), b"photo one").expect("a");
        std::fs::write(p("b.jpg"), b"photo two").expect("b");
        std::fs::write(p("c.jpg"), b"photo one").expect("c");
        std::fs::write(p("d.jpg"), b"photo one!").expect("d");
        let distinct = [p("a.jpg"), p("b.jpg"), p("d.jpg")];
        assert_eq!(first_duplicate(&distinct).expect("ok"), None);
        let copy = [p("a.jpg"), p("b.jpg"), p("c.jpg")];
        assert_eq!(
            first_duplicate(&copy).expect("ok"),
            Some((0, 2, Sameness::SameBytes))
        );
        let twice = [p("b.jpg"), dir.path().join(".").join("b.jpg")];
        assert_eq!(
            first_duplicate(&twice).expect("ok"),
            Some((0, 1, Sameness::SameFile))
        );
        let e = refuse_duplicate_photos(&copy).unwrap_err().to_string();
        assert!(
            e.contains("a.jpg and") && e.contains("c.jpg hold identical bytes"),
            "{e}"
        );
    }
}
