//! Decoded photos kept between a flight's stages (the features, each matching round's render,
//! the written frames) while they fit a memory budget: on the senseFly photos (4608 x 3456
//! JPEGs) decoding was about half of every round's render, repeated for each of up to eight
//! rounds. A kept photo is the very raster a fresh decode gives, and kept gray levels the very
//! levels a fresh render makes, so what is kept changes no result: Dask's workers, which
//! decode afresh, write the same bytes.

use crate::Error;
use aerorect_raster::{AnyRaster, ReducedLevels};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// The most bytes of decoded photos and their gray levels a flight keeps (1 GiB: the snowpeak
/// flight's 11 photos are 525 MB and their levels 233 MB, the 1,000-frame simulation's photos
/// 173 MB). Photos past it are decoded at each use, levels made at each render.
pub const DECODED_BUDGET_BYTES: usize = 1 << 30;

/// The flight's decoded photos, and the reduced levels of their gray frames that each round's
/// render reads, one slot of each a frame.
#[derive(Debug)]
pub(super) struct Decoded {
    photos: Vec<OnceLock<Arc<AnyRaster>>>,
    levels: Vec<OnceLock<Arc<ReducedLevels<f32>>>>,
    used: AtomicUsize,
    budget: usize,
}

impl Decoded {
    pub(super) fn new(frames: usize, budget: usize) -> Self {
        Self {
            photos: (0..frames).map(|_| OnceLock::new()).collect(),
            levels: (0..frames).map(|_| OnceLock::new()).collect(),
            used: AtomicUsize::new(0),
            budget,
        }
    }

    /// Frame `k`'s photo (at `path`): kept from an earlier use, else decoded, and kept when
    /// it fits the budget.
    pub(super) fn get(&self, k: usize, path: &Path) -> Result<Arc<AnyRaster>, Error> {
        let decode = || {
            Ok(super::timing::time("decode", || {
                aerorect_io::read_image(path)
            })?)
        };
        self.kept(&self.photos, k, decode, byte_len)
    }

    /// The reduced levels of frame `k`'s gray frame (`crate::motion::gray_levels` of its
    /// photo): kept from an earlier render, else made, and kept when they fit the budget.
    pub(super) fn gray_levels(
        &self,
        k: usize,
        path: &Path,
    ) -> Result<Arc<ReducedLevels<f32>>, Error> {
        let make = || {
            let image = self.get(k, path)?;
            super::timing::time("render: gray levels", || crate::motion::gray_levels(&image))
        };
        self.kept(&self.levels, k, make, ReducedLevels::byte_len)
    }

    /// Slot `k` of `slots`: its value, else `make`'s, kept when it fits the budget.
    fn kept<V>(
        &self,
        slots: &[OnceLock<Arc<V>>],
        k: usize,
        make: impl FnOnce() -> Result<V, Error>,
        bytes: impl Fn(&V) -> usize,
    ) -> Result<Arc<V>, Error> {
        let slot = slots.get(k).ok_or_else(|| {
            Error::Invalid(format!("frame {k} of a flight of {} frames", slots.len()))
        })?;
        if let Some(value) = slot.get() {
            return Ok(Arc::clone(value));
        }
        let value = Arc::new(make()?);
        let n = bytes(&value);
        let before = self.used.fetch_add(n, Ordering::Relaxed);
        if before + n > self.budget || slot.set(Arc::clone(&value)).is_err() {
            // Over the budget, or another thread kept the same value first.
            self.used.fetch_sub(n, Ordering::Relaxed);
        }
        Ok(value)
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

    /// The gray levels count against the same budget: made from the kept photo (its file
    /// gone), kept while they fit and then handed back as they are; over the budget, made
    /// again at each call.
    #[test]
    fn keeps_gray_levels_within_the_budget() {
        let dir = tempfile::tempdir().expect("dir");
        for (budget, kept) in [(64, true), (40, false)] {
            let a = png(dir.path(), &format!("{budget}.png"), 7);
            let d = Decoded::new(1, budget);
            d.get(0, &a).expect("photo");
            std::fs::remove_file(&a).expect("rm");
            let first = d.gray_levels(0, &a).expect("levels");
            // 8 x 4 -> 4 x 2 f32, the only level of so small a frame.
            assert_eq!(first.byte_len(), 32);
            assert_eq!(d.kept_bytes(), if kept { 64 } else { 32 });
            let again = d.gray_levels(0, &a).expect("levels");
            assert_eq!(Arc::ptr_eq(&first, &again), kept, "budget {budget}");
            let plan = aerorect_core::Homography::new(aerorect_core::Mat3::new(
                2.0, 0.0, 0.5, 0.0, 2.0, 0.5, 0.0, 0.0, 1.0,
            ))
            .expect("h");
            let opts = aerorect_raster::WarpOptions {
                prefilter: true,
                ..Default::default()
            };
            let size = aerorect_core::ImageSize::new(4, 2);
            let out = aerorect_raster::warp_levels(&again, &plan, size, &opts)
                .expect("warp")
                .expect("level 1");
            assert!(out.plane(0).iter().all(|&v| v == 7.0));
        }
    }
}
