//! An image's reduced levels kept to warp it many times: a prefiltered warp (`prefilter`) of a
//! destination more than twice coarser than the source reads only levels 1 and deeper, which
//! it builds afresh from the image at every call. [`ReducedLevels`] holds the whole image's
//! levels 1 to the deepest, built once (from level 0's rows, so level 0 itself need not exist
//! as a whole), and [`warp_levels`] warps from them: the same pixels as [`super::warp`] of
//! level 0, bit for bit, or `None` where that warp would read level 0.

use super::options::WarpOptions;
use super::prefilter::{self, Levels, deepest_level, half_row, reduce_half};
use super::types::Build;
use crate::error::RasterError;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::ImageSize;
use rayon::prelude::*;

/// Levels 1 to the deepest of one image (2 x 2 box means, as the prefilter makes them).
#[derive(Debug, Clone)]
pub struct ReducedLevels<T> {
    size0: ImageSize,
    reduced: Vec<Raster<T>>,
}

impl<T: Sample> ReducedLevels<T> {
    /// The levels of a one-band image of `size0`, whose row `r` `row(r, out)` writes (`out`
    /// holds `size0.width` samples). Level 0 is made two rows at a time, never whole.
    pub fn from_rows(
        size0: ImageSize,
        row: impl Fn(usize, &mut [T]) + Sync,
    ) -> Result<Self, RasterError> {
        if size0.width == 0 || size0.height == 0 {
            return Err(RasterError::Empty);
        }
        let (w, h) = (size0.width, size0.height);
        let mut first = Raster::new(ImageSize::new(w.div_ceil(2), h.div_ceil(2)), 1)?;
        let half_width = first.width();
        first
            .plane_mut(0)
            .par_chunks_mut(half_width)
            .enumerate()
            .for_each_init(
                || (vec![T::default(); w], vec![T::default(); w]),
                |(top, bottom), (r, dst)| {
                    let (r0, r1) = (2 * r, (2 * r + 1).min(h - 1));
                    row(r0, top);
                    if r1 == r0 {
                        half_row(top, top, dst);
                    } else {
                        row(r1, bottom);
                        half_row(top, bottom, dst);
                    }
                },
            );
        Self::from_first(size0, first)
    }

    /// The levels of `image` (any bands).
    pub fn of(image: &Raster<T>) -> Result<Self, RasterError> {
        Self::from_first(image.size(), reduce_half(image)?)
    }

    /// Level 0's size.
    pub fn size0(&self) -> ImageSize {
        self.size0
    }

    /// Bytes held.
    pub fn byte_len(&self) -> usize {
        self.reduced
            .iter()
            .map(|r| r.size().pixels() * r.bands() * std::mem::size_of::<T>())
            .sum()
    }

    /// The bytes [`Self::byte_len`] gives for the levels of a `bands`-band image of `size0`,
    /// without making them.
    pub fn byte_len_for(size0: ImageSize, bands: usize) -> usize {
        let mut size = size0;
        (0..deepest_level(size0).max(1))
            .map(|_| {
                size = ImageSize::new(size.width.div_ceil(2), size.height.div_ceil(2));
                size.pixels() * bands * std::mem::size_of::<T>()
            })
            .sum()
    }

    fn from_first(size0: ImageSize, first: Raster<T>) -> Result<Self, RasterError> {
        let mut reduced = vec![first];
        while reduced.len() < deepest_level(size0) {
            let next = reduce_half(&reduced[reduced.len() - 1])?;
            reduced.push(next);
        }
        Ok(Self { size0, reduced })
    }
}

/// [`super::warp`] of the image whose levels these are, into a new `size` raster, from the
/// levels alone: the same pixels, bit for bit. `None` where that warp would read level 0: no
/// prefilter asked for (or not bilinear or bicubic), or a tile whose scale is under 2 and
/// that has a source position.
pub fn warp_levels<T: Sample, M: PixelMap>(
    levels: &ReducedLevels<T>,
    map: &M,
    size: ImageSize,
    opts: &WarpOptions,
) -> Result<Option<Raster<T>>, RasterError> {
    if !prefilter::applies(opts) {
        return Ok(None);
    }
    let Some(plan) = prefilter::plan(map, size, levels.size0) else {
        return Ok(None);
    };
    if plan.max_level() > levels.reduced.len()
        || !prefilter::tiles_of_level0_have_no_source(map, &plan, size)
    {
        return Ok(None);
    }
    // As the warp of level 0 would.
    super::source_fits::<T>(levels.size0, levels.reduced[0].bands())?;
    let bands = levels.reduced[0].bands();
    let mut dst = Raster::new(size, opts.output_bands(bands))?;
    let source = Levels {
        level0: None,
        size0: levels.size0,
        reduced: &levels.reduced,
        origin: [0, 0],
    };
    prefilter::run_levels(&source, map, opts, &mut dst, &plan, Build::Best)?;
    Ok(Some(dst))
}
