//! The limits every image reader checks before it allocates: the most decoded bytes a file
//! may claim (absolute, and relative to its length) and the most pixels of one image.

use crate::error::IoError;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// The largest image we decode, in bytes of samples (guards against memory bombs): 4 GiB.
pub const MAX_DECODED_BYTES: u64 = 4 << 30;

/// No codec we read expands its data much more than a thousand times (Deflate at most 1032:1,
/// LZW about 2700:1, baseline JPEG a few hundred), so this many decoded bytes per file byte is
/// out of reach of a real file.
const MAX_EXPANSION: u64 = 4096;

/// The most a file of `file_len` bytes may decode to: the decoders allocate the whole image
/// before reading its data, so a 3 KB PNG or TIFF whose header claims 30000 x 30000 pixels
/// (under the 4 GiB limit) took up to 3 GB before failing (found by tests/fuzz.rs). Files
/// under 64 KiB may claim up to 256 MiB, so no small real image is refused by this.
pub(crate) fn most_decoded_bytes(file_len: u64) -> u64 {
    file_len
        .saturating_mul(MAX_EXPANSION)
        .clamp(256 << 20, MAX_DECODED_BYTES)
}

/// The default of [`max_image_pixels`]: 500 million pixels (a 150 MP aerial frame three times
/// over; a 30000 x 30000 image is refused). The commands then hold the image and a float copy
/// or two of it (gray f32, pyramids), which for 900 Mpx aborted the process for want of memory.
pub const DEFAULT_MAX_IMAGE_PIXELS: u64 = 500_000_000;

static MAX_IMAGE_PIXELS: AtomicU64 = AtomicU64::new(DEFAULT_MAX_IMAGE_PIXELS);

/// The most pixels every image reader (images, DEMs, every command's frames) decodes, checked
/// against the header before anything is allocated.
pub fn max_image_pixels() -> u64 {
    MAX_IMAGE_PIXELS.load(Ordering::Relaxed)
}

/// Sets [`max_image_pixels`] for the whole process (at least one pixel).
pub fn set_max_image_pixels(pixels: u64) {
    MAX_IMAGE_PIXELS.store(pixels.max(1), Ordering::Relaxed);
}

/// The error for an image of `w` x `h` pixels over [`max_image_pixels`], naming the file.
pub(crate) fn check_image_pixels(path: &Path, w: u64, h: u64) -> Result<(), IoError> {
    let most = max_image_pixels();
    let pixels = w.saturating_mul(h);
    if pixels > most {
        return Err(IoError::decode(
            path,
            format!(
                "the image is {w} x {h} = {pixels} pixels, over the limit of {most} pixels for one decoded image"
            ),
        ));
    }
    Ok(())
}

/// The error for a header claiming `claimed` decoded bytes, more than the file can hold.
pub(crate) fn check_claimed_bytes(path: &Path, what: &str, claimed: u64) -> Result<(), IoError> {
    let file_len = std::fs::metadata(path)
        .map_err(|e| IoError::io(path, e))?
        .len();
    let most = most_decoded_bytes(file_len);
    if claimed > most {
        return Err(IoError::decode(
            path,
            format!(
                "the header claims {what} ({claimed} bytes decoded), more than a file of {file_len} bytes can hold (at most {most} bytes are decoded from it)"
            ),
        ));
    }
    Ok(())
}
