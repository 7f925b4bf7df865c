//! EXIF (kamadak-exif) and GDAL's `EXIF_*` metadata items of a TIFF (tag 42112).

use super::{MetadataError, PhotoMetadata};
use crate::error::IoError;
use exif::{In, Tag, Value};
use std::collections::BTreeMap;
use std::path::Path;

fn rational(ex: &exif::Exif, tag: Tag) -> Option<f64> {
    match &ex.get_field(tag, In::PRIMARY)?.value {
        Value::Rational(v) => v.first().map(|r| r.to_f64()),
        Value::SRational(v) => v.first().map(|r| r.to_f64()),
        other => other.get_uint(0).map(f64::from),
    }
}

fn ascii(ex: &exif::Exif, tag: Tag) -> Option<String> {
    match &ex.get_field(tag, In::PRIMARY)?.value {
        Value::Ascii(v) => v
            .first()
            .map(|s| String::from_utf8_lossy(s).trim().to_string()),
        _ => None,
    }
}

/// Degrees from EXIF's degrees, minutes, seconds and the N/S or E/W reference.
fn gps_degrees(ex: &exif::Exif, tag: Tag, reference: Tag, negative: &str) -> Option<f64> {
    let Value::Rational(v) = &ex.get_field(tag, In::PRIMARY)?.value else {
        return None;
    };
    if v.len() < 3 {
        return None;
    }
    let deg = v[0].to_f64() + v[1].to_f64() / 60.0 + v[2].to_f64() / 3600.0;
    let sign = match ascii(ex, reference) {
        Some(r) if r.eq_ignore_ascii_case(negative) => -1.0,
        _ => 1.0,
    };
    deg.is_finite().then_some(sign * deg)
}

pub(super) fn fill_exif(m: &mut PhotoMetadata, ex: &exif::Exif) {
    let uint = |tag| ex.get_field(tag, In::PRIMARY)?.value.get_uint(0);
    m.make = ascii(ex, Tag::Make);
    m.model = ascii(ex, Tag::Model);
    m.width = uint(Tag::PixelXDimension);
    m.height = uint(Tag::PixelYDimension);
    m.orientation = uint(Tag::Orientation);
    m.focal_length_mm = rational(ex, Tag::FocalLength);
    m.focal_length_35mm = uint(Tag::FocalLengthIn35mmFilm).map(f64::from);
    m.latitude_deg = gps_degrees(ex, Tag::GPSLatitude, Tag::GPSLatitudeRef, "S");
    m.longitude_deg = gps_degrees(ex, Tag::GPSLongitude, Tag::GPSLongitudeRef, "W");
    m.gps_altitude_m = rational(ex, Tag::GPSAltitude).map(|a| {
        if uint(Tag::GPSAltitudeRef) == Some(1) {
            -a
        } else {
            a
        }
    });
    m.time = ascii(ex, Tag::DateTimeOriginal);
}

/// GDAL's metadata tag (42112) of a TIFF: `<GDALMetadata><Item name="EXIF_Make">DJI</Item>`,
/// by item name (items of every domain; band items left out). Empty when the tag is absent.
pub(super) fn gdal_metadata_items(path: &Path) -> Result<BTreeMap<String, String>, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut dec = tiff::decoder::Decoder::new(std::io::BufReader::new(file))
        .map_err(|e| IoError::decode(path, e))?;
    let tag = tiff::tags::Tag::Unknown(GDAL_METADATA);
    if dec
        .find_tag(tag)
        .map_err(|e| IoError::decode(path, e))?
        .is_none()
    {
        return Ok(BTreeMap::new());
    }
    let xml = dec
        .get_tag_ascii_string(tag)
        .map_err(|e| IoError::decode(path, e))?;
    let xml = xml.trim_end_matches('\0');
    let doc = roxmltree::Document::parse(xml)
        .map_err(|e| IoError::metadata(path.display(), MetadataError::GdalXml(e)))?;
    Ok(doc
        .descendants()
        .filter(|n| n.has_tag_name("Item") && n.attribute("sample").is_none())
        .filter_map(|n| Some((n.attribute("name")?.to_string(), n.text()?.to_string())))
        .collect())
}

const GDAL_METADATA: u16 = 42112;

/// The numbers of a GDAL EXIF item: "(53) (54) (1.2)", "(4.73)", "26".
fn gdal_numbers(item: &str, value: &str) -> Result<Vec<f64>, MetadataError> {
    value
        .split_whitespace()
        .map(|t| {
            let t = t.trim_start_matches('(').trim_end_matches(')');
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(MetadataError::GdalNumber {
                    item: item.to_string(),
                    value: value.to_string(),
                }),
            }
        })
        .collect()
}

/// Fills what EXIF did not give from GDAL's `EXIF_*` metadata items.
pub(super) fn fill_gdal_exif(
    m: &mut PhotoMetadata,
    items: &BTreeMap<String, String>,
) -> Result<(), MetadataError> {
    let text = |k: &str| items.get(k).map(|v| v.trim().to_string());
    let first = |k: &str| -> Result<Option<f64>, MetadataError> {
        match items.get(k) {
            Some(v) => Ok(gdal_numbers(k, v)?.first().copied()),
            None => Ok(None),
        }
    };
    let dms = |k: &str, reference: &str, negative: &str| -> Result<Option<f64>, MetadataError> {
        let Some(v) = items.get(k) else {
            return Ok(None);
        };
        let n = gdal_numbers(k, v)?;
        let deg = n
            .iter()
            .zip([1.0, 60.0, 3600.0])
            .map(|(x, s)| x / s)
            .sum::<f64>();
        let neg = text(reference).is_some_and(|r| r.eq_ignore_ascii_case(negative));
        Ok(Some(if neg { -deg } else { deg }))
    };
    m.make = m.make.take().or(text("EXIF_Make"));
    m.model = m.model.take().or(text("EXIF_Model"));
    m.width = m.width.or(first("EXIF_PixelXDimension")?.map(|v| v as u32));
    m.height = m
        .height
        .or(first("EXIF_PixelYDimension")?.map(|v| v as u32));
    m.focal_length_mm = m.focal_length_mm.or(first("EXIF_FocalLength")?);
    m.focal_length_35mm = m.focal_length_35mm.or(first("EXIF_FocalLengthIn35mmFilm")?);
    m.latitude_deg = m
        .latitude_deg
        .or(dms("EXIF_GPSLatitude", "EXIF_GPSLatitudeRef", "S")?);
    m.longitude_deg = m
        .longitude_deg
        .or(dms("EXIF_GPSLongitude", "EXIF_GPSLongitudeRef", "W")?);
    if m.gps_altitude_m.is_none()
        && let Some(a) = first("EXIF_GPSAltitude")?
    {
        let below = text("EXIF_GPSAltitudeRef").is_some_and(|r| r == "1" || r == "0x01");
        m.gps_altitude_m = Some(if below { -a } else { a });
    }
    m.time = m.time.take().or(text("EXIF_DateTimeOriginal"));
    Ok(())
}
