//! A tile from the frames' weighted sums, and tiles pasted into one raster.

use super::cache::Format;
use super::labels::CellBox;
use super::weights::Weights;
use super::{MosaicOptions, Window};
use crate::Error;
use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, Raster, Sample, SampleKind};

/// Adds a frame's cells `r` (rendered over box `b` of a tile `tw` cells wide: `bands` bands,
/// then an alpha band when `alpha`), weighted by `w`, to the tile's weighted sums and weights.
/// A cell adds nothing where its weight is not positive, its alpha is 0 (outside the frame) or
/// a sample is not finite.
pub(super) fn accumulate(
    sums: (&mut [Vec<f32>], &mut [f32]),
    tw: usize,
    weights: (CellBox, &Weights),
    r: &AnyRaster,
    bands: (usize, bool),
) {
    match r {
        AnyRaster::U8(r) => add_frame(sums, tw, weights, (r, true), bands),
        AnyRaster::U16(r) => add_frame(sums, tw, weights, (r, true), bands),
        AnyRaster::F32(r) => add_frame(sums, tw, weights, (r, false), bands),
    }
}

/// [`accumulate`] for samples of type `T` (`integer`: every sample is finite).
fn add_frame<T: Sample>(
    (acc, wsum): (&mut [Vec<f32>], &mut [f32]),
    tw: usize,
    (b, w): (CellBox, &Weights),
    (r, integer): (&Raster<T>, bool),
    (bands, alpha): (usize, bool),
) {
    let valid = alpha.then(|| r.plane(bands));
    let planes: Vec<&[T]> = (0..bands).map(|i| r.plane(i)).collect();
    // Integer samples are finite: a cell that adds nothing adds 0 x its sample (+0), which
    // leaves the sums as they were, in one pass the compiler vectorises.
    let bw = b.width();
    let mut we = vec![0f32; bw];
    for (j, row) in (b.r0..b.r1).enumerate() {
        let (i0, s0) = (row * tw + b.c0, j * bw);
        // The row's weights, 0 where the cell is outside the frame or a sample not finite.
        let wrow = w.row(row, (b.c0, b.c1));
        match valid {
            Some(a) => {
                let cells = we.iter_mut().zip(wrow).zip(&a[s0..s0 + bw]);
                for ((e, &wi), v) in cells {
                    *e = if wi > 0.0 && v.to_f32() > 0.0 {
                        wi
                    } else {
                        0.0
                    };
                }
            }
            None => {
                for (e, &wi) in we.iter_mut().zip(wrow) {
                    *e = if wi > 0.0 { wi } else { 0.0 };
                }
            }
        }
        if !integer {
            for (c, e) in we.iter_mut().enumerate() {
                if !planes.iter().all(|p| p[s0 + c].to_f32().is_finite()) {
                    *e = 0.0;
                }
            }
        }
        for (a, p) in acc.iter_mut().zip(&planes) {
            let cells = a[i0..i0 + bw].iter_mut().zip(&p[s0..s0 + bw]).zip(&we);
            if integer {
                cells.for_each(|((x, &v), &e)| *x += e * v.to_f32());
            } else {
                cells
                    .filter(|(_, e)| **e > 0.0)
                    .for_each(|((x, &v), &e)| *x += e * v.to_f32());
            }
        }
        for (x, &e) in wsum[i0..i0 + bw].iter_mut().zip(&we) {
            *x += e;
        }
    }
}

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
                    divide(&mut plane, a, wsum, nodata);
                }
                plane
            })
            .collect();
        if opts.alpha {
            let mut a = vec![T::default(); wsum.len()];
            if !empty {
                for (o, &w) in a.iter_mut().zip(wsum) {
                    *o = if w > 0.0 { T::OPAQUE } else { T::default() };
                }
            }
            planes.push(a);
        }
        Ok(Raster::from_planes(size, planes)?)
    }
    Ok(match format.sample {
        SampleKind::U8 => AnyRaster::U8(build(size, acc, wsum, opts)?),
        SampleKind::U16 => AnyRaster::U16(build(size, acc, wsum, opts)?),
        SampleKind::F32 => AnyRaster::F32(build(size, acc, wsum, opts)?),
    })
}

/// Each cell's weighted sum `a` divided by its weight, `nodata` where it has none. Divided
/// everywhere (a cell without weight divides to NaN and is nodata): one pass the compiler
/// vectorises, every cell stored (a store only where weighed became masked stores, slow on
/// AMD's cores), with `nodata` a value of its own (read through the closure's reference, it
/// was loaded per cell and the loop stayed scalar).
fn divide<T: Sample>(plane: &mut [T], a: &[f32], wsum: &[f32], nodata: T) {
    for ((o, &v), &w) in plane.iter_mut().zip(a).zip(wsum) {
        let q = T::from_f32(v / w);
        *o = if w > 0.0 { q } else { nodata };
    }
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
