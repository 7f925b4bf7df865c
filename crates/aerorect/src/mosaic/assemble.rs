//! A tile from the frames' weighted sums, and tiles pasted into one raster.

use super::cache::Format;
use super::{MosaicOptions, Window};
use crate::Error;
use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, Raster, Sample};

/// The tile from its weighted sums: the frames' sample type, an alpha band when asked.
pub(super) fn assemble(
    format: Format,
    size: ImageSize,
    acc: Vec<Vec<f32>>,
    wsum: &[f32],
    opts: &MosaicOptions,
) -> Result<AnyRaster, Error> {
    fn build<T: Sample>(
        size: ImageSize,
        acc: Vec<Vec<f32>>,
        wsum: &[f32],
        opts: &MosaicOptions,
    ) -> Result<Raster<T>, Error> {
        let nodata = T::from_f64_exact(opts.nodata).ok_or_else(|| {
            Error::Invalid(format!(
                "nodata {} does not fit the frames' {} samples",
                opts.nodata,
                T::NAME
            ))
        })?;
        // Two thirds of snowpeak's tiles lie beyond every frame: filled, not divided out.
        let empty = wsum.iter().all(|&w| w <= 0.0);
        let mut planes: Vec<Vec<T>> = acc
            .iter()
            .map(|a| {
                let mut plane = vec![nodata; wsum.len()];
                if !empty {
                    // Divided everywhere (a cell without weight divides to NaN and keeps
                    // nodata): one pass the compiler vectorises.
                    for ((o, &v), &w) in plane.iter_mut().zip(a).zip(wsum) {
                        let q = T::from_f32(v / w);
                        *o = if w > 0.0 { q } else { *o };
                    }
                }
                plane
            })
            .collect();
        if opts.alpha {
            let a = wsum
                .iter()
                .map(|&w| if w > 0.0 { T::OPAQUE } else { T::default() });
            planes.push(a.collect());
        }
        Ok(Raster::from_planes(size, planes)?)
    }
    Ok(match format.sample {
        "u8" => AnyRaster::U8(build(size, acc, wsum, opts)?),
        "u16" => AnyRaster::U16(build(size, acc, wsum, opts)?),
        _ => AnyRaster::F32(build(size, acc, wsum, opts)?),
    })
}

/// Copies `tile` into the mosaic `whole` (made, of the tile's type and bands, at the first).
pub(super) fn paste(
    whole: &mut Option<AnyRaster>,
    size: ImageSize,
    tile: &AnyRaster,
    w: Window,
) -> Result<(), Error> {
    fn copy<T: Sample>(dst: &mut Raster<T>, src: &Raster<T>, w: Window) {
        let (width, tw) = (dst.size().width, w.size.width);
        for b in 0..src.bands() {
            let d = dst.plane_mut(b);
            for (r, row) in src.plane(b).chunks(tw).enumerate() {
                let at = (w.row0 + r) * width + w.col0;
                d[at..at + tw].copy_from_slice(row);
            }
        }
    }
    if whole.is_none() {
        let bands = tile.bands();
        *whole = Some(match tile {
            AnyRaster::U8(_) => AnyRaster::U8(Raster::new(size, bands)?),
            AnyRaster::U16(_) => AnyRaster::U16(Raster::new(size, bands)?),
            AnyRaster::F32(_) => AnyRaster::F32(Raster::new(size, bands)?),
        });
    }
    match (whole.as_mut(), tile) {
        (Some(AnyRaster::U8(d)), AnyRaster::U8(s)) if d.bands() == s.bands() => copy(d, s, w),
        (Some(AnyRaster::U16(d)), AnyRaster::U16(s)) if d.bands() == s.bands() => copy(d, s, w),
        (Some(AnyRaster::F32(d)), AnyRaster::F32(s)) if d.bands() == s.bands() => copy(d, s, w),
        _ => {
            return Err(Error::Invalid(
                "mosaic tiles of different sample types or bands".into(),
            ));
        }
    }
    Ok(())
}
