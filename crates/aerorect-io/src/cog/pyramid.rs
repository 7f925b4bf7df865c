//! The overview levels of a COG and the bytes of its tiles.
//!
//! A level's pixel (x, y) has the children (2x + i, 2y + j), i, j in {0, 1}, of the level
//! above (those inside it). Image bands: the mean of the valid children (rounded half up for
//! integers); a child is valid where the mask is non-zero, else (for the colour bands of an
//! image with alpha) where alpha is non-zero, else where the sample is not nodata; a pixel
//! with no valid child is nodata (0 without one). The alpha band itself is the mean of all
//! children. Masks: the top-left child (nearest).

use super::CogMask;
use aerorect_core::ImageSize;
use aerorect_raster::{Raster, RasterError, Sample};
use std::borrow::Cow;

/// A sample type a COG stores: its TIFF BitsPerSample and SampleFormat.
pub(crate) trait CogSample: Sample {
    const BITS: u16;
    /// SampleFormat: 1 unsigned integer, 3 IEEE float.
    const FORMAT: u16;
    fn put_le(self, out: &mut Vec<u8>);
    /// Appends `values` as little-endian bytes.
    fn extend_le(values: &[Self], out: &mut Vec<u8>) {
        out.reserve(values.len() * usize::from(Self::BITS / 8));
        for &v in values {
            v.put_le(out);
        }
    }
    /// Equality for nodata: NaN equals NaN.
    fn same(self, other: Self) -> bool;
}

impl CogSample for u8 {
    const BITS: u16 = 8;
    const FORMAT: u16 = 1;
    fn put_le(self, out: &mut Vec<u8>) {
        out.push(self);
    }
    fn extend_le(values: &[Self], out: &mut Vec<u8>) {
        out.extend_from_slice(values);
    }
    fn same(self, other: Self) -> bool {
        self == other
    }
}

impl CogSample for u16 {
    const BITS: u16 = 16;
    const FORMAT: u16 = 1;
    fn put_le(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
    fn same(self, other: Self) -> bool {
        self == other
    }
}

impl CogSample for f32 {
    const BITS: u16 = 32;
    const FORMAT: u16 = 3;
    fn put_le(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.to_le_bytes());
    }
    fn same(self, other: Self) -> bool {
        self == other || (self.is_nan() && other.is_nan())
    }
}

/// One resolution: its bands, its mask (255 valid, 0 not) and whether its last band is alpha.
pub(crate) struct Level<'a, T: CogSample> {
    pub raster: Cow<'a, Raster<T>>,
    pub mask: Option<Vec<u8>>,
    pub alpha: bool,
}

/// The full resolution (the alpha band split off into the mask for [`CogMask::AlphaBand`])
/// and, with `overviews`, the levels halving until one fits a `tile` x `tile` tile.
pub(crate) fn levels<'a, T: CogSample>(
    raster: &'a Raster<T>,
    mask: &CogMask,
    nodata: Option<T>,
    tile: usize,
    overviews: bool,
) -> Result<Vec<Level<'a, T>>, RasterError> {
    let first = match mask {
        CogMask::None => Level {
            raster: Cow::Borrowed(raster),
            mask: None,
            alpha: matches!(raster.bands(), 2 | 4),
        },
        CogMask::Plane(m) => Level {
            raster: Cow::Borrowed(raster),
            mask: Some(m.iter().map(|&v| if v != 0 { 255 } else { 0 }).collect()),
            alpha: matches!(raster.bands(), 2 | 4),
        },
        CogMask::AlphaBand => {
            let n = raster.bands() - 1;
            let planes = raster.planes()[..n].to_vec();
            let alpha = raster.plane(n);
            let m = alpha
                .iter()
                .map(|&a| if a.to_f32() > 0.0 { 255 } else { 0 })
                .collect();
            Level {
                raster: Cow::Owned(Raster::from_planes(raster.size(), planes)?),
                mask: Some(m),
                alpha: false,
            }
        }
    };
    let mut out = vec![first];
    while let Some(last) = out.last().filter(|_| overviews) {
        if last.raster.width() <= tile && last.raster.height() <= tile {
            break;
        }
        let next = half(last, nodata)?;
        out.push(next);
    }
    Ok(out)
}

/// The next level: children averaged (valid ones only), masks by nearest.
pub(crate) fn half<T: CogSample>(
    level: &Level<'_, T>,
    nodata: Option<T>,
) -> Result<Level<'static, T>, RasterError> {
    let src = &level.raster;
    let (w, h) = (src.width(), src.height());
    let size = ImageSize::new(w.div_ceil(2), h.div_ceil(2));
    let bands = src.bands();
    let fill = nodata.unwrap_or_default();
    let mut planes = Vec::with_capacity(bands);
    for b in 0..bands {
        let plane = src.plane(b);
        let is_alpha = level.alpha && b == bands - 1;
        let valid = |i: usize| -> bool {
            if let Some(m) = &level.mask {
                m[i] != 0
            } else if is_alpha {
                true
            } else if level.alpha {
                src.plane(bands - 1)[i].to_f32() > 0.0
            } else {
                nodata.is_none_or(|nd| !plane[i].same(nd))
            }
        };
        let mut out = Vec::with_capacity(size.width * size.height);
        for y in 0..size.height {
            for x in 0..size.width {
                let (mut sum, mut n) = (0.0f64, 0u32);
                for cy in 2 * y..(2 * y + 2).min(h) {
                    for cx in 2 * x..(2 * x + 2).min(w) {
                        let i = cy * w + cx;
                        if valid(i) {
                            sum += f64::from(plane[i].to_f32());
                            n += 1;
                        }
                    }
                }
                out.push(if n > 0 {
                    T::from_f32((sum / f64::from(n)) as f32)
                } else {
                    fill
                });
            }
        }
        planes.push(out);
    }
    let mask = level.mask.as_ref().map(|m| {
        let mut out = Vec::with_capacity(size.width * size.height);
        for y in 0..size.height {
            for x in 0..size.width {
                out.push(m[2 * y * w + 2 * x]);
            }
        }
        out
    });
    Ok(Level {
        raster: Cow::Owned(Raster::from_planes(size, planes)?),
        mask,
        alpha: level.alpha,
    })
}

/// Tile (tx, ty) as interleaved little-endian samples, `tile` x `tile`; the part past the
/// image is zero, or (`replicate`, for JPEG) repeats the edge pixels.
pub(crate) fn tile_bytes<T: CogSample>(
    r: &Raster<T>,
    tx: usize,
    ty: usize,
    tile: usize,
    replicate: bool,
) -> Vec<u8> {
    let (w, h, bands) = (r.width(), r.height(), r.bands());
    let bytes = usize::from(T::BITS / 8);
    let mut out = Vec::with_capacity(tile * tile * bands * bytes);
    let (x0, y0) = (tx * tile, ty * tile);
    for j in 0..tile {
        let y = y0 + j;
        if y >= h && !replicate {
            out.resize(tile * tile * bands * bytes, 0);
            break;
        }
        let y = y.min(h - 1);
        for i in 0..tile {
            let x = x0 + i;
            if x >= w && !replicate {
                out.resize(out.len() + (tile - i) * bands * bytes, 0);
                break;
            }
            let idx = y * w + x.min(w - 1);
            for b in 0..bands {
                r.plane(b)[idx].put_le(&mut out);
            }
        }
    }
    out
}

/// A mask tile packed 1 bit a pixel, most significant bit first, rows padded to bytes; 1 is
/// valid, the part past the image 0.
pub(crate) fn mask_tile(
    m: &[u8],
    w: usize,
    h: usize,
    tx: usize,
    ty: usize,
    tile: usize,
) -> Vec<u8> {
    let row_bytes = tile.div_ceil(8);
    let mut out = vec![0u8; row_bytes * tile];
    for j in 0..tile.min(h.saturating_sub(ty * tile)) {
        let y = ty * tile + j;
        for i in 0..tile.min(w.saturating_sub(tx * tile)) {
            if m[y * w + tx * tile + i] != 0 {
                out[j * row_bytes + i / 8] |= 0x80 >> (i % 8);
            }
        }
    }
    out
}
