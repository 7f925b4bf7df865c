//! Decoded frames shared by the threads compositing tiles: a small least-recently-used set of
//! slots, one per frame, so that two tiles wanting the same frame at once decode it once (the
//! second waits on the first's slot) and a frame let go is decoded again when asked for.
//!
//! Memory: the cache holds at least `cache_frames` frames, and as many as `cache_bytes` holds
//! of the largest; a tile being composited holds one more frame (the one it is rendering)
//! after the cache may have let it go, so at most that + (threads compositing) frames are
//! decoded at once (a 4608 x 3456 RGB u8 photo is 48 MB).

use super::MosaicFrame;
use crate::Error;
use aerorect_raster::{AnyRaster, SampleKind};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

/// Sample type and bands of the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Format {
    pub sample: SampleKind,
    pub bands: usize,
}

impl Format {
    fn of(img: &AnyRaster) -> Self {
        Self {
            sample: img.sample_kind(),
            bands: img.bands(),
        }
    }

    /// Bytes of one pixel (every band).
    fn pixel_bytes(self) -> usize {
        self.bands * self.sample.bytes()
    }
}

/// One frame's decoded image, empty until the first thread to want it has decoded it.
type Slot = Mutex<Option<Arc<AnyRaster>>>;

/// A lock that a panicking holder did not spoil: the slots hold whole values only.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Decoded frames of `frames` (as many as [`Self::capacity`]), shared between threads.
pub(super) struct FrameCache<'a, L> {
    frames: &'a [MosaicFrame],
    load: L,
    /// At least this many frames are held, and as many as `bytes` holds of the largest
    /// (once the frames' format is known).
    frames_held: usize,
    bytes: usize,
    /// The largest frame's pixels.
    largest_px: usize,
    /// The frames held, most recently asked for first.
    slots: Mutex<Vec<(usize, Arc<Slot>)>>,
    /// The first frame's format, which every frame must share.
    format: OnceLock<Format>,
    /// Per frame: loads (decodes, or hand-overs by the loader).
    loads: Vec<AtomicUsize>,
}

impl<'a, L, R> FrameCache<'a, L>
where
    L: Fn(&MosaicFrame) -> Result<R, Error> + Sync,
    R: Into<Arc<AnyRaster>>,
{
    /// At least `frames_held` frames held (one when 0), more as `bytes` allows.
    pub fn new(frames: &'a [MosaicFrame], load: L, (frames_held, bytes): (usize, usize)) -> Self {
        Self {
            frames,
            load,
            frames_held: frames_held.max(1),
            bytes,
            largest_px: frames
                .iter()
                .map(|f| f.plan.camera.size.pixels())
                .max()
                .unwrap_or(0),
            slots: Mutex::new(Vec::new()),
            format: OnceLock::new(),
            loads: frames.iter().map(|_| AtomicUsize::new(0)).collect(),
        }
    }

    /// Loads per frame so far.
    pub fn loads(&self) -> Vec<usize> {
        self.loads
            .iter()
            .map(|n| n.load(Ordering::Relaxed))
            .collect()
    }

    /// The frames' format: the first frame's (decoding it when no frame has been yet).
    pub fn format(&self) -> Result<Format, Error> {
        if let Some(f) = self.format.get() {
            return Ok(*f);
        }
        let first = self.image(0)?;
        Ok(*self.format.get_or_init(|| Format::of(&first)))
    }

    /// Frame `k`'s image, refused when its format is not the first frame's.
    pub fn frame(&self, k: usize) -> Result<Arc<AnyRaster>, Error> {
        let want = self.format()?;
        let img = self.image(k)?;
        let got = Format::of(&img);
        if got != want {
            return Err(Error::Invalid(format!(
                "{}: {} bands of {}, the mosaic's other frames have {} of {}",
                self.frames[k].path.display(),
                got.bands,
                got.sample,
                want.bands,
                want.sample
            )));
        }
        Ok(img)
    }

    /// How many frames are held: `frames_held`, or as many of the largest frame as `bytes`
    /// holds once the format is known.
    fn capacity(&self) -> usize {
        let by_bytes = match self.format.get() {
            Some(f) => self.bytes / (self.largest_px * f.pixel_bytes()).max(1),
            None => 0,
        };
        self.frames_held.max(by_bytes)
    }

    /// Frame `k`'s image, from its slot or decoded into it.
    fn image(&self, k: usize) -> Result<Arc<AnyRaster>, Error> {
        let slot = {
            let mut slots = lock(&self.slots);
            let e = match slots.iter().position(|e| e.0 == k) {
                Some(i) => slots.remove(i),
                None => {
                    slots.truncate(self.capacity() - 1);
                    (k, Arc::new(Mutex::new(None)))
                }
            };
            let slot = Arc::clone(&e.1);
            slots.insert(0, e);
            slot
        };
        let mut held = lock(&slot);
        if let Some(img) = held.as_ref() {
            return Ok(Arc::clone(img));
        }
        let img = self.decode(k)?;
        *held = Some(Arc::clone(&img));
        Ok(img)
    }

    /// Frame `k` decoded (or handed over by the loader), refused when its image is not its
    /// camera's size.
    fn decode(&self, k: usize) -> Result<Arc<AnyRaster>, Error> {
        let f = &self.frames[k];
        let img: Arc<AnyRaster> = (self.load)(f)?.into();
        self.loads[k].fetch_add(1, Ordering::Relaxed);
        let (got, want) = (img.size(), f.plan.camera.size);
        if got != want {
            return Err(Error::Invalid(format!(
                "{}: the image is {} x {}, its plan is for {} x {}",
                f.path.display(),
                got.width,
                got.height,
                want.width,
                want.height
            )));
        }
        Ok(img)
    }
}
