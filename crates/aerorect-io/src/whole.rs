//! Whether an image file already on disk is whole, without decoding its pixels: its header and
//! directories decode and every block of data they point to lies inside the file. `batch`
//! skips an existing output only when it is whole.

use crate::error::IoError;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use tiff::tags::Tag;

/// PNG's last chunk: IEND, empty, with its CRC.
const PNG_END: [u8; 12] = [0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82];

/// Checks that `path` is a whole TIFF (every IFD, each strip or tile inside the file), PNG
/// (signature, header, IEND last) or JPEG (SOI first, an end-of-image marker near the end).
pub fn check_image_whole(path: &Path) -> Result<(), IoError> {
    let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let len = f.metadata().map_err(|e| IoError::io(path, e))?.len();
    let mut magic = [0u8; 8];
    let n = f.read(&mut magic).map_err(|e| IoError::io(path, e))?;
    let magic = &magic[..n];
    if [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"]
        .iter()
        .any(|m| magic.starts_with(*m))
    {
        f.rewind().map_err(|e| IoError::io(path, e))?;
        return check_tiff(path, f, len);
    }
    let tail = tail_bytes(&mut f, len, 1024).map_err(|e| IoError::io(path, e))?;
    if magic.starts_with(b"\x89PNG\r\n\x1a\n") {
        if !tail.ends_with(&PNG_END) {
            return Err(IoError::decode(
                path,
                "truncated PNG: it does not end with IEND",
            ));
        }
        return crate::image_file::check_header(path);
    }
    if magic.starts_with(&[0xFF, 0xD8]) {
        if !tail.windows(2).any(|w| w == [0xFF, 0xD9]) {
            return Err(IoError::decode(
                path,
                "truncated JPEG: no end-of-image marker",
            ));
        }
        return crate::image_file::check_header(path);
    }
    Err(IoError::decode(path, "not a PNG, JPEG or TIFF file"))
}

fn tail_bytes(f: &mut std::fs::File, len: u64, most: u64) -> std::io::Result<Vec<u8>> {
    let n = len.min(most);
    f.seek(SeekFrom::Start(len - n))?;
    let mut tail = vec![0u8; n as usize];
    f.read_exact(&mut tail)?;
    Ok(tail)
}

/// Every image of the TIFF (overviews too): its strips or tiles end inside the file.
fn check_tiff(path: &Path, f: std::fs::File, len: u64) -> Result<(), IoError> {
    let bad = |e: tiff::TiffError| IoError::decode(path, e);
    let mut dec = tiff::decoder::Decoder::new(std::io::BufReader::new(f)).map_err(bad)?;
    for image in 0.. {
        dec.dimensions().map_err(bad)?;
        let (offsets, counts) = match dec.find_tag(Tag::TileOffsets).map_err(bad)? {
            Some(_) => (Tag::TileOffsets, Tag::TileByteCounts),
            None => (Tag::StripOffsets, Tag::StripByteCounts),
        };
        let starts = dec.get_tag_u64_vec(offsets).map_err(bad)?;
        let sizes = dec.get_tag_u64_vec(counts).map_err(bad)?;
        let end = starts
            .iter()
            .zip(&sizes)
            .map(|(s, n)| s.saturating_add(*n))
            .max()
            .unwrap_or(0);
        if starts.len() != sizes.len() || end > len {
            return Err(IoError::decode(
                path,
                format!(
                    "truncated TIFF: image {image}'s data ends at byte {end}, the file has {len}"
                ),
            ));
        }
        if !dec.more_images() {
            break;
        }
        dec.next_image().map_err(bad)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use aerorect_core::ImageSize;
    use aerorect_raster::{AnyRaster, Raster};

    #[test]
    fn a_written_image_is_whole_and_any_cut_of_it_is_not() {
        let dir = tempfile::tempdir().expect("tempdir");
        let size = ImageSize::new(40, 30);
        let data: Vec<u8> = (0..size.pixels()).map(|i| (i * 7 % 251) as u8).collect();
        let img = AnyRaster::U8(Raster::from_planes(size, vec![data]).expect("raster"));
        for name in ["a.tif", "a.png"] {
            let p = dir.path().join(name);
            crate::write_image(&p, &img).expect("write");
            check_image_whole(&p).expect("whole");
            let bytes = std::fs::read(&p).expect("read");
            for keep in [bytes.len() - 1, bytes.len() * 2 / 3, 9] {
                std::fs::write(&p, &bytes[..keep]).expect("cut");
                let e = check_image_whole(&p).expect_err("cut file");
                assert!(e.to_string().contains(name), "{e}");
            }
        }
    }
}
