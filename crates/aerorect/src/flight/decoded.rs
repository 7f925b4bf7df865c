//! Decoded photos kept between a flight's stages (the features, each matching round's render,
//! the written frames) while they fit a memory budget ([`crate::memory::cache_budget_bytes`]):
//! on the senseFly photos (4608 x 3456 JPEGs) decoding was about half of every round's render,
//! repeated for each of up to eight rounds. A kept photo is the very raster a fresh decode
//! gives, and kept gray levels the very levels a fresh render makes, so what is kept changes
//! no result: Dask's workers, which decode afresh, write the same bytes.

use crate::Error;
use aerorect_raster::{AnyRaster, ReducedLevels};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// The flight's decoded photos, and the reduced levels of their gray frames that each round's
/// render reads, one slot of each a frame.
///
/// Levels come first: every round's render reads a frame's levels, a photo is read twice (by
/// the features and by the written frames), and levels are under half a photo's bytes (a
/// gray f32 quarter and its reductions against RGB u8). Photos are kept only within the
/// budget less every frame's levels: with the budget first come first served, 22 of 167
/// photos of 16 Mpx filled 1 GiB in the features round and every later round decoded the
/// other 145 again.
#[derive(Debug)]
pub(super) struct Decoded {
    photos: Vec<OnceLock<Arc<AnyRaster>>>,
    levels: Vec<OnceLock<Arc<ReducedLevels<f32>>>>,
    used: AtomicUsize,
    budget: usize,
    /// Bytes of kept photos (counted in `used` too), and the most they may take.
    photos_used: AtomicUsize,
    photo_budget: usize,
    /// Each frame's gray levels' bytes.
    level_bytes: Vec<usize>,
}

impl Decoded {
    /// Slots for frames whose levels will take `level_bytes` each, within `budget`.
    pub(super) fn new(level_bytes: &[usize], budget: usize) -> Self {
        let levels: usize = level_bytes.iter().sum();
        Self {
            photos: level_bytes.iter().map(|_| OnceLock::new()).collect(),
            levels: level_bytes.iter().map(|_| OnceLock::new()).collect(),
            used: AtomicUsize::new(0),
            budget,
            photos_used: AtomicUsize::new(0),
            photo_budget: budget.saturating_sub(levels),
            level_bytes: level_bytes.to_vec(),
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
        self.kept((&self.photos, true), k, decode, byte_len)
    }

    /// The reduced levels of frame `k`'s gray frame (`crate::motion::gray_levels` of its
    /// photo): kept from an earlier render, else made, and kept when they fit the budget and
    /// `keep` asks for it. Keeping costs their memory's first touch (36 frames of 11 Mpx on
    /// this machine: 0.36 s of CPU making them kept, 0.21 s not), for nothing where no round
    /// follows.
    pub(super) fn gray_levels(
        &self,
        (k, path): (usize, &Path),
        keep: bool,
    ) -> Result<Arc<ReducedLevels<f32>>, Error> {
        let make = || levels_of(self.get(k, path)?.as_ref());
        match (keep, self.levels.get(k).and_then(|slot| slot.get())) {
            (false, Some(kept)) => Ok(Arc::clone(kept)),
            (false, None) => Ok(Arc::new(make()?)),
            (true, _) => self.kept((&self.levels, false), k, make, ReducedLevels::byte_len),
        }
    }

    /// The same photos without their gray levels, once the rounds that read them are done:
    /// their bytes (3.5 GB for 167 photos of 16 Mpx) are freed for the frames written and
    /// mosaicked. As it is where another holder shares it.
    pub(super) fn without_levels(mut self: Arc<Self>) -> Arc<Self> {
        if let Some(d) = Arc::get_mut(&mut self) {
            let freed: usize = (d.levels.iter_mut())
                .filter_map(|slot| slot.take())
                .map(|levels| levels.byte_len())
                .sum();
            let used = d.used.get_mut();
            *used = used.saturating_sub(freed);
        }
        self
    }

    /// Frame `k`'s photo for a use that decodes it anyway (the features). A photo not kept
    /// has its gray levels made from it now where they fit, so that no round's render decodes
    /// it again (making them is about a tenth of a decode: 12 against 116 ms for a 16-Mpx
    /// JPEG).
    pub(super) fn get_with_levels(&self, k: usize, path: &Path) -> Result<Arc<AnyRaster>, Error> {
        let image = self.get(k, path)?;
        let photo_kept = self.photos.get(k).is_some_and(|s| s.get().is_some());
        let levels_kept = self.levels.get(k).is_some_and(|s| s.get().is_some());
        let fits = self
            .level_bytes
            .get(k)
            .is_some_and(|&n| self.used.load(Ordering::Relaxed).saturating_add(n) <= self.budget);
        if !photo_kept && !levels_kept && fits {
            self.kept(
                (&self.levels, false),
                k,
                || levels_of(&image),
                ReducedLevels::byte_len,
            )?;
        }
        Ok(image)
    }

    /// Slot `k` of `slots`: its value, else `make`'s, kept when it fits the budget (and, for
    /// `photo` slots, the photos' share of it).
    fn kept<V>(
        &self,
        (slots, photo): (&[OnceLock<Arc<V>>], bool),
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
        let photos_before = match photo {
            true => self.photos_used.fetch_add(n, Ordering::Relaxed),
            false => 0,
        };
        let over = before + n > self.budget || (photo && photos_before + n > self.photo_budget);
        if over || slot.set(Arc::clone(&value)).is_err() {
            // Over the budget, or another thread kept the same value first.
            self.used.fetch_sub(n, Ordering::Relaxed);
            if photo {
                self.photos_used.fetch_sub(n, Ordering::Relaxed);
            }
        }
        Ok(value)
    }

    /// Bytes kept.
    #[cfg(test)]
    fn kept_bytes(&self) -> usize {
        self.used.load(Ordering::Relaxed)
    }
}

/// The reduced levels of a photo's gray frame, timed as the render's.
fn levels_of(image: &AnyRaster) -> Result<ReducedLevels<f32>, Error> {
    super::timing::time("render: gray levels", || crate::motion::gray_levels(image))
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
        // Two frames whose levels take 32 bytes each: room for one 32-byte photo beside them.
        let d = Decoded::new(&[32, 32], 104);
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

    /// The gray levels come first: a photo is kept only where every frame's levels still fit
    /// beside it, levels wherever they fit. Kept levels are handed back as they are (their
    /// photo's file gone), levels over the budget made again at each call.
    #[test]
    fn keeps_gray_levels_before_photos() {
        let dir = tempfile::tempdir().expect("dir");
        // (budget, photo kept, levels kept): the 8 x 4 photo's levels take 32 bytes.
        for (budget, photo, levels) in [(64, true, true), (63, false, true), (31, false, false)] {
            let a = png(dir.path(), &format!("{budget}.png"), 7);
            let d = Decoded::new(&[32], budget);
            d.get(0, &a).expect("photo");
            assert_eq!(
                d.kept_bytes(),
                if photo { 32 } else { 0 },
                "budget {budget}"
            );
            let first = d.gray_levels((0, &a), true).expect("levels");
            // 8 x 4 -> 4 x 2 f32, the only level of so small a frame.
            assert_eq!(first.byte_len(), 32);
            let kept = 32 * (photo as usize + levels as usize);
            assert_eq!(d.kept_bytes(), kept, "budget {budget}");
            std::fs::remove_file(&a).expect("rm");
            let again = match d.gray_levels((0, &a), true) {
                Ok(again) => again,
                Err(_) => {
                    // Neither kept: made again from the photo, whose file is gone.
                    assert!(!photo && !levels, "budget {budget}");
                    continue;
                }
            };
            assert_eq!(Arc::ptr_eq(&first, &again), levels, "budget {budget}");
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

    /// A photo the features decode but the budget does not keep leaves its gray levels kept,
    /// made from it (its file gone, the render still has them); a kept photo leaves none (the
    /// render makes them from it), nor does one whose levels would not fit.
    #[test]
    fn features_leave_the_levels_of_a_photo_not_kept() {
        let dir = tempfile::tempdir().expect("dir");
        // (budget, photo kept, levels kept)
        for (budget, photo, levels) in [(64, true, false), (40, false, true), (31, false, false)] {
            let a = png(dir.path(), &format!("{budget}.png"), 7);
            let d = Decoded::new(&[32], budget);
            d.get_with_levels(0, &a).expect("photo");
            let kept = 32 * (photo as usize + levels as usize);
            assert_eq!(d.kept_bytes(), kept, "budget {budget}");
            std::fs::remove_file(&a).expect("rm");
            assert_eq!(
                d.gray_levels((0, &a), true).is_ok(),
                photo || levels,
                "budget {budget}"
            );
        }
    }

    /// Once the rounds are done the levels are let go (the photo stays), unless another
    /// holder shares the slots.
    #[test]
    fn levels_are_let_go_after_the_rounds() {
        let dir = tempfile::tempdir().expect("dir");
        for shared in [false, true] {
            let a = png(dir.path(), &format!("{shared}.png"), 7);
            let d = Arc::new(Decoded::new(&[32], 64));
            let photo = d.get(0, &a).expect("photo");
            d.gray_levels((0, &a), true).expect("levels");
            assert_eq!(d.kept_bytes(), 64);
            let other = shared.then(|| Arc::clone(&d));
            let d = d.without_levels();
            assert_eq!(d.kept_bytes(), if shared { 64 } else { 32 });
            std::fs::remove_file(&a).expect("rm");
            assert!(Arc::ptr_eq(&photo, &d.get(0, &a).expect("kept photo")));
            // Without the file, levels come only from the slot (or the kept photo).
            let levels = d.gray_levels((0, &a), true).expect("levels");
            assert_eq!(d.kept_bytes(), 64, "made again from the photo and kept");
            drop((levels, other));
        }
    }

    /// Levels asked for without keeping are made and not kept, or handed back where kept.
    #[test]
    fn levels_asked_for_without_keeping_are_not_kept() {
        let dir = tempfile::tempdir().expect("dir");
        let a = png(dir.path(), "a.png", 7);
        let d = Decoded::new(&[32], 64);
        d.get(0, &a).expect("photo");
        let probe = d.gray_levels((0, &a), false).expect("levels");
        assert_eq!(d.kept_bytes(), 32, "the photo only");
        let kept = d.gray_levels((0, &a), true).expect("levels");
        assert!(!Arc::ptr_eq(&probe, &kept));
        assert_eq!(d.kept_bytes(), 64);
        assert!(Arc::ptr_eq(
            &kept,
            &d.gray_levels((0, &a), false).expect("kept")
        ));
    }
}
