//! TIFF reading through the `tiff` crate: 1-4 bands, strips or tiles, TIFF or BigTIFF; any
//! integer or float sample type, uncompressed, LZW, Deflate, PackBits or JPEG (YCbCr turned
//! into RGB). Writing is `strip_tiff`'s (8/16-bit and f32 with Deflate).

use crate::error::IoError;
use crate::image_limits::{MAX_DECODED_BYTES, check_claimed_bytes, check_image_pixels};
use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, Raster};
use std::path::Path;
use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits};

/// A TIFF's first image: size, bands and interleaved samples as the `tiff` crate decoded them,
/// YCbCr already turned into RGB.
pub(crate) struct Decoded {
    pub size: ImageSize,
    pub bands: usize,
    pub samples: DecodingResult,
}

/// Decodes the first image of a TIFF or BigTIFF (any compression the `tiff` crate reads, JPEG
/// included).
pub(crate) fn decode(path: &Path) -> Result<Decoded, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut limits = Limits::default();
    limits.decoding_buffer_size = MAX_DECODED_BYTES as usize;
    limits.intermediate_buffer_size = MAX_DECODED_BYTES as usize;
    let mut dec = Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| IoError::decode(path, e))?
        .with_limits(limits);
    let (w, h) = dec.dimensions().map_err(|e| IoError::decode(path, e))?;
    let colour = dec.colortype().map_err(|e| IoError::decode(path, e))?;
    let bands = match colour {
        ColorType::Gray(_) => 1,
        ColorType::GrayA(_) => 2,
        ColorType::RGB(_) | ColorType::YCbCr(8) => 3,
        ColorType::RGBA(_) => 4,
        ColorType::Multiband { num_samples, .. } if (1..=4).contains(&num_samples) => {
            num_samples as usize
        }
        other => {
            return Err(IoError::decode(
                path,
                format!("unsupported colour layout {other:?}"),
            ));
        }
    };
    check_bit_depth(path, &colour)?;
    check_claimed_size(path, w, h, bands, &colour)?;
    let size = ImageSize::new(w as usize, h as usize);
    let mut samples = dec.read_image().map_err(|e| read_error(path, e))?;
    if colour == ColorType::YCbCr(8)
        && let DecodingResult::U8(v) = &mut samples
    {
        ycbcr_to_rgb(v);
    }
    Ok(Decoded {
        size,
        bands,
        samples,
    })
}

/// Refuses sample sizes other than whole bytes (1-bit bilevel, 4-bit palette, 12-bit), which
/// the decoder would hand back packed, not one value per sample.
fn check_bit_depth(path: &Path, colour: &ColorType) -> Result<(), IoError> {
    let bits = match *colour {
        ColorType::Gray(b)
        | ColorType::GrayA(b)
        | ColorType::RGB(b)
        | ColorType::RGBA(b)
        | ColorType::YCbCr(b) => b,
        ColorType::Multiband { bit_depth, .. } => bit_depth,
        _ => 8,
    };
    if matches!(bits, 8 | 16 | 32 | 64) {
        return Ok(());
    }
    Err(IoError::decode(
        path,
        format!("unsupported {bits}-bit samples: only 8, 16, 32 and 64-bit TIFFs are read"),
    ))
}

/// The decoder's error in words: a read past the end is a truncated file.
fn read_error(path: &Path, e: tiff::TiffError) -> IoError {
    match &e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            IoError::decode(
                path,
                "the file is truncated: its image data ends before the size its header states",
            )
        }
        _ => IoError::decode(path, e),
    }
}

/// Refuses a header that claims more samples than the file could hold, before the decoder
/// allocates the whole image (see [`check_claimed_bytes`]).
fn check_claimed_size(
    path: &Path,
    w: u32,
    h: u32,
    bands: usize,
    colour: &ColorType,
) -> Result<(), IoError> {
    let bits = match *colour {
        ColorType::Gray(b)
        | ColorType::GrayA(b)
        | ColorType::RGB(b)
        | ColorType::RGBA(b)
        | ColorType::YCbCr(b) => u64::from(b),
        ColorType::Multiband { bit_depth, .. } => u64::from(bit_depth),
        _ => 8,
    };
    let claimed = u64::from(w) * u64::from(h) * bands as u64 * bits.div_ceil(8);
    let what = format!("{w} x {h} pixels of {bands} x {bits} bits");
    check_claimed_bytes(path, &what, claimed)?;
    check_image_pixels(path, u64::from(w), u64::from(h))
}

/// JFIF's YCbCr -> RGB (ITU-R BT.601 full range, ReferenceBlackWhite at its default), in place.
fn ycbcr_to_rgb(v: &mut [u8]) {
    let to8 = |x: f32| x.round().clamp(0.0, 255.0) as u8;
    for px in v.chunks_exact_mut(3) {
        let y = f32::from(px[0]);
        let cb = f32::from(px[1]) - 128.0;
        let cr = f32::from(px[2]) - 128.0;
        px[0] = to8(y + 1.402 * cr);
        px[1] = to8(y - 0.344_136 * cb - 0.714_136 * cr);
        px[2] = to8(y + 1.772 * cb);
    }
}

/// Every sample as f32 (signed and wider integers, f16 and f64 included).
pub(crate) fn samples_f32(samples: DecodingResult) -> Vec<f32> {
    match samples {
        DecodingResult::U8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::U64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f32::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::I64(v) => v.into_iter().map(|x| x as f32).collect(),
        DecodingResult::F16(v) => v.into_iter().map(|x| x.to_f32()).collect(),
        DecodingResult::F32(v) => v,
        DecodingResult::F64(v) => v.into_iter().map(|x| x as f32).collect(),
    }
}

/// A TIFF image: 8/16-bit unsigned samples kept, every other sample type as f32.
pub(crate) fn read(path: &Path) -> Result<AnyRaster, IoError> {
    let Decoded {
        size,
        bands,
        samples,
    } = decode(path)?;
    let err = |e: aerorect_raster::RasterError| IoError::decode(path, e);
    Ok(match samples {
        DecodingResult::U8(v) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        DecodingResult::U16(v) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        other => {
            let v = samples_f32(other);
            AnyRaster::F32(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
    })
}
