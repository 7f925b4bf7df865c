//! TIFF through the `tiff` crate: 8/16-bit and f32 samples, 1-4 bands, strips or tiles,
//! uncompressed, LZW, Deflate or PackBits when reading; Deflate when writing.

use crate::error::IoError;
use crate::geotiff::GeoReference;
use crate::image_file::MAX_DECODED_BYTES;
use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, Raster, Sample};
use std::io::{Seek, Write};
use std::path::Path;
use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::encoder::{Compression, DeflateLevel, TiffEncoder, TiffValue, colortype};
use tiff::tags::{PhotometricInterpretation, SampleFormat, Tag};

pub(crate) fn read(path: &Path) -> Result<AnyRaster, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut limits = Limits::default();
    limits.decoding_buffer_size = MAX_DECODED_BYTES as usize;
    limits.intermediate_buffer_size = MAX_DECODED_BYTES as usize;
    let mut dec = Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| IoError::decode(path, e))?
        .with_limits(limits);
    let (w, h) = dec.dimensions().map_err(|e| IoError::decode(path, e))?;
    let bands = match dec.colortype().map_err(|e| IoError::decode(path, e))? {
        ColorType::Gray(_) => 1,
        ColorType::GrayA(_) => 2,
        ColorType::RGB(_) => 3,
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
    let size = ImageSize::new(w as usize, h as usize);
    let result = dec.read_image().map_err(|e| IoError::decode(path, e))?;
    let err = |e: aerorect_raster::RasterError| IoError::decode(path, e);
    Ok(match result {
        DecodingResult::U8(v) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        DecodingResult::U16(v) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        DecodingResult::F32(v) => {
            AnyRaster::F32(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        DecodingResult::F64(v) => {
            let v: Vec<f32> = v.iter().map(|&x| x as f32).collect();
            AnyRaster::F32(Raster::from_interleaved(size, bands, &v).map_err(err)?)
        }
        _ => {
            return Err(IoError::decode(
                path,
                "unsupported sample type (8/16-bit unsigned or float only)",
            ));
        }
    })
}

/// Gray + alpha, which the `tiff` crate's encoder does not define.
macro_rules! gray_alpha {
    ($name:ident, $inner:ty, $bits:expr, $fmt:expr) => {
        pub(crate) struct $name;
        impl colortype::ColorType for $name {
            type Inner = $inner;
            const TIFF_VALUE: PhotometricInterpretation = PhotometricInterpretation::BlackIsZero;
            const BITS_PER_SAMPLE: &'static [u16] = &[$bits, $bits];
            const SAMPLE_FORMAT: &'static [SampleFormat] = &[$fmt, $fmt];
            fn horizontal_predict(row: &[$inner], result: &mut Vec<$inner>) {
                result.extend_from_slice(row);
            }
        }
    };
}
gray_alpha!(GrayAlpha8, u8, 8, SampleFormat::Uint);
gray_alpha!(GrayAlpha16, u16, 16, SampleFormat::Uint);
gray_alpha!(GrayAlpha32Float, f32, 32, SampleFormat::IEEEFP);

pub(crate) fn write<W: Write + Seek>(
    w: W,
    raster: &AnyRaster,
    geo: Option<&GeoReference>,
) -> Result<(), String> {
    match raster {
        AnyRaster::U8(r) => match r.bands() {
            1 => put::<_, colortype::Gray8, u8>(w, r, geo),
            2 => put::<_, GrayAlpha8, u8>(w, r, geo),
            3 => put::<_, colortype::RGB8, u8>(w, r, geo),
            4 => put::<_, colortype::RGBA8, u8>(w, r, geo),
            b => Err(format!(
                "TIFF output holds 1 to 4 bands, this image has {b}"
            )),
        },
        AnyRaster::U16(r) => match r.bands() {
            1 => put::<_, colortype::Gray16, u16>(w, r, geo),
            2 => put::<_, GrayAlpha16, u16>(w, r, geo),
            3 => put::<_, colortype::RGB16, u16>(w, r, geo),
            4 => put::<_, colortype::RGBA16, u16>(w, r, geo),
            b => Err(format!(
                "TIFF output holds 1 to 4 bands, this image has {b}"
            )),
        },
        AnyRaster::F32(r) => match r.bands() {
            1 => put::<_, colortype::Gray32Float, f32>(w, r, geo),
            2 => put::<_, GrayAlpha32Float, f32>(w, r, geo),
            3 => put::<_, colortype::RGB32Float, f32>(w, r, geo),
            4 => put::<_, colortype::RGBA32Float, f32>(w, r, geo),
            b => Err(format!(
                "TIFF output holds 1 to 4 bands, this image has {b}"
            )),
        },
    }
}

fn put<W, C, T>(w: W, r: &Raster<T>, geo: Option<&GeoReference>) -> Result<(), String>
where
    W: Write + Seek,
    C: colortype::ColorType<Inner = T>,
    T: Sample,
    [T]: TiffValue,
{
    let mut enc = TiffEncoder::new(w)
        .map_err(|e| e.to_string())?
        .with_compression(Compression::Deflate(DeflateLevel::Fast));
    let (width, height) = (r.width() as u32, r.height() as u32);
    let mut img = enc
        .new_image::<C>(width, height)
        .map_err(|e| e.to_string())?;
    if r.bands() == 2 || r.bands() == 4 {
        // The last band is unassociated alpha (ExtraSamples = 2).
        img.encoder()
            .write_tag(Tag::ExtraSamples, &[2u16][..])
            .map_err(|e| e.to_string())?;
    }
    if let Some(g) = geo {
        g.write_tags(img.encoder()).map_err(|e| e.to_string())?;
    }
    // One interleaved copy of the image: the tiff crate (0.11) compresses only in `write_data`;
    // its `write_strip` would write raw strips under a Deflate tag.
    img.write_data(&r.to_interleaved())
        .map_err(|e| e.to_string())
}
