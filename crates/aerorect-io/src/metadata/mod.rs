//! Photo metadata: EXIF (kamadak-exif, from JPEG or TIFF), GDAL's `EXIF_*` metadata items in a
//! TIFF (tag 42112), and the XMP packet (roxmltree) from a JPEG's APP1 segment, a TIFF's tag
//! 700 or a GDAL metadata item, its tags matched by namespace URI: DJI's `drone-dji` (dji.rs),
//! senseFly's and Pix4D's body angles (body.rs).

mod body;
mod dji;
pub(crate) mod error;
mod exif_tags;
mod xmp;

pub use body::{BodyAngles, BodySchema, BodyTags, PIX4D_NS, SENSEFLY_NS, body_tags};
pub use dji::{DJI_NS, DjiTags, dji_number, dji_tags};
pub use xmp::{tags_in, xmp_number, xmp_packet, xmp_tags};

use crate::error::IoError;
pub use error::MetadataError;
use exif_tags::{fill_exif, fill_gdal_exif, gdal_metadata_items};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// What a photo says about its camera, position and attitude; every field is optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PhotoMetadata {
    pub make: Option<String>,
    pub model: Option<String>,
    /// EXIF PixelXDimension / PixelYDimension.
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// EXIF Orientation (1 = as stored).
    pub orientation: Option<u32>,
    pub focal_length_mm: Option<f64>,
    pub focal_length_35mm: Option<f64>,
    /// Degrees, north and east positive (EXIF GPS, else XMP GpsLatitude / GpsLongitude).
    pub latitude_deg: Option<f64>,
    pub longitude_deg: Option<f64>,
    /// EXIF GPSAltitude (metres above sea level).
    pub gps_altitude_m: Option<f64>,
    pub time: Option<String>,
    pub dji: DjiTags,
    /// senseFly's or Pix4D's XMP yaw, pitch, roll and accuracies.
    pub body: BodyTags,
}

/// Reads a photo's EXIF and XMP. A photo with neither gives an empty record; a tag whose value
/// cannot be read as a number is an error naming the file, tag and value.
pub fn read_photo_metadata(path: &Path) -> Result<PhotoMetadata, IoError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, e))?;
    let mut meta = PhotoMetadata::default();
    match exif::Reader::new().read_from_container(&mut std::io::Cursor::new(&bytes)) {
        Ok(ex) => fill_exif(&mut meta, &ex),
        Err(exif::Error::NotFound(_)) => {}
        Err(error) => {
            return Err(IoError::Exif {
                source_name: name,
                error: Box::new(error),
            });
        }
    }
    let gdal = if bytes.starts_with(b"II") || bytes.starts_with(b"MM") {
        gdal_metadata_items(path)?
    } else {
        BTreeMap::new()
    };
    let bad = |e| IoError::metadata(&name, e);
    fill_gdal_exif(&mut meta, &gdal).map_err(bad)?;
    // The XMP packet: in the bytes (a JPEG's APP1 segment, a TIFF's tag 700), else escaped in a
    // GDAL metadata item.
    let xmp = xmp_packet(&bytes).or_else(|| gdal.values().find_map(|v| xmp_packet(v.as_bytes())));
    if let Some(xmp) = xmp {
        let tags = xmp_tags(xmp).map_err(bad)?;
        let dji = tags_in(&tags, &[DJI_NS])
            .map(|(_, t)| t)
            .unwrap_or_default();
        meta.dji = dji::parse_dji(&dji).map_err(bad)?;
        meta.body = body_tags(&tags).map_err(bad)?;
    }
    if meta.latitude_deg.is_none() {
        meta.latitude_deg = meta.dji.latitude_deg;
        meta.longitude_deg = meta.dji.longitude_deg;
    }
    Ok(meta)
}
