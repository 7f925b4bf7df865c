//! GeoTIFF georeferencing written by hand with the `tiff` crate's tags (33550
//! ModelPixelScale, 33922 ModelTiepoint, 34735 GeoKeyDirectory, 42113 GDAL_NODATA), a world
//! file beside PNG output, and the same tags read back.
//!
//! Convention: north-up grids, PixelIsArea; `top_left` is the outer corner of pixel (0, 0), so
//! the centre of pixel (c, r) is (x0 + (c + 0.5) sx, y0 - (r + 0.5) sy).

use crate::error::IoError;
use serde::Serialize;
use std::path::{Path, PathBuf};
use tiff::tags::Tag;

pub(crate) const MODEL_PIXEL_SCALE: u16 = 33550;
pub(crate) const MODEL_TIEPOINT: u16 = 33922;
pub(crate) const GEO_KEY_DIRECTORY: u16 = 34735;
pub(crate) const GDAL_NODATA: u16 = 42113;

/// A north-up grid in a projected CRS given by its EPSG code (metres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GeoReference {
    pub epsg: u16,
    /// Ground size of a pixel along x (east) and y (north), both > 0.
    pub pixel_size: [f64; 2],
    /// The outer corner of pixel (0, 0): easting, northing.
    pub top_left: [f64; 2],
    pub nodata: Option<f64>,
}

impl GeoReference {
    /// The ground position of pixel centre (c, r).
    pub fn ground_of_pixel(&self, c: f64, r: f64) -> [f64; 2] {
        [
            self.top_left[0] + (c + 0.5) * self.pixel_size[0],
            self.top_left[1] - (r + 0.5) * self.pixel_size[1],
        ]
    }

    /// GDAL's geotransform (x0, sx, 0, y0, 0, -sy).
    pub fn geotransform(&self) -> [f64; 6] {
        [
            self.top_left[0],
            self.pixel_size[0],
            0.0,
            self.top_left[1],
            0.0,
            -self.pixel_size[1],
        ]
    }

    /// The GeoKeyDirectory: projected, PixelIsArea, the EPSG code, metres.
    pub(crate) fn geo_keys(&self) -> Vec<u16> {
        vec![
            1, 1, 0, 4, // version 1.1.0, four keys
            1024, 0, 1, 1, // GTModelTypeGeoKey = ModelTypeProjected
            1025, 0, 1, 1, // GTRasterTypeGeoKey = RasterPixelIsArea
            3072, 0, 1, self.epsg, // ProjectedCSTypeGeoKey
            3076, 0, 1, 9001, // ProjLinearUnitsGeoKey = metre
        ]
    }

    pub(crate) fn write_tags<W: std::io::Write + std::io::Seek, K: tiff::encoder::TiffKind>(
        &self,
        enc: &mut tiff::encoder::DirectoryEncoder<'_, W, K>,
    ) -> tiff::TiffResult<()> {
        enc.write_tag(
            Tag::Unknown(MODEL_PIXEL_SCALE),
            &[self.pixel_size[0], self.pixel_size[1], 0.0][..],
        )?;
        enc.write_tag(
            Tag::Unknown(MODEL_TIEPOINT),
            &[0.0, 0.0, 0.0, self.top_left[0], self.top_left[1], 0.0][..],
        )?;
        enc.write_tag(Tag::Unknown(GEO_KEY_DIRECTORY), &self.geo_keys()[..])?;
        if let Some(nd) = self.nodata {
            enc.write_tag(Tag::Unknown(GDAL_NODATA), format!("{nd}").as_str())?;
        }
        Ok(())
    }
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

/// Writes the six-line world file (pixel size, rotations, centre of the top-left pixel).
pub fn write_world_file(image: &Path, geo: &GeoReference) -> Result<PathBuf, IoError> {
    let path = world_file_path(image);
    let c = geo.ground_of_pixel(0.0, 0.0);
    let text = format!(
        "{:.12}\n0\n0\n{:.12}\n{:.6}\n{:.6}\n",
        geo.pixel_size[0], -geo.pixel_size[1], c[0], c[1]
    );
    crate::write_atomically(&path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes())
            .map_err(|e| IoError::io(&path, e))
    })?;
    Ok(path)
}

/// The georeferencing of a GeoTIFF written as above; `None` for a TIFF without it.
pub fn read_georeference(path: &Path) -> Result<Option<GeoReference>, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut dec = tiff::decoder::Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| IoError::decode(path, e))?;
    let err = |e: tiff::TiffError| IoError::decode(path, e);
    if dec
        .find_tag(Tag::Unknown(GEO_KEY_DIRECTORY))
        .map_err(err)?
        .is_none()
    {
        return Ok(None);
    }
    let scale = dec
        .get_tag_f64_vec(Tag::Unknown(MODEL_PIXEL_SCALE))
        .map_err(err)?;
    let tie = dec
        .get_tag_f64_vec(Tag::Unknown(MODEL_TIEPOINT))
        .map_err(err)?;
    let keys = dec
        .get_tag_u16_vec(Tag::Unknown(GEO_KEY_DIRECTORY))
        .map_err(err)?;
    let nodata = match dec.find_tag(Tag::Unknown(GDAL_NODATA)).map_err(err)? {
        Some(_) => dec
            .get_tag_ascii_string(Tag::Unknown(GDAL_NODATA))
            .map_err(err)?
            .trim_matches(char::from(0))
            .trim()
            .parse::<f64>()
            .ok(),
        None => None,
    };
    let epsg = keys
        .chunks_exact(4)
        .skip(1)
        .find(|k| k[0] == 3072)
        .map(|k| k[3])
        .ok_or_else(|| {
            IoError::field(
                path.display(),
                "GeoKeyDirectory has no ProjectedCSTypeGeoKey",
            )
        })?;
    if scale.len() < 2 || tie.len() < 6 {
        return Err(IoError::field(
            path.display(),
            "short ModelPixelScale or ModelTiepoint",
        ));
    }
    Ok(Some(GeoReference {
        epsg,
        pixel_size: [scale[0], scale[1]],
        top_left: [tie[3] - tie[0] * scale[0], tie[4] + tie[1] * scale[1]],
        nodata,
    }))
}
