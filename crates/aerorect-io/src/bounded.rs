//! Bounded reading of text inputs (camera files in every format, attitude files, CSV tables,
//! `.prj` files): a text input larger than [`MAX_TEXT_BYTES`] is refused with an error naming
//! the file and the cap, so `/dev/zero` or `/dev/urandom` given as a camera file ends at once
//! instead of reading forever.

use crate::error::IoError;
use std::io::Read;
use std::path::Path;

/// The most bytes a text input may hold: 16 MiB (a camera, pose or check-point file of a
/// real project is kilobytes; a flight's pose table of 100 000 frames about 10 MB).
pub const MAX_TEXT_BYTES: u64 = 16 << 20;

/// The message for a text input over the cap.
fn too_large() -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!(
            "larger than {} MiB, the most a text input may hold (reading stopped there)",
            MAX_TEXT_BYTES >> 20
        ),
    )
}

/// A reader that fails once more than `cap` bytes have been read from `inner`.
pub struct Capped<R> {
    inner: R,
    left: u64,
}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // One byte past the cap is read to tell "exactly at the cap" from "over it".
        let want = buf
            .len()
            .min(usize::try_from(self.left + 1).unwrap_or(usize::MAX));
        let n = self.inner.read(&mut buf[..want])?;
        if n as u64 > self.left {
            return Err(too_large());
        }
        self.left -= n as u64;
        Ok(n)
    }
}

/// `path` opened for reading through a [`MAX_TEXT_BYTES`] cap.
pub fn capped_reader(path: &Path) -> Result<Capped<std::fs::File>, IoError> {
    let inner = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    Ok(Capped {
        inner,
        left: MAX_TEXT_BYTES,
    })
}

/// The text of `path` (UTF-8, at most [`MAX_TEXT_BYTES`]); errors name the file.
pub fn read_text(path: &Path) -> Result<String, IoError> {
    let mut bytes = Vec::new();
    capped_reader(path)?
        .read_to_end(&mut bytes)
        .map_err(|e| IoError::io(path, e))?;
    String::from_utf8(bytes).map_err(|_| {
        IoError::io(
            path,
            std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                "stream did not contain valid UTF-8",
            ),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_text_at_the_cap_reads_and_one_byte_more_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let at = dir.path().join("at.txt");
        std::fs::write(&at, vec![b'a'; MAX_TEXT_BYTES as usize]).expect("write");
        assert_eq!(
            read_text(&at).expect("at the cap").len() as u64,
            MAX_TEXT_BYTES
        );
        let over = dir.path().join("over.txt");
        std::fs::write(&over, vec![b'a'; MAX_TEXT_BYTES as usize + 1]).expect("write");
        let e = read_text(&over).unwrap_err().to_string();
        assert!(e.contains("over.txt") && e.contains("16 MiB"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn an_endless_device_stops_at_the_cap() {
        let e = read_text(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("/dev/zero") && e.contains("16 MiB"), "{e}");
    }
}
