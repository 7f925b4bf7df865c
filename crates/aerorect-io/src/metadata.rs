//! Photo metadata: EXIF (kamadak-exif, from JPEG or TIFF), GDAL's `EXIF_*` metadata items in a
//! TIFF (tag 42112), and the XMP `drone-dji` tags (roxmltree) from a JPEG's APP1 segment, a
//! TIFF's tag 700 or a GDAL metadata item, with the quirks found in the wild: numbers written
//! "+37.10", and `GpsLongtitude` misspelt.

use crate::error::IoError;
use exif::{In, Tag, Value};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The namespace of DJI's XMP tags.
pub const DJI_NS: &str = "http://www.dji.com/drone-dji/1.0/";

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
}

/// The `drone-dji` XMP tags.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct DjiTags {
    pub gimbal_roll_deg: Option<f64>,
    pub gimbal_pitch_deg: Option<f64>,
    pub gimbal_yaw_deg: Option<f64>,
    pub flight_roll_deg: Option<f64>,
    pub flight_pitch_deg: Option<f64>,
    pub flight_yaw_deg: Option<f64>,
    pub relative_altitude_m: Option<f64>,
    pub absolute_altitude_m: Option<f64>,
    pub calibrated_focal_length_px: Option<f64>,
    pub calibrated_optical_center_x_px: Option<f64>,
    pub calibrated_optical_center_y_px: Option<f64>,
    pub dewarp_data: Option<String>,
    pub latitude_deg: Option<f64>,
    pub longitude_deg: Option<f64>,
    /// The RTK receiver's standard deviations (m) east, north and up (`RtkStdLon`,
    /// `RtkStdLat`, `RtkStdHgt`), on RTK aircraft only.
    pub rtk_std_m: Option<[f64; 3]>,
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
        Err(e) => return Err(IoError::field(&name, format!("EXIF: {e}"))),
    }
    let gdal = if bytes.starts_with(b"II") || bytes.starts_with(b"MM") {
        gdal_metadata_items(path)?
    } else {
        BTreeMap::new()
    };
    fill_gdal_exif(&mut meta, &gdal).map_err(|e| IoError::field(&name, e))?;
    // The XMP packet: in the bytes (a JPEG's APP1 segment, a TIFF's tag 700), else escaped in a
    // GDAL metadata item.
    let xmp = xmp_packet(&bytes).or_else(|| gdal.values().find_map(|v| xmp_packet(v.as_bytes())));
    if let Some(xmp) = xmp {
        let tags = dji_tags(xmp).map_err(|e| IoError::field(&name, format!("XMP: {e}")))?;
        meta.dji = parse_dji(&tags).map_err(|e| IoError::field(&name, e))?;
    }
    if meta.latitude_deg.is_none() {
        meta.latitude_deg = meta.dji.latitude_deg;
        meta.longitude_deg = meta.dji.longitude_deg;
    }
    Ok(meta)
}

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

fn fill_exif(m: &mut PhotoMetadata, ex: &exif::Exif) {
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
fn gdal_metadata_items(path: &Path) -> Result<BTreeMap<String, String>, IoError> {
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
        .map_err(|e| IoError::field(path.display(), format!("GDAL metadata (tag 42112): {e}")))?;
    Ok(doc
        .descendants()
        .filter(|n| n.has_tag_name("Item") && n.attribute("sample").is_none())
        .filter_map(|n| Some((n.attribute("name")?.to_string(), n.text()?.to_string())))
        .collect())
}

const GDAL_METADATA: u16 = 42112;

/// The numbers of a GDAL EXIF item: "(53) (54) (1.2)", "(4.73)", "26".
fn gdal_numbers(item: &str, value: &str) -> Result<Vec<f64>, String> {
    value
        .split_whitespace()
        .map(|t| {
            let t = t.trim_start_matches('(').trim_end_matches(')');
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(format!("GDAL metadata {item} = '{value}' is not a number")),
            }
        })
        .collect()
}

/// Fills what EXIF did not give from GDAL's `EXIF_*` metadata items.
fn fill_gdal_exif(m: &mut PhotoMetadata, items: &BTreeMap<String, String>) -> Result<(), String> {
    let text = |k: &str| items.get(k).map(|v| v.trim().to_string());
    let first = |k: &str| -> Result<Option<f64>, String> {
        match items.get(k) {
            Some(v) => Ok(gdal_numbers(k, v)?.first().copied()),
            None => Ok(None),
        }
    };
    let dms = |k: &str, reference: &str, negative: &str| -> Result<Option<f64>, String> {
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

/// The XMP packet of a file: the text from `<x:xmpmeta` to `</x:xmpmeta>`.
pub fn xmp_packet(bytes: &[u8]) -> Option<&str> {
    let find = |needle: &[u8], from: usize| {
        bytes[from..]
            .windows(needle.len())
            .position(|w| w == needle)
            .map(|p| p + from)
    };
    let start = find(b"<x:xmpmeta", 0)?;
    let end = find(b"</x:xmpmeta>", start)? + b"</x:xmpmeta>".len();
    std::str::from_utf8(&bytes[start..end]).ok()
}

/// Every `drone-dji` tag of an XMP packet, written as an attribute or as an element, by local
/// name.
pub fn dji_tags(xmp: &str) -> Result<BTreeMap<String, String>, String> {
    let doc = roxmltree::Document::parse(xmp).map_err(|e| e.to_string())?;
    let mut out = BTreeMap::new();
    for node in doc.descendants() {
        for a in node.attributes() {
            if a.namespace() == Some(DJI_NS) {
                out.insert(a.name().to_string(), a.value().to_string());
            }
        }
        if node.is_element()
            && node.tag_name().namespace() == Some(DJI_NS)
            && let Some(t) = node.text()
        {
            out.insert(node.tag_name().name().to_string(), t.trim().to_string());
        }
    }
    Ok(out)
}

/// A DJI number: "+37.10", "-19.00", " 5 ".
pub fn dji_number(tag: &str, value: &str) -> Result<f64, String> {
    let t = value.trim();
    let t = t.strip_prefix('+').unwrap_or(t);
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("XMP drone-dji:{tag} = '{value}' is not a number")),
    }
}

fn parse_dji(tags: &BTreeMap<String, String>) -> Result<DjiTags, String> {
    let num = |names: &[&str]| -> Result<Option<f64>, String> {
        for n in names {
            if let Some(v) = tags.get(*n) {
                return dji_number(n, v).map(Some);
            }
        }
        Ok(None)
    };
    // Heights beyond 100 km are no flight (1e308 used to reach the homography as "singular").
    let height = |name: &str| -> Result<Option<f64>, String> {
        match num(&[name])? {
            Some(v) if v.abs() > 1e5 => Err(format!(
                "XMP drone-dji:{name} = '{}' is outside the sane range |h| <= 100000 m",
                tags.get(name).map_or("", |t| t.trim())
            )),
            v => Ok(v),
        }
    };
    Ok(DjiTags {
        gimbal_roll_deg: num(&["GimbalRollDegree"])?,
        gimbal_pitch_deg: num(&["GimbalPitchDegree"])?,
        gimbal_yaw_deg: num(&["GimbalYawDegree"])?,
        flight_roll_deg: num(&["FlightRollDegree"])?,
        flight_pitch_deg: num(&["FlightPitchDegree"])?,
        flight_yaw_deg: num(&["FlightYawDegree"])?,
        relative_altitude_m: height("RelativeAltitude")?,
        absolute_altitude_m: height("AbsoluteAltitude")?,
        calibrated_focal_length_px: num(&["CalibratedFocalLength"])?,
        calibrated_optical_center_x_px: num(&["CalibratedOpticalCenterX"])?,
        calibrated_optical_center_y_px: num(&["CalibratedOpticalCenterY"])?,
        dewarp_data: tags.get("DewarpData").cloned(),
        latitude_deg: num(&["GpsLatitude"])?,
        // Older firmware misspells it.
        longitude_deg: num(&["GpsLongitude", "GpsLongtitude"])?,
        rtk_std_m: match (
            num(&["RtkStdLon"])?,
            num(&["RtkStdLat"])?,
            num(&["RtkStdHgt"])?,
        ) {
            (Some(e), Some(n), Some(u)) => Some([e, n, u]),
            _ => None,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const XMP: &str = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">
  <rdf:Description rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/"
    drone-dji:GimbalPitchDegree="-19.00" drone-dji:GimbalYawDegree="+117.60"
    drone-dji:GpsLatitude="53.90" drone-dji:GpsLongtitude="+27.55">
    <drone-dji:RelativeAltitude>+119.30</drone-dji:RelativeAltitude>
    <drone-dji:DewarpData>2018-09-04;3678.9,3671.5,10.5,-17.2,-0.26,0.11,0.001,-0.0003,-0.23</drone-dji:DewarpData>
  </rdf:Description></rdf:RDF></x:xmpmeta>"#;

    #[test]
    fn dji_tags_as_attributes_and_elements_with_their_quirks() {
        let mut bytes = b"\xff\xd8junk".to_vec();
        bytes.extend_from_slice(XMP.as_bytes());
        bytes.extend_from_slice(b"more");
        let tags = dji_tags(xmp_packet(&bytes).expect("packet")).expect("xml");
        let d = parse_dji(&tags).expect("numbers");
        assert_eq!(d.gimbal_pitch_deg, Some(-19.0));
        assert_eq!(d.gimbal_yaw_deg, Some(117.6));
        assert_eq!(d.relative_altitude_m, Some(119.3));
        assert_eq!(d.longitude_deg, Some(27.55));
        assert!(
            d.dewarp_data
                .expect("dewarp")
                .starts_with("2018-09-04;3678.9")
        );
        assert_eq!(d.flight_yaw_deg, None);
        assert_eq!(d.rtk_std_m, None);
    }

    #[test]
    fn rtk_standard_deviations_east_north_up() {
        // As a Phantom 4 RTK writes them (metres).
        let rtk = XMP.replace(
            "drone-dji:GpsLatitude=",
            "drone-dji:RtkStdLon=\"0.01352\" drone-dji:RtkStdLat=\"0.01589\" drone-dji:RtkStdHgt=\"0.02937\" drone-dji:GpsLatitude=",
        );
        let d = parse_dji(&dji_tags(&rtk).expect("xml")).expect("numbers");
        assert_eq!(d.rtk_std_m, Some([0.01352, 0.01589, 0.02937]));
    }

    #[test]
    fn a_bad_number_names_the_tag_and_value() {
        let bad = XMP.replace("-19.00", "-19,00");
        let tags = dji_tags(&bad).expect("xml");
        let e = parse_dji(&tags).unwrap_err();
        assert!(e.contains("GimbalPitchDegree = '-19,00'"), "{e}");
    }
}
