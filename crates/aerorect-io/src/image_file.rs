//! Reading and writing images; the format is found from the file's first bytes when reading
//! and from the extension when writing (.tif/.tiff, .png).

use crate::error::{CodecError, IoError};
use crate::image_limits::{check_claimed_bytes, check_image_pixels};
use crate::staged::StagedOutputs;
use crate::tiff_file;
use aerorect_core::ImageSize;
use aerorect_raster::{AnyRaster, Raster};
use image::{DynamicImage, ImageReader};
use std::io::{BufWriter, Read, Write};
use std::path::{Path, PathBuf};

pub use crate::image_limits::{
    DEFAULT_MAX_IMAGE_PIXELS, MAX_DECODED_BYTES, max_image_pixels, set_max_image_pixels,
};

/// Reads a PNG, JPEG or TIFF image (8/16-bit integer or 32-bit float, 1-4 bands).
pub fn read_image(path: &Path) -> Result<AnyRaster, IoError> {
    let mut magic = [0u8; 4];
    let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let n = f.read(&mut magic).map_err(|e| IoError::io(path, e))?;
    if n >= 4
        && (magic == *b"II*\0" || magic == *b"MM\0*" || magic == *b"II+\0" || magic == *b"MM\0+")
    {
        return tiff_file::read(path);
    }
    if n >= 2 && magic[..2] == [0xFF, 0xD8] {
        check_jpeg_end(path)?;
    }
    read_with_image_crate(path)
}

/// The size of the PNG, JPEG or TIFF image at `path` from its header alone (no pixels are
/// decoded): what [`read_image`] would give as its raster's size, in a fraction of the time
/// (planning a flight needs every photo's size; decoding a 20 Mpx JPEG for it took 0.2-0.3 s).
/// A file whose pixels are damaged is not found out here but when it is read.
pub fn read_image_size(path: &Path) -> Result<ImageSize, IoError> {
    let mut magic = [0u8; 4];
    let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let n = f.read(&mut magic).map_err(|e| IoError::io(path, e))?;
    let (w, h) = if n >= 4
        && (magic == *b"II*\0" || magic == *b"MM\0*" || magic == *b"II+\0" || magic == *b"MM\0+")
    {
        let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
        tiff::decoder::Decoder::new(std::io::BufReader::new(file))
            .and_then(|mut d| d.dimensions())
            .map_err(|e| IoError::decode(path, e))?
    } else {
        let reader = ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| IoError::io(path, e))?;
        if reader.format().is_none() {
            return Err(IoError::decode(path, "not a PNG, JPEG or TIFF file"));
        }
        reader
            .into_dimensions()
            .map_err(|e| IoError::decode(path, e))?
    };
    check_image_pixels(path, u64::from(w), u64::from(h))?;
    Ok(ImageSize::new(w as usize, h as usize))
}

/// The JPEG decoder fills a cut-off file with gray; refuse one without an end-of-image marker
/// (FF D9) in its last KiB instead.
fn check_jpeg_end(path: &Path) -> Result<(), IoError> {
    use std::io::{Seek, SeekFrom};
    let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let len = f.metadata().map_err(|e| IoError::io(path, e))?.len();
    let tail_len = len.min(1024);
    f.seek(SeekFrom::Start(len - tail_len))
        .map_err(|e| IoError::io(path, e))?;
    let mut tail = vec![0u8; tail_len as usize];
    f.read_exact(&mut tail).map_err(|e| IoError::io(path, e))?;
    if tail.windows(2).any(|w| w == [0xFF, 0xD9]) {
        Ok(())
    } else {
        Err(IoError::decode(
            path,
            "truncated JPEG: no end-of-image marker",
        ))
    }
}

/// Decodes a PNG or JPEG image held in memory (the demo's embedded scene); `name` is for messages.
pub fn decode_image_bytes(bytes: &[u8], name: &str) -> Result<AnyRaster, IoError> {
    let img = image::load_from_memory(bytes).map_err(|e| IoError::decode(Path::new(name), e))?;
    raster_from_dynamic(img).map_err(|e| IoError::decode(Path::new(name), e))
}

fn read_with_image_crate(path: &Path) -> Result<AnyRaster, IoError> {
    let mut reader = ImageReader::open(path).map_err(|e| IoError::io(path, e))?;
    reader = reader
        .with_guessed_format()
        .map_err(|e| IoError::io(path, e))?;
    if reader.format().is_none() {
        return Err(IoError::decode(path, "not a PNG, JPEG or TIFF file"));
    }
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_DECODED_BYTES);
    reader.limits(limits);
    let decoder = reader
        .into_decoder()
        .map_err(|e| IoError::decode(path, e))?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    let claimed = image::ImageDecoder::total_bytes(&decoder);
    check_claimed_bytes(path, &format!("{w} x {h} pixels"), claimed)?;
    check_image_pixels(path, u64::from(w), u64::from(h))?;
    let colour = image::ImageDecoder::color_type(&decoder);
    let bands = usize::from(colour.channel_count());
    let eight_bit = usize::from(colour.bytes_per_pixel()) == bands;
    if eight_bit && claimed <= REUSED_DECODE_MAX_BYTES {
        let size = ImageSize::new(w as usize, h as usize);
        let mut buf = decode_buffer(claimed as usize);
        let read = image::ImageDecoder::read_image(decoder, &mut buf)
            .map_err(|e| IoError::decode(path, e))
            .and_then(|()| {
                Raster::from_interleaved(size, bands, &buf)
                    .map(AnyRaster::U8)
                    .map_err(|e| IoError::decode(path, CodecError::from(e)))
            });
        give_back(buf);
        return read;
    }
    let img = DynamicImage::from_decoder(decoder).map_err(|e| IoError::decode(path, e))?;
    raster_from_dynamic(img).map_err(|e| IoError::decode(path, e))
}

/// The largest 8-bit image (bytes) decoded into a kept buffer ([`decode_buffer`]): a 20-Mpx
/// RGB photo is 60 MB. Larger ones get a buffer of their own.
const REUSED_DECODE_MAX_BYTES: u64 = 128 << 20;

/// The most buffers kept for decoding (each at most [`REUSED_DECODE_MAX_BYTES`]): as many as
/// threads decode at once on a small machine; more threads allocate their own.
const KEPT_DECODE_BUFFERS: usize = 4;

/// Buffers 8-bit images were decoded into, kept for the next: a raster's planes are copied out
/// of one. A fresh buffer per photo was a fresh mapping (over glibc's 32 MB threshold), its
/// first touch a page fault per 4 KiB: on the snowpeak flight (16-Mpx photos) a fifth of the
/// run's page faults.
static DECODE_BUFFERS: std::sync::Mutex<Vec<Vec<u8>>> = std::sync::Mutex::new(Vec::new());

/// A buffer of `n` bytes, a kept one where there is one (its contents are not cleared).
fn decode_buffer(n: usize) -> Vec<u8> {
    let kept = DECODE_BUFFERS.lock().ok().and_then(|mut b| b.pop());
    let mut buf = kept.unwrap_or_default();
    buf.resize(n, 0);
    buf
}

/// Keeps `buf` for the next decode, within [`KEPT_DECODE_BUFFERS`].
fn give_back(buf: Vec<u8>) {
    if let Ok(mut kept) = DECODE_BUFFERS.lock()
        && kept.len() < KEPT_DECODE_BUFFERS
    {
        kept.push(buf);
    }
}

/// Decodes the header of a PNG or JPEG file (its size and layout), not its pixels.
pub(crate) fn check_header(path: &Path) -> Result<(), IoError> {
    let reader = ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| IoError::io(path, e))?;
    reader
        .into_decoder()
        .map(|_| ())
        .map_err(|e| IoError::decode(path, e))
}

fn raster_from_dynamic(img: DynamicImage) -> Result<AnyRaster, CodecError> {
    let size = ImageSize::new(img.width() as usize, img.height() as usize);
    let bands = img.color().channel_count() as usize;
    let err = CodecError::from;
    Ok(match img {
        DynamicImage::ImageLuma8(b) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageLumaA8(b) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgb8(b) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgba8(b) => {
            AnyRaster::U8(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageLuma16(b) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageLumaA16(b) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgb16(b) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgba16(b) => {
            AnyRaster::U16(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgb32F(b) => {
            AnyRaster::F32(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        DynamicImage::ImageRgba32F(b) => {
            AnyRaster::F32(Raster::from_interleaved(size, bands, b.as_raw()).map_err(err)?)
        }
        other => return Err(format!("unsupported pixel layout {:?}", other.color()).into()),
    })
}

/// Writes `raster` to `path` (TIFF or PNG by extension), keeping the bit depth; atomically.
pub fn write_image(path: &Path, raster: &AnyRaster) -> Result<(), IoError> {
    write_image_geo(path, raster, None)
}

/// Writes `raster` like [`write_image`]; with `geo`, a .tif becomes a GeoTIFF, and a .png gets
/// a world file, a `.prj` (OGC WKT) and a `.png.aux.xml` (the SRS, which GDAL reads for PNG)
/// beside it. The image and its sidecars are written to temporary files first and renamed
/// together: when one fails, none is left.
pub fn write_image_geo(
    path: &Path,
    raster: &AnyRaster,
    geo: Option<&crate::geotiff::GeoReference>,
) -> Result<(), IoError> {
    let mut staged = StagedOutputs::new();
    staged.image(path, raster, geo)?;
    staged.commit()
}

impl StagedOutputs {
    /// Stages an image like [`write_image_geo`] (with its sidecars), to land with the other
    /// staged outputs.
    pub fn image(
        &mut self,
        path: &Path,
        raster: &AnyRaster,
        geo: Option<&crate::geotiff::GeoReference>,
    ) -> Result<(), IoError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("tif") | Some("tiff") => self.file(path, |w| {
                crate::strip_tiff::write(w, raster, geo, None).map_err(|e| IoError::encode(path, e))
            }),
            Some("png") => {
                let sidecars = match geo {
                    Some(g) => png_sidecars(path, g)?,
                    None => Vec::new(),
                };
                self.file(path, |w| {
                    write_png(w, raster).map_err(|e| IoError::encode(path, e))
                })?;
                for (p, text) in &sidecars {
                    self.text(p, text)?;
                }
                Ok(())
            }
            _ => Err(IoError::encode(
                path,
                "unknown output format: use a .tif, .tiff or .png file name",
            )),
        }
    }
}

/// Every file an image write makes: the image, and for a georeferenced PNG its world file,
/// `.prj` and `.png.aux.xml`.
pub fn image_files(path: &Path, georeferenced: bool) -> Vec<PathBuf> {
    let png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let mut files = vec![path.to_path_buf()];
    if png && georeferenced {
        files.extend(png_sidecar_paths(path));
    }
    files
}

fn png_sidecar_paths(path: &Path) -> [PathBuf; 3] {
    let mut aux = path.as_os_str().to_owned();
    aux.push(".aux.xml");
    [
        crate::geotiff::world_file_path(path),
        path.with_extension("prj"),
        PathBuf::from(aux),
    ]
}

/// The world file, `.prj` and `.aux.xml` of a georeferenced PNG, with their text.
fn png_sidecars(
    path: &Path,
    geo: &crate::geotiff::GeoReference,
) -> Result<Vec<(PathBuf, String)>, IoError> {
    let wkt = geo
        .crs
        .to_wkt()
        .map_err(|e| IoError::encode(path, CodecError::NoWkt(e)))?;
    let xml = format!(
        "<PAMDataset>\n  <SRS>{}</SRS>\n</PAMDataset>\n",
        xml_escape(&wkt)
    );
    let [world, prj, aux] = png_sidecar_paths(path);
    Ok(vec![
        (world, crate::geotiff::world_file_text(geo)),
        (prj, wkt),
        (aux, xml),
    ])
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn write_png<W: Write>(w: W, raster: &AnyRaster) -> Result<(), CodecError> {
    use image::{ExtendedColorType, ImageEncoder, codecs::png::PngEncoder};
    let size = raster.size();
    let (bytes, color): (Vec<u8>, ExtendedColorType) = match (raster, raster.bands()) {
        (AnyRaster::U8(r), 1) => (r.to_interleaved(), ExtendedColorType::L8),
        (AnyRaster::U8(r), 2) => (r.to_interleaved(), ExtendedColorType::La8),
        (AnyRaster::U8(r), 3) => (r.to_interleaved(), ExtendedColorType::Rgb8),
        (AnyRaster::U8(r), 4) => (r.to_interleaved(), ExtendedColorType::Rgba8),
        (AnyRaster::U16(r), b @ 1..=4) => {
            // PngEncoder takes 16-bit samples as native-endian bytes.
            let bytes = r
                .to_interleaved()
                .iter()
                .flat_map(|v| v.to_ne_bytes())
                .collect();
            let c = [
                ExtendedColorType::L16,
                ExtendedColorType::La16,
                ExtendedColorType::Rgb16,
                ExtendedColorType::Rgba16,
            ][b - 1];
            (bytes, c)
        }
        (AnyRaster::F32(_), _) => {
            return Err("PNG cannot hold 32-bit float samples: write a .tif".into());
        }
        (_, b) => return Err(format!("PNG holds 1 to 4 bands, this image has {b}").into()),
    };
    PngEncoder::new(w)
        .write_image(&bytes, size.width as u32, size.height as u32, color)
        .map_err(CodecError::from)
}

/// Writes through `write` into a temporary file beside `path`, then renames it into place.
/// On error the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&mut std::fs::File>) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let mut staged = StagedOutputs::new();
    staged.file(path, write)?;
    staged.commit()
}

/// True when `a` and `b` name the same file (both resolved; `b` may not exist yet).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (resolved_path(a), resolved_path(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// The absolute path `p` names with links resolved: the file's own when it exists, else its
/// folder's joined with the name; `None` when the folder does not exist either.
pub fn resolved_path(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let parent = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(p.file_name()?))
}

/// A PNG of `raster` scaled to fit `max_side` (8-bit: 16-bit samples are shifted, float
/// samples clamped to [0, 1]); for report thumbnails. `name` says what it is a thumbnail of,
/// for messages.
pub fn thumbnail_png(raster: &AnyRaster, max_side: u32, name: &str) -> Result<Vec<u8>, IoError> {
    thumbnail(raster, max_side).map_err(|reason| IoError::Encode {
        source_name: format!("{name}: thumbnail"),
        reason,
    })
}

fn thumbnail(raster: &AnyRaster, max_side: u32) -> Result<Vec<u8>, CodecError> {
    use image::{DynamicImage, ImageBuffer, ImageFormat, Luma, Rgb, Rgba};
    let size = raster.size();
    let to8: Vec<u8> = match raster {
        AnyRaster::U8(r) => r.to_interleaved(),
        AnyRaster::U16(r) => r.to_interleaved().iter().map(|v| (v >> 8) as u8).collect(),
        AnyRaster::F32(r) => r
            .to_interleaved()
            .iter()
            .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect(),
    };
    let (w, h) = (size.width as u32, size.height as u32);
    let bad = || CodecError::from("buffer size mismatch");
    let img = match raster.bands() {
        1 => DynamicImage::ImageLuma8(
            ImageBuffer::<Luma<u8>, _>::from_raw(w, h, to8).ok_or_else(bad)?,
        ),
        3 => {
            DynamicImage::ImageRgb8(ImageBuffer::<Rgb<u8>, _>::from_raw(w, h, to8).ok_or_else(bad)?)
        }
        4 => DynamicImage::ImageRgba8(
            ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, to8).ok_or_else(bad)?,
        ),
        b => return Err(format!("{b} bands (1, 3 or 4 make a PNG)").into()),
    };
    let thumb = img.thumbnail(max_side, max_side);
    let mut out = std::io::Cursor::new(Vec::new());
    thumb.write_to(&mut out, ImageFormat::Png)?;
    Ok(out.into_inner())
}
