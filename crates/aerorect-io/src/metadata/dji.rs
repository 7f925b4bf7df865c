//! DJI's `drone-dji` XMP tags, with the quirks found in the wild: numbers written "+37.10",
//! and `GpsLongtitude` misspelt.

use super::MetadataError;
use super::xmp::{tags_in, xmp_number, xmp_tags};
use serde::Serialize;
use std::collections::BTreeMap;

/// The namespace of DJI's XMP tags.
pub const DJI_NS: &str = "http://www.dji.com/drone-dji/1.0/";

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

/// Every `drone-dji` tag of an XMP packet, written as an attribute or as an element, by local
/// name.
pub fn dji_tags(xmp: &str) -> Result<BTreeMap<String, String>, MetadataError> {
    let tags = xmp_tags(xmp)?;
    Ok(tags_in(&tags, &[DJI_NS])
        .map(|(_, t)| t)
        .unwrap_or_default())
}

/// A DJI number: "+37.10", "-19.00", " 5 ".
pub fn dji_number(tag: &str, value: &str) -> Result<f64, MetadataError> {
    xmp_number("drone-dji", tag, value)
}

pub(super) fn parse_dji(tags: &BTreeMap<String, String>) -> Result<DjiTags, MetadataError> {
    let num = |names: &[&str]| -> Result<Option<f64>, MetadataError> {
        for n in names {
            if let Some(v) = tags.get(*n) {
                return dji_number(n, v).map(Some);
            }
        }
        Ok(None)
    };
    // Heights beyond 100 km are no flight (1e308 used to reach the homography as "singular").
    let height = |name: &str| -> Result<Option<f64>, MetadataError> {
        match num(&[name])? {
            Some(v) if v.abs() > 1e5 => Err(MetadataError::Height {
                tag: name.to_string(),
                value: tags.get(name).map_or("", |t| t.trim()).to_string(),
            }),
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
    use crate::metadata::xmp_packet;

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
        let e = parse_dji(&tags).unwrap_err().to_string();
        assert!(e.contains("GimbalPitchDegree = '-19,00'"), "{e}");
    }
}
