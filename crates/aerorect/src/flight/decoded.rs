//! Decoded photos kept between a flight's stages (the features, each matching round's render,
//! the written frames) while they fit a memory budget: on the senseFly photos (4608 x 3456
//! JPEGs) decoding was about half of every round's render, repeated for each of up to eight
//! rounds. A kept photo is the very raster a fresh decode gives, so what is kept changes no
//! result: Dask's workers, which decode afresh, write the same bytes.

use crate::Error;
use aerorect_raster::AnyRaster;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// The most bytes of decoded photos a flight keeps (1 GiB: the snowpeak flight's 11 photos
/// are 525 MB, the 1,000-frame simulation's 173 MB). Photos past it are decoded at each use.
pub const DECODED_BUDGET_BYTES: usize = 1 << 30;

/// The flight's decoded photos, one slot a frame.
#[derive(Debug)]
pub(super) struct Decoded {
    slots: Vec<OnceLock<Arc<AnyRaster>>>,
    used: AtomicUsize,
    budget: usize,
}

impl Decoded {
    pub(super) fn new(frames: usize, budget: usize) -> Self {
        Self {
            slots: (0..frames).map(|_| OnceLock::new()).collect(),
            used: AtomicUsize::new(0),
            budget,
        }
    }

    /// Frame `k`'s photo (at `path`): kept from an earlier use, else decoded, and kept when
    /// it fits the budget.
    pub(super) fn get(&self, k: usize, path: &Path) -> Result<Arc<AnyRaster>, Error> {
        let slot = self.slots.get(k).ok_or_else(|| {
            Error::Invalid(format!(
                "frame {k} of a flight of {} frames",
                self.slots.len()
            ))
        })?;
        if let Some(image) = slot.get() {
            return Ok(Arc::clone(image));
        }
        let image = Arc::new(super::timing::time("decode", || {
            aerorect_io::read_image(path)
        })?);
        let bytes = byte_len(&image);
        let before = self.used.fetch_add(bytes, Ordering::Relaxed);
        if before + bytes > self.budget || slot.set(Arc::clone(&image)).is_err() {
            // Over the budget, or another thread kept the same photo first.
            self.used.fetch_sub(bytes, Ordering::Relaxed);
        }
        Ok(image)
    }

    /// Bytes kept.
    #[cfg(test)]
    fn kept_bytes(&self) -> usize {
        self.used.load(Ordering::Relaxed)
    }
}

fn byte_len(image: &AnyRaster) -> usize {
    image.size().pixels() * image.bands() * image.sample_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use aerorect_raster::Raster;

    fn png(dir: &Path, name: &str, value: u8) -> std::path::PathBuf {
        let size = aerorect_core::ImageSize::new(8, 4);
        let r = Raster::from_planes(size, vec![vec![value; 32]]).expect("raster");
        let p = dir.join(name);
        aerorect_io::write_image(&p, &AnyRaster::U8(r)).expect("write");
        p
    }

    #[test]
    fn keeps_photos_within_the_budget_and_gives_the_decoded_pixels() {
        let dir = tempfile::tempdir().expect("dir");
        let (a, b) = (png(dir.path(), "a.png", 7), png(dir.path(), "b.png", 9));
        // Room for one 32-byte photo.
        let d = Decoded::new(2, 40);
        let first = d.get(0, &a).expect("a");
        assert_eq!(d.kept_bytes(), 32);
        let other = d.get(1, &b).expect("b");
        assert_eq!(d.kept_bytes(), 32, "b is over the budget");
        // Once removed, a kept photo still comes back; one that was not kept cannot be read.
        std::fs::remove_file(&a).expect("rm");
        std::fs::remove_file(&b).expect("rm");
        assert!(Arc::ptr_eq(&first, &d.get(0, &a).expect("kept")));
        assert!(d.get(1, &b).is_err());
        let AnyRaster::U8(r) = other.as_ref() else {
            panic!("u8")
        };
        assert!(r.plane(0).iter().all(|&v| v == 9));
        assert!(d.get(2, &a).is_err());
    }
}
