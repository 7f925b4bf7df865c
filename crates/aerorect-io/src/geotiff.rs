//! GeoTIFF georeferencing written by hand with the `tiff` crate's tags (33550
//! ModelPixelScale, 33922 ModelTiepoint or 34264 ModelTransformation, 34735-34737 GeoKeys,
//! 42113 GDAL_NODATA), a world file beside PNG output, and the same tags read back.
//!
//! Convention: PixelIsArea; `top_left` is the outer corner of pixel (0, 0), so on a north-up
//! grid the centre of pixel (c, r) is (x0 + (c + 0.5) sx, y0 - (r + 0.5) sy).

use crate::error::{CodecError, IoError};
use crate::geokeys::{self, GEO_ASCII_PARAMS, GEO_DOUBLE_PARAMS, GEO_KEY_DIRECTORY};
use aerorect_geo::Crs;
use serde::Serialize;
use std::path::{Path, PathBuf};
use tiff::tags::Tag;

pub(crate) const MODEL_PIXEL_SCALE: u16 = 33550;
pub(crate) const MODEL_TIEPOINT: u16 = 33922;
pub(crate) const MODEL_TRANSFORMATION: u16 = 34264;
pub(crate) const GDAL_NODATA: u16 = 42113;

/// An image's grid on the ground: GDAL's geotransform in its parts, and the CRS.
///
/// Ground (x, y) of the outer corner of pixel (c, r):
/// x = top_left[0] + c pixel_size[0] + r rotation[0], y = top_left[1] + c rotation[1] - r pixel_size[1].
/// A north-up grid has `rotation` zero and both `pixel_size` > 0 (aerorect writes only those).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GeoReference {
    pub crs: Crs,
    /// Ground size of a pixel along x (east) and y (north): GDAL's gt[1] and -gt[5].
    pub pixel_size: [f64; 2],
    /// The outer corner of pixel (0, 0): easting, northing.
    pub top_left: [f64; 2],
    /// GDAL's gt[2] and gt[4] (0 for a north-up grid).
    pub rotation: [f64; 2],
    pub nodata: Option<f64>,
}

impl GeoReference {
    /// The ground position of pixel centre (c, r).
    pub fn ground_of_pixel(&self, c: f64, r: f64) -> [f64; 2] {
        let g = self.geotransform();
        let (c, r) = (c + 0.5, r + 0.5);
        [g[0] + c * g[1] + r * g[2], g[3] + c * g[4] + r * g[5]]
    }

    /// The pixel-centre coordinates (c, r) of a ground position; `None` for a degenerate grid.
    pub fn pixel_of_ground(&self, x: f64, y: f64) -> Option<[f64; 2]> {
        let g = self.geotransform();
        let det = g[1] * g[5] - g[2] * g[4];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (dx, dy) = (x - g[0], y - g[3]);
        let c = (g[5] * dx - g[2] * dy) / det;
        let r = (g[1] * dy - g[4] * dx) / det;
        Some([c - 0.5, r - 0.5])
    }

    /// GDAL's geotransform (x0, sx, rx, y0, ry, -sy).
    pub fn geotransform(&self) -> [f64; 6] {
        [
            self.top_left[0],
            self.pixel_size[0],
            self.rotation[0],
            self.top_left[1],
            self.rotation[1],
            -self.pixel_size[1],
        ]
    }

    /// The grid of GDAL's geotransform `gt`.
    pub fn from_geotransform(crs: Crs, gt: [f64; 6], nodata: Option<f64>) -> Self {
        GeoReference {
            crs,
            pixel_size: [gt[1], -gt[5]],
            top_left: [gt[0], gt[3]],
            rotation: [gt[2], gt[4]],
            nodata,
        }
    }

    fn is_north_up(&self) -> bool {
        self.rotation == [0.0, 0.0] && self.pixel_size[0] > 0.0 && self.pixel_size[1] > 0.0
    }

    /// The GeoTIFF tags of this grid, in tag order: the scale and tie point (north-up) or the
    /// transformation, the GeoKeys and GDAL_NODATA. Written by the `tiff` crate's encoder
    /// ([`Self::write_tags`]) and by the cloud-optimised writer's own IFDs (`cog`).
    pub(crate) fn tags(&self) -> Result<Vec<(u16, GeoTagValue)>, CodecError> {
        let (dir, doubles, ascii) = geokeys::encode(&self.crs)?;
        let mut tags = Vec::new();
        if self.is_north_up() {
            let scale = vec![self.pixel_size[0], self.pixel_size[1], 0.0];
            let tie = vec![0.0, 0.0, 0.0, self.top_left[0], self.top_left[1], 0.0];
            tags.push((MODEL_PIXEL_SCALE, GeoTagValue::Doubles(scale)));
            tags.push((MODEL_TIEPOINT, GeoTagValue::Doubles(tie)));
        } else {
            let g = self.geotransform();
            let m = vec![
                g[1], g[2], 0.0, g[0], g[4], g[5], 0.0, g[3], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                1.0,
            ];
            tags.push((MODEL_TRANSFORMATION, GeoTagValue::Doubles(m)));
        }
        tags.push((GEO_KEY_DIRECTORY, GeoTagValue::Shorts(dir)));
        if !doubles.is_empty() {
            tags.push((GEO_DOUBLE_PARAMS, GeoTagValue::Doubles(doubles)));
        }
        if !ascii.is_empty() {
            tags.push((GEO_ASCII_PARAMS, GeoTagValue::Ascii(ascii)));
        }
        if let Some(nd) = self.nodata {
            tags.push((GDAL_NODATA, GeoTagValue::Ascii(format!("{nd}"))));
        }
        Ok(tags)
    }

    pub(crate) fn write_tags<W: std::io::Write + std::io::Seek, K: tiff::encoder::TiffKind>(
        &self,
        enc: &mut tiff::encoder::DirectoryEncoder<'_, W, K>,
    ) -> Result<(), CodecError> {
        for (tag, value) in self.tags()? {
            let t = Tag::Unknown(tag);
            match &value {
                GeoTagValue::Doubles(v) => enc.write_tag(t, &v[..]),
                GeoTagValue::Shorts(v) => enc.write_tag(t, &v[..]),
                GeoTagValue::Ascii(s) => enc.write_tag(t, s.as_str()),
            }?;
        }
        Ok(())
    }
}

/// The value of one GeoTIFF tag.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum GeoTagValue {
    Doubles(Vec<f64>),
    Shorts(Vec<u16>),
    Ascii(String),
}

/// The world file beside an image: `out.png` -> `out.pgw` (also `.tfw`, `.jgw`).
pub fn world_file_path(image: &Path) -> PathBuf {
    let ext = image
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let w = match ext.as_str() {
        "png" => "pgw",
        "tif" | "tiff" => "tfw",
        "jpg" | "jpeg" => "jgw",
        _ => "wld",
    };
    image.with_extension(w)
}

/// Writes the six-line world file (gt[1], gt[4], gt[2], gt[5], centre of the top-left pixel).
pub fn write_world_file(image: &Path, geo: &GeoReference) -> Result<PathBuf, IoError> {
    let path = world_file_path(image);
    let text = world_file_text(geo);
    crate::write_atomically(&path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())
            .map_err(|e| IoError::io(&path, e))
    })?;
    Ok(path)
}

/// The world file's text; the centre to 1e-10 (GDAL's `%.10f`), so that a frame read back
/// lands on its grid to far better than the 1e-6 pixel `overlap` requires.
pub(crate) fn world_file_text(geo: &GeoReference) -> String {
    let g = geo.geotransform();
    let c = geo.ground_of_pixel(0.0, 0.0);
    format!(
        "{:.12}\n{:.12}\n{:.12}\n{:.12}\n{:.10}\n{:.10}\n",
        g[1], g[4], g[2], g[5], c[0], c[1]
    )
}

/// The georeferencing of a GeoTIFF: CRS from its GeoKeys (EPSG code, GDAL's user-defined
/// projection keys, or a WKT citation), geotransform from ModelTransformation or
/// ModelTiepoint + ModelPixelScale (PixelIsPoint shifted by half a pixel, as GDAL does), and
/// GDAL_NODATA. `None` for a TIFF without a GeoKeyDirectory. Any other image (a PNG of
/// `batch --format png`) is read through its sidecars: [`read_world_georeference`].
pub fn read_georeference(path: &Path) -> Result<Option<GeoReference>, IoError> {
    let mut magic = [0u8; 4];
    let mut file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let n = std::io::Read::read(&mut file, &mut magic).map_err(|e| IoError::io(path, e))?;
    if n < 4 || !(magic[..2] == *b"II" || magic[..2] == *b"MM") {
        return read_world_georeference(path);
    }
    std::io::Seek::rewind(&mut file).map_err(|e| IoError::io(path, e))?;
    let mut dec = tiff::decoder::Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| IoError::decode(path, e))?;
    let Some(dir) = tag_u16s(&mut dec, path, GEO_KEY_DIRECTORY)? else {
        return Ok(None);
    };
    let doubles = tag_f64s(&mut dec, path, GEO_DOUBLE_PARAMS)?.unwrap_or_default();
    let ascii = tag_ascii(&mut dec, path, GEO_ASCII_PARAMS)?.unwrap_or_default();
    let keys = geokeys::GeoKeys::parse(&dir, &doubles, &ascii)
        .and_then(|k| Ok((k.crs()?, k.pixel_is_point())))
        .map_err(|error| IoError::GeoKeys {
            source_name: path.display().to_string(),
            error: Box::new(error),
        })?;
    let (crs, pixel_is_point) = keys;
    let mut gt = geotransform(&mut dec, path)?;
    if pixel_is_point {
        gt[0] -= 0.5 * (gt[1] + gt[2]);
        gt[3] -= 0.5 * (gt[4] + gt[5]);
    }
    let nodata = match tag_ascii(&mut dec, path, GDAL_NODATA)? {
        None => None,
        Some(t) => {
            let t = t.trim_matches(char::from(0)).trim();
            Some(t.parse::<f64>().map_err(|_| {
                IoError::field(
                    path.display(),
                    format!("GDAL_NODATA (42113) = '{t}' is not a number"),
                )
            })?)
        }
    };
    Ok(Some(GeoReference::from_geotransform(crs, gt, nodata)))
}

/// The georeferencing of an image from its world file (`.pgw`, `.tfw`, `.jgw` or `.wld`: the
/// six lines gt[1], gt[4], gt[2], gt[5] and the centre of pixel (0, 0)) and its CRS from the
/// `.prj` beside it, else the `<SRS>` of its `.aux.xml` (GDAL's). `None` without a world file;
/// a world file without a CRS is an error naming both sidecars.
pub fn read_world_georeference(path: &Path) -> Result<Option<GeoReference>, IoError> {
    let world = world_file_path(path);
    let Ok(text) = std::fs::read_to_string(&world) else {
        return Ok(None);
    };
    let values: Vec<f64> = text
        .split_whitespace()
        .map(|v| v.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| IoError::field(world.display(), format!("not six numbers: {e}")))?;
    let &[a, d, b, e, c, f] = values.as_slice() else {
        return Err(IoError::field(
            world.display(),
            format!("{} values, a world file has six", values.len()),
        ));
    };
    let prj = path.with_extension("prj");
    let mut aux = path.as_os_str().to_owned();
    aux.push(".aux.xml");
    let aux = std::path::PathBuf::from(aux);
    let crs = match std::fs::read_to_string(&prj) {
        Ok(wkt) => Crs::parse(&wkt).map_err(|e| IoError::field(prj.display(), e))?,
        Err(_) => {
            let srs = std::fs::read_to_string(&aux).ok().and_then(|x| aux_srs(&x));
            let srs = srs.ok_or_else(|| {
                IoError::field(
                    world.display(),
                    format!(
                        "a world file without a CRS: neither {} nor an <SRS> in {}",
                        prj.display(),
                        aux.display()
                    ),
                )
            })?;
            Crs::parse(&srs).map_err(|e| IoError::field(aux.display(), e))?
        }
    };
    // The world file names the centre of pixel (0, 0); the geotransform its outer corner.
    let gt = [c - 0.5 * (a + b), a, b, f - 0.5 * (d + e), d, e];
    Ok(Some(GeoReference::from_geotransform(crs, gt, None)))
}

/// The text of the `<SRS>` element of a GDAL `.aux.xml`, unescaped.
fn aux_srs(xml: &str) -> Option<String> {
    let doc = roxmltree::Document::parse(xml).ok()?;
    let srs = doc.descendants().find(|n| n.has_tag_name("SRS"))?;
    srs.text().map(str::to_string)
}

type Dec = tiff::decoder::Decoder<std::io::BufReader<std::fs::File>>;

/// GDAL's geotransform from ModelTransformation, else ModelTiepoint + ModelPixelScale.
fn geotransform(dec: &mut Dec, path: &Path) -> Result<[f64; 6], IoError> {
    if let Some(m) = tag_f64s(dec, path, MODEL_TRANSFORMATION)? {
        if m.len() < 8 {
            return Err(IoError::field(
                path.display(),
                format!("ModelTransformation (34264) has {} values, not 16", m.len()),
            ));
        }
        return Ok([m[3], m[0], m[1], m[7], m[4], m[5]]);
    }
    let scale = tag_f64s(dec, path, MODEL_PIXEL_SCALE)?.unwrap_or_default();
    let tie = tag_f64s(dec, path, MODEL_TIEPOINT)?.unwrap_or_default();
    if scale.len() < 2 || tie.len() < 6 {
        return Err(IoError::field(
            path.display(),
            "no ModelTransformation (34264), and ModelPixelScale (33550) or ModelTiepoint (33922) is missing or short",
        ));
    }
    let (sx, sy) = (scale[0], scale[1]);
    Ok([
        tie[3] - tie[0] * sx,
        sx,
        0.0,
        tie[4] + tie[1] * sy,
        0.0,
        -sy,
    ])
}

fn tag_f64s(dec: &mut Dec, path: &Path, tag: u16) -> Result<Option<Vec<f64>>, IoError> {
    let t = Tag::Unknown(tag);
    match dec.find_tag(t).map_err(|e| IoError::decode(path, e))? {
        None => Ok(None),
        Some(_) => dec
            .get_tag_f64_vec(t)
            .map(Some)
            .map_err(|e| IoError::decode(path, e)),
    }
}

fn tag_u16s(dec: &mut Dec, path: &Path, tag: u16) -> Result<Option<Vec<u16>>, IoError> {
    let t = Tag::Unknown(tag);
    match dec.find_tag(t).map_err(|e| IoError::decode(path, e))? {
        None => Ok(None),
        Some(_) => dec
            .get_tag_u16_vec(t)
            .map(Some)
            .map_err(|e| IoError::decode(path, e)),
    }
}

fn tag_ascii(dec: &mut Dec, path: &Path, tag: u16) -> Result<Option<String>, IoError> {
    let t = Tag::Unknown(tag);
    match dec.find_tag(t).map_err(|e| IoError::decode(path, e))? {
        None => Ok(None),
        Some(_) => dec
            .get_tag_ascii_string(t)
            .map(Some)
            .map_err(|e| IoError::decode(path, e)),
    }
}
