//! A tiled (Geo)TIFF written one tile at a time, so an image larger than memory (a flight's
//! mosaic) never has to be held whole: each tile is asked for in row-major order, compressed
//! (Deflate, with the horizontal predictor for integer samples) and appended to the file; the
//! directory with the tile offsets and the GeoTIFF tags follows the last tile. BigTIFF when the
//! uncompressed image would not fit a classic TIFF's 4 GiB. Written to a temporary file and
//! renamed, so a failure (of the writer or of the tile source) leaves nothing behind.

use crate::error::{CodecError, IoError};
use crate::geotiff::GeoReference;
use aerorect_core::ImageSize;
use aerorect_raster::AnyRaster;
use std::io::{Seek, Write};
use std::path::Path;
use tiff::encoder::compression::{CompressionAlgorithm, Deflate, DeflateLevel};
use tiff::encoder::{TiffEncoder, TiffKind, TiffKindBig, TiffKindStandard};
use tiff::tags::Tag;

/// Above this many uncompressed bytes the file is a BigTIFF (classic offsets are 32-bit).
const CLASSIC_LIMIT_BYTES: u128 = 3 << 30;

/// Writes a tiled TIFF of `size` (a GeoTIFF with `geo`) at `path`, atomically. `tile_at(col0,
/// row0, size)` gives the tile whose top-left pixel is (col0, row0): `size` pixels (smaller
/// than `tile` at the right and bottom edges), every tile of the first one's sample type and
/// band count (1-4; 2 and 4 end with an alpha band). `tile` must be a multiple of 16 (TIFF).
/// An error from `tile_at` is returned as is, and nothing is written.
pub fn write_tiled_tiff<E: From<IoError>>(
    path: &Path,
    size: ImageSize,
    tile: usize,
    geo: Option<&GeoReference>,
    mut tile_at: impl FnMut(usize, usize, ImageSize) -> Result<AnyRaster, E>,
) -> Result<(), E> {
    if tile == 0 || !tile.is_multiple_of(16) || size.width == 0 || size.height == 0 {
        return Err(IoError::encode(
            path,
            format!(
                "a tiled TIFF needs tiles of a multiple of 16 px (got {tile}) and a non-empty image ({} x {})",
                size.width, size.height
            ),
        )
        .into());
    }
    let mut failed: Option<E> = None;
    let written = crate::write_atomically(path, |w| {
        let mut next = |c: usize, r: usize| {
            let s = ImageSize::new(tile.min(size.width - c), tile.min(size.height - r));
            match tile_at(c, r, s) {
                Ok(t) if t.size() == s => Ok(Some(t)),
                Ok(t) => Err(CodecError::from(format!(
                    "tile at ({c}, {r}) is {} x {}, expected {} x {}",
                    t.size().width,
                    t.size().height,
                    s.width,
                    s.height
                ))),
                Err(e) => {
                    failed = Some(e);
                    Ok(None)
                }
            }
        };
        let layout = Layout { size, tile };
        let result = match next(0, 0) {
            Ok(Some(first)) => {
                let bytes = size.pixels() as u128 * first.bands() as u128 * sample_bytes(&first);
                if bytes > CLASSIC_LIMIT_BYTES {
                    let enc = TiffEncoder::new_big(w).map_err(CodecError::from);
                    enc.and_then(|e| encode::<_, TiffKindBig>(e, layout, geo, first, &mut next))
                } else {
                    let enc = TiffEncoder::new(w).map_err(CodecError::from);
                    enc.and_then(|e| {
                        encode::<_, TiffKindStandard>(e, layout, geo, first, &mut next)
                    })
                }
            }
            Ok(None) => Ok(()),
            Err(e) => Err(e),
        };
        match result {
            Ok(()) if failed.is_none() => Ok(()),
            Ok(()) => Err(IoError::encode(path, "the tile source failed")),
            Err(e) => Err(IoError::encode(path, e)),
        }
    });
    match (written, failed) {
        (_, Some(e)) => Err(e),
        (Err(e), None) => Err(e.into()),
        (Ok(()), None) => Ok(()),
    }
}

#[derive(Clone, Copy)]
struct Layout {
    size: ImageSize,
    tile: usize,
}

fn sample_bytes(r: &AnyRaster) -> u128 {
    match r {
        AnyRaster::U8(_) => 1,
        AnyRaster::U16(_) => 2,
        AnyRaster::F32(_) => 4,
    }
}

type NextTile<'a> = dyn FnMut(usize, usize) -> Result<Option<AnyRaster>, CodecError> + 'a;

fn encode<W: Write + Seek, K: TiffKind>(
    mut enc: TiffEncoder<W, K>,
    layout: Layout,
    geo: Option<&GeoReference>,
    first: AnyRaster,
    next: &mut NextTile<'_>,
) -> Result<(), CodecError> {
    let e = CodecError::from;
    let (bands, kind) = (first.bands(), first.sample_name());
    if !(1..=4).contains(&bands) {
        return Err(format!("TIFF output holds 1 to 4 bands, this image has {bands}").into());
    }
    let (bits, format, integer) = match first {
        AnyRaster::U8(_) => (8u16, 1u16, true),
        AnyRaster::U16(_) => (16, 1, true),
        AnyRaster::F32(_) => (32, 3, false),
    };
    let Layout { size, tile } = layout;
    let mut dir = enc.image_directory().map_err(e)?;
    let (mut offsets, mut counts) = (Vec::new(), Vec::new());
    let mut pending = Some(first);
    for r in (0..size.height).step_by(tile) {
        for c in (0..size.width).step_by(tile) {
            let t = match pending.take() {
                Some(t) => t,
                None => match next(c, r)? {
                    Some(t) => t,
                    None => return Ok(()), // the source failed; the caller reports it
                },
            };
            if t.bands() != bands || t.sample_name() != kind {
                return Err(format!(
                    "tile at ({c}, {r}) has {} {} bands, the first had {bands} {kind}",
                    t.bands(),
                    t.sample_name(),
                )
                .into());
            }
            let raw = tile_bytes(&t, tile);
            let mut packed = Vec::with_capacity(raw.len() / 2);
            Deflate::with_level(DeflateLevel::Fast).write_to(&mut packed, &raw)?;
            let at = dir.write_data(&packed[..]).map_err(e)?;
            offsets.push(K::convert_offset(at).map_err(e)?);
            counts.push(K::convert_offset(packed.len() as u64).map_err(e)?);
        }
    }
    dir.write_tag(Tag::ImageWidth, size.width as u32)
        .map_err(e)?;
    dir.write_tag(Tag::ImageLength, size.height as u32)
        .map_err(e)?;
    dir.write_tag(Tag::BitsPerSample, &vec![bits; bands][..])
        .map_err(e)?;
    dir.write_tag(Tag::Compression, 8u16).map_err(e)?; // Adobe Deflate
    let photometric: u16 = if bands >= 3 { 2 } else { 1 }; // RGB or BlackIsZero
    dir.write_tag(Tag::PhotometricInterpretation, photometric)
        .map_err(e)?;
    dir.write_tag(Tag::SamplesPerPixel, bands as u16)
        .map_err(e)?;
    dir.write_tag(Tag::PlanarConfiguration, 1u16).map_err(e)?;
    if integer {
        dir.write_tag(Tag::Predictor, 2u16).map_err(e)?; // horizontal differencing
    }
    dir.write_tag(Tag::TileWidth, tile as u32).map_err(e)?;
    dir.write_tag(Tag::TileLength, tile as u32).map_err(e)?;
    dir.write_tag(Tag::TileOffsets, K::convert_slice(&offsets))
        .map_err(e)?;
    dir.write_tag(Tag::TileByteCounts, K::convert_slice(&counts))
        .map_err(e)?;
    if bands == 2 || bands == 4 {
        dir.write_tag(Tag::ExtraSamples, &[2u16][..]).map_err(e)?; // unassociated alpha
    }
    dir.write_tag(Tag::SampleFormat, &vec![format; bands][..])
        .map_err(e)?;
    if let Some(g) = geo {
        g.write_tags(&mut dir)?;
    }
    dir.finish().map_err(e)
}

/// The tile's samples interleaved in a full `tile` x `tile` block (zeros past the image's
/// edge), native byte order; integer samples horizontally differenced (TIFF predictor 2).
fn tile_bytes(t: &AnyRaster, tile: usize) -> Vec<u8> {
    match t {
        AnyRaster::U8(r) => {
            let mut v = padded(r, tile);
            predict(&mut v, r.bands(), tile, u8::wrapping_sub);
            v
        }
        AnyRaster::U16(r) => {
            let mut v = padded(r, tile);
            predict(&mut v, r.bands(), tile, u16::wrapping_sub);
            v.iter().flat_map(|x| x.to_ne_bytes()).collect()
        }
        AnyRaster::F32(r) => padded(r, tile)
            .iter()
            .flat_map(|x| x.to_ne_bytes())
            .collect(),
    }
}

fn padded<T: aerorect_raster::Sample>(r: &aerorect_raster::Raster<T>, tile: usize) -> Vec<T> {
    let (w, b) = (r.width(), r.bands());
    let mut out = vec![T::default(); tile * tile * b];
    for (band, plane) in r.planes().iter().enumerate() {
        for (y, row) in plane.chunks_exact(w).enumerate() {
            for (x, &v) in row.iter().enumerate() {
                out[(y * tile + x) * b + band] = v;
            }
        }
    }
    out
}

/// TIFF's horizontal predictor: each sample minus the same band's sample to its left.
fn predict<T: Copy>(v: &mut [T], bands: usize, tile: usize, sub: fn(T, T) -> T) {
    for row in v.chunks_exact_mut(tile * bands) {
        for i in (bands..row.len()).rev() {
            row[i] = sub(row[i], row[i - bands]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aerorect_raster::Raster;

    fn image(size: ImageSize, bands: usize) -> Raster<u16> {
        let planes = (0..bands)
            .map(|b| {
                (0..size.pixels())
                    .map(|i| ((i * 7 + b * 1000) % 65_000) as u16)
                    .collect()
            })
            .collect();
        Raster::from_planes(size, planes).expect("planes")
    }

    #[test]
    fn tiles_written_one_by_one_read_back_as_the_image() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("t.tif");
        let size = ImageSize::new(70, 45);
        let full = image(size, 2);
        let mut asked = Vec::new();
        write_tiled_tiff::<IoError>(&path, size, 32, None, |c, r, s| {
            asked.push((c, r));
            let planes = (0..2)
                .map(|b| {
                    (0..s.pixels())
                        .map(|i| full.plane(b)[(r + i / s.width) * 70 + c + i % s.width])
                        .collect()
                })
                .collect();
            Ok(AnyRaster::U16(
                Raster::from_planes(s, planes).expect("tile"),
            ))
        })
        .expect("written");
        assert_eq!(
            asked,
            [(0, 0), (32, 0), (64, 0), (0, 32), (32, 32), (64, 32)]
        );
        let back = crate::read_image(&path).expect("read");
        let AnyRaster::U16(back) = back else {
            panic!("u16 expected")
        };
        assert_eq!(back.size(), size);
        assert_eq!(back.planes(), full.planes());
    }

    #[test]
    fn a_failing_source_leaves_nothing() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("t.tif");
        let r: Result<(), IoError> =
            write_tiled_tiff(&path, ImageSize::new(40, 40), 16, None, |c, _, s| {
                if c == 16 {
                    return Err(IoError::field("source", "boom"));
                }
                Ok(AnyRaster::U8(Raster::new(s, 1).expect("tile")))
            });
        assert!(r.expect_err("fails").to_string().contains("boom"));
        assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
    }
}
