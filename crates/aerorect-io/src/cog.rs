//! Cloud-optimised GeoTIFF (COG) output, laid out as GDAL's COG driver lays it out and as
//! `rio cogeo validate` checks it: a tiled TIFF (or BigTIFF) whose IFDs come first (the full
//! resolution, then each overview, each image IFD followed by its mask IFD when there is a
//! mask), with their tag values and the TileOffsets/TileByteCounts arrays before any tile
//! data; the tiles of the smallest overview come first and those of the full resolution last
//! (each image tile followed by its mask tile). GeoTIFF tags on the full resolution's IFD only.
//!
//! Overviews halve the image (sizes rounded up) until it fits one tile. Image overviews are
//! 2x2 averages of the valid children (a pixel with none is nodata, or 0 under a mask); mask
//! overviews take the nearest (top-left) child. Compression: Deflate (zlib, `flate2`), or JPEG
//! (the `image` crate's baseline encoder, 4:4:4, written as YCbCr for RGB) for 8-bit images of
//! 1 or 3 bands; masks are always Deflate. The TIFF structure is written here by hand: the
//! `tiff` crate's encoder writes strips only.

mod check;
pub(crate) mod layout;
pub(crate) mod option_error;
mod pyramid;

pub use option_error::CogOptionError;

use crate::error::{CodecError, IoError};
use crate::geotiff::{GDAL_NODATA, GeoReference, GeoTagValue};
use aerorect_raster::{AnyRaster, Raster};
use layout::{Ifd, NEW_SUBFILE_TYPE, Value};
pub(crate) use pyramid::CogSample;
use pyramid::Level;
use rayon::prelude::*;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

/// Compression of the image tiles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CogCompression {
    /// Lossless zlib Deflate (TIFF compression 8).
    Deflate,
    /// Baseline JPEG (TIFF compression 7): 8-bit images of 1 or 3 bands (after an alpha band
    /// became the mask); `quality` 1-100.
    Jpeg { quality: u8 },
}

/// Which pixels are valid.
#[derive(Debug, Clone, PartialEq)]
pub enum CogMask {
    /// No mask: the nodata value (if any) marks invalid samples, band by band.
    None,
    /// The last band (of 2 or 4) is alpha: it becomes an internal 1-bit mask (alpha > 0 is
    /// valid) and is not written as a band (GDAL's way for JPEG).
    AlphaBand,
    /// An internal 1-bit mask from this plane (width x height, row-major, non-zero = valid).
    Plane(Vec<u8>),
}

/// How to write a cloud-optimised GeoTIFF.
#[derive(Debug, Clone, PartialEq)]
pub struct CogOptions {
    /// Tile width and height in pixels: a multiple of 16, from 16 to 4096. Default 512.
    pub tile: usize,
    /// Default Deflate.
    pub compression: CogCompression,
    /// zlib level of Deflate tiles and of masks, 1 (fastest) to 9; default 6 (GDAL's). On an
    /// 8000 x 6000 RGB image (2 cores) 6 takes about three times as long as 1.
    pub deflate_level: u32,
    /// Internal overviews, halving until the image fits one tile. Default true.
    pub overviews: bool,
    /// The nodata value; `None` takes the GeoReference's. Written as GDAL_NODATA.
    pub nodata: Option<f64>,
    /// Default [`CogMask::None`].
    pub mask: CogMask,
    /// BigTIFF: `None` chooses it when the uncompressed tiles would come near 4 GiB.
    pub bigtiff: Option<bool>,
}

impl CogOptions {
    /// The defaults, with an alpha band (when the image has one) as the internal mask: what
    /// `--cog` writes for every command and front end.
    pub fn masked_by_alpha(alpha: bool) -> Self {
        CogOptions {
            mask: if alpha {
                CogMask::AlphaBand
            } else {
                CogMask::None
            },
            ..CogOptions::default()
        }
    }
}

impl Default for CogOptions {
    fn default() -> Self {
        CogOptions {
            tile: 512,
            compression: CogCompression::Deflate,
            deflate_level: 6,
            overviews: true,
            nodata: None,
            mask: CogMask::None,
            bigtiff: None,
        }
    }
}

/// Writes `raster` as a cloud-optimised GeoTIFF at `path` (atomically: a temporary file
/// renamed into place).
pub fn write_cog(
    path: &Path,
    raster: &AnyRaster,
    geo: &GeoReference,
    opts: &CogOptions,
) -> Result<(), IoError> {
    write_cog_file(path, raster, Some(geo), opts)
}

/// Like [`crate::write_image_geo`] for a .tif/.tiff name, but cloud-optimised; `geo` may be
/// absent (a plain tiled TIFF with overviews).
pub fn write_image_cog(
    path: &Path,
    raster: &AnyRaster,
    geo: Option<&GeoReference>,
    opts: &CogOptions,
) -> Result<(), IoError> {
    let mut staged = crate::StagedOutputs::new();
    staged.cog(path, raster, geo, opts)?;
    staged.commit()
}

fn write_cog_file(
    path: &Path,
    raster: &AnyRaster,
    geo: Option<&GeoReference>,
    opts: &CogOptions,
) -> Result<(), IoError> {
    let mut staged = crate::StagedOutputs::new();
    stage_cog(&mut staged, path, raster, geo, opts)?;
    staged.commit()
}

impl crate::StagedOutputs {
    /// Stages a cloud-optimised GeoTIFF like [`write_image_cog`], to land with the other
    /// staged outputs.
    pub fn cog(
        &mut self,
        path: &Path,
        raster: &AnyRaster,
        geo: Option<&GeoReference>,
        opts: &CogOptions,
    ) -> Result<(), IoError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        if !matches!(ext.as_deref(), Some("tif") | Some("tiff")) {
            return Err(IoError::encode(
                path,
                "a cloud-optimised GeoTIFF needs a .tif or .tiff file name",
            ));
        }
        stage_cog(self, path, raster, geo, opts)
    }
}

fn stage_cog(
    staged: &mut crate::StagedOutputs,
    path: &Path,
    raster: &AnyRaster,
    geo: Option<&GeoReference>,
    opts: &CogOptions,
) -> Result<(), IoError> {
    opts.validate(raster, geo)
        .map_err(|e| IoError::encode(path, e))?;
    let nodata = opts.nodata.or(geo.and_then(|g| g.nodata));
    let mut tags = match geo {
        Some(g) => g.tags().map_err(|e| IoError::encode(path, e))?,
        None => Vec::new(),
    };
    tags.retain(|(t, _)| *t != GDAL_NODATA);
    if let Some(nd) = nodata {
        tags.push((GDAL_NODATA, GeoTagValue::Ascii(format!("{nd}"))));
    }
    let geo_tags: Vec<(u16, Value)> = tags.into_iter().map(|(t, v)| (t, v.into())).collect();
    staged.file(path, |w| {
        let r = match raster {
            AnyRaster::U8(r) => write_typed(w, r, nodata, &geo_tags, opts),
            AnyRaster::U16(r) => write_typed(w, r, nodata, &geo_tags, opts),
            AnyRaster::F32(r) => write_typed(w, r, nodata, &geo_tags, opts),
        };
        r.map_err(|e| IoError::encode(path, e))
    })
}

fn write_typed<W: Write + Seek, T: CogSample>(
    w: &mut W,
    raster: &Raster<T>,
    nodata: Option<f64>,
    geo_tags: &[(u16, Value)],
    opts: &CogOptions,
) -> Result<(), CodecError> {
    let nodata = nodata.and_then(T::from_f64_exact);
    let levels = pyramid::levels(raster, &opts.mask, nodata, opts.tile, opts.overviews)?;
    let ifds = ifds(&levels, geo_tags, opts);
    let big = opts
        .bigtiff
        .unwrap_or_else(|| needs_bigtiff(&ifds, &levels, opts));
    let lay = layout::layout(&ifds, big);
    w.write_all(&lay.bytes)?;
    let mut pos = lay.bytes.len() as u64;
    let per_level = if levels[0].mask.is_some() { 2 } else { 1 };
    let mut offsets = vec![Vec::new(); ifds.len()];
    let mut counts = vec![Vec::new(); ifds.len()];
    for (li, level) in levels.iter().enumerate().rev() {
        let (across, down) = tiles_of(level, opts.tile);
        for ty in 0..down {
            let row: Vec<(Vec<u8>, Option<Vec<u8>>)> = (0..across)
                .into_par_iter()
                .map(|tx| encode_tile(level, tx, ty, opts))
                .collect::<Result<_, CodecError>>()?;
            for (img, mask) in row {
                let ifd = li * per_level;
                for (k, data) in std::iter::once(img).chain(mask).enumerate() {
                    w.write_all(&data)?;
                    offsets[ifd + k].push(pos);
                    counts[ifd + k].push(data.len() as u64);
                    pos += data.len() as u64;
                }
            }
        }
    }
    for (i, (o, c)) in offsets.iter().zip(&counts).enumerate() {
        let (Some(ob), Some(cb)) = (lay.array(o), lay.array(c)) else {
            return Err(format!("the file passes 4 GiB ({pos} bytes): write it as BigTIFF").into());
        };
        w.seek(SeekFrom::Start(lay.offsets_at[i]))?;
        w.write_all(&ob)?;
        w.seek(SeekFrom::Start(lay.counts_at[i]))?;
        w.write_all(&cb)?;
    }
    w.seek(SeekFrom::End(0))?;
    Ok(())
}

fn tiles_of<T>(level: &Level<'_, T>, tile: usize) -> (usize, usize)
where
    T: CogSample,
{
    (
        level.raster.width().div_ceil(tile),
        level.raster.height().div_ceil(tile),
    )
}

/// BigTIFF when the uncompressed tiles (JPEG: with a quarter more) reach 3.9 GB.
fn needs_bigtiff<T: CogSample>(ifds: &[Ifd], levels: &[Level<'_, T>], opts: &CogOptions) -> bool {
    let px = (opts.tile * opts.tile) as f64;
    let bands = levels[0].raster.bands() as f64;
    let sample = f64::from(T::BITS) / 8.0;
    let tiles: f64 = levels
        .iter()
        .map(|l| {
            let (a, d) = tiles_of(l, opts.tile);
            (a * d) as f64
        })
        .sum();
    let mut bytes = tiles * px * bands * sample;
    if matches!(opts.compression, CogCompression::Jpeg { .. }) {
        bytes *= 1.25;
    }
    if levels[0].mask.is_some() {
        bytes += tiles * px / 8.0;
    }
    bytes += 64.0 * ifds.len() as f64 + 16.0 * tiles;
    bytes > 3.9e9
}

/// The IFDs in file order: each level's image, then its mask when there is one.
fn ifds<T: CogSample>(
    levels: &[Level<'_, T>],
    geo_tags: &[(u16, Value)],
    opts: &CogOptions,
) -> Vec<Ifd> {
    let tile = opts.tile as u32;
    let bands = levels[0].raster.bands();
    let jpeg = matches!(opts.compression, CogCompression::Jpeg { .. });
    let alpha = levels[0].alpha;
    let photometric: u16 = match (bands, jpeg) {
        (3, true) => 6, // YCbCr: the JPEG encoder stores JFIF YCbCr
        (3 | 4, _) => 2,
        _ => 1,
    };
    let mut out = Vec::new();
    for (i, level) in levels.iter().enumerate() {
        let (across, down) = tiles_of(level, opts.tile);
        let (w, h) = (level.raster.width() as u32, level.raster.height() as u32);
        let size_tags = |sub: u32| {
            vec![
                (NEW_SUBFILE_TYPE, Value::Long(vec![sub])),
                (256, Value::Long(vec![w])),
                (257, Value::Long(vec![h])),
            ]
        };
        let mut tags = size_tags(if i == 0 { 0 } else { 1 });
        tags.extend([
            (258, Value::Short(vec![T::BITS; bands])),
            (259, Value::Short(vec![if jpeg { 7 } else { 8 }])),
            (262, Value::Short(vec![photometric])),
            (277, Value::Short(vec![bands as u16])),
            (284, Value::Short(vec![1])),
            (322, Value::Long(vec![tile])),
            (323, Value::Long(vec![tile])),
            (339, Value::Short(vec![T::FORMAT; bands])),
        ]);
        if alpha {
            tags.push((338, Value::Short(vec![2]))); // unassociated alpha
        }
        if photometric == 6 {
            tags.push((530, Value::Short(vec![1, 1])));
        }
        if i == 0 {
            tags.extend(geo_tags.iter().cloned());
        }
        out.push(Ifd {
            tags,
            tiles: across * down,
        });
        if level.mask.is_some() {
            let mut tags = size_tags(if i == 0 { 4 } else { 5 });
            tags.extend([
                (258, Value::Short(vec![1])),
                (259, Value::Short(vec![8])),
                (262, Value::Short(vec![4])), // transparency mask
                (277, Value::Short(vec![1])),
                (284, Value::Short(vec![1])),
                (322, Value::Long(vec![tile])),
                (323, Value::Long(vec![tile])),
                (339, Value::Short(vec![1])),
            ]);
            out.push(Ifd {
                tags,
                tiles: across * down,
            });
        }
    }
    out
}

/// One tile of a level, compressed, and its mask tile.
fn encode_tile<T: CogSample>(
    level: &Level<'_, T>,
    tx: usize,
    ty: usize,
    opts: &CogOptions,
) -> Result<(Vec<u8>, Option<Vec<u8>>), CodecError> {
    let t = opts.tile;
    let img = match opts.compression {
        CogCompression::Deflate => deflate(
            &pyramid::tile_bytes(&level.raster, tx, ty, t, false),
            opts.deflate_level,
        ),
        CogCompression::Jpeg { quality } => jpeg(
            &pyramid::tile_bytes(&level.raster, tx, ty, t, true),
            t,
            level.raster.bands(),
            quality,
        ),
    }?;
    let mask = match &level.mask {
        Some(m) => {
            let (w, h) = (level.raster.width(), level.raster.height());
            Some(deflate(
                &pyramid::mask_tile(m, w, h, tx, ty, t),
                opts.deflate_level,
            )?)
        }
        None => None,
    };
    Ok((img, mask))
}

fn deflate(bytes: &[u8], level: u32) -> Result<Vec<u8>, CodecError> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(level));
    z.write_all(bytes)?;
    Ok(z.finish()?)
}

fn jpeg(bytes: &[u8], tile: usize, bands: usize, quality: u8) -> Result<Vec<u8>, CodecError> {
    use image::ImageEncoder;
    let colour = if bands == 3 {
        image::ExtendedColorType::Rgb8
    } else {
        image::ExtendedColorType::L8
    };
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, quality).write_image(
        bytes,
        tile as u32,
        tile as u32,
        colour,
    )?;
    Ok(out)
}
