//! Aircraft (body) yaw, pitch and roll written by fixed wings and multispectral rigs: senseFly's
//! `Roll/Pitch/Yaw` (and the older `RollAngle/PitchAngle/Heading`), and Pix4D's
//! `Camera:Yaw/Pitch/Roll` (Parrot, MicaSense, Sony/Wingtra, eBee X). Both are Pix4D's
//! yaw-pitch-roll: NED Z-Y-X angles of the body, the camera fixed looking down with the image
//! top towards the nose, so pitch 0 is nadir (the rotation is built in `aerorect::photo_source`).

use super::MetadataError;
use super::xmp::{first_number, tags_in};
use serde::Serialize;
use std::collections::BTreeMap;

/// senseFly's namespaces: the one Pix4D, Orthority and OpenSfM name, and the one senseFly's
/// own eMotion wrote into the Canon compacts' JPEGs (ExifTool 8.71 era).
pub const SENSEFLY_NS: [&str; 2] = [
    "http://ns.sensefly.com/Camera/1.0/",
    "http://ns.sensefly.com/sensefly/1.0/",
];

/// Pix4D's camera namespace (the `Camera:` prefix).
pub const PIX4D_NS: &str = "http://pix4d.com/camera/1.0/";

/// Where a photo's yaw, pitch and roll were read, which fixes their convention.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum BodySchema {
    /// XMP senseFly `Roll`, `Pitch`, `Yaw`.
    Sensefly,
    /// XMP senseFly `RollAngle`, `PitchAngle`, `Heading` (older eMotion).
    SenseflyLegacy,
    /// XMP Pix4D `Camera:Yaw`, `Camera:Pitch`, `Camera:Roll`.
    Pix4d,
    /// An ODM `geo.txt` line's yaw, pitch, roll.
    OdmGeoTxt,
    /// A Pix4D geolocation CSV's yaw, pitch, roll.
    Pix4dCsv,
    /// A senseFly `geoinfo.txt` line's heading, pitch, roll.
    SenseflyGeoinfo,
}

impl BodySchema {
    /// Written by senseFly (the schemas whose roll sign peer tools disagree on).
    pub fn is_sensefly(self) -> bool {
        matches!(
            self,
            BodySchema::Sensefly | BodySchema::SenseflyLegacy | BodySchema::SenseflyGeoinfo
        )
    }
}

/// Yaw (clockwise from north), pitch (0 = nadir) and roll, degrees, as recorded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BodyAngles {
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
    pub schema: BodySchema,
}

/// The senseFly or Pix4D XMP tags of a photo.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BodyTags {
    pub angles: Option<BodyAngles>,
    /// GPSXYAccuracy, GPSZAccuracy (m, one standard deviation).
    pub xy_accuracy_m: Option<f64>,
    pub z_accuracy_m: Option<f64>,
    /// senseFly AltitudeWGS84: ellipsoidal height (m).
    pub altitude_wgs84_m: Option<f64>,
    /// senseFly Height: above the take-off point (m).
    pub height_m: Option<f64>,
}

/// The senseFly, else the Pix4D, tags of a packet's tags (keyed by namespace and name). A tag
/// that is not a number is an error naming it; a schema with only some of its three angles has
/// no angles.
pub fn body_tags(all: &BTreeMap<(String, String), String>) -> Result<BodyTags, MetadataError> {
    if let Some((_, t)) = tags_in(all, &SENSEFLY_NS) {
        let n = |names: &[&str]| first_number("sensefly", &t, names);
        let (schema, angles) = match (n(&["Yaw"])?, n(&["Heading"])?) {
            (Some(y), _) => (
                BodySchema::Sensefly,
                (Some(y), n(&["Pitch"])?, n(&["Roll"])?),
            ),
            (None, h) => (
                BodySchema::SenseflyLegacy,
                (h, n(&["PitchAngle"])?, n(&["RollAngle"])?),
            ),
        };
        return Ok(BodyTags {
            angles: angles_of(angles, schema),
            xy_accuracy_m: n(&["GPSXYAccuracy"])?,
            z_accuracy_m: n(&["GPSZAccuracy"])?,
            altitude_wgs84_m: n(&["AltitudeWGS84"])?,
            height_m: n(&["Height"])?,
        });
    }
    if let Some((_, t)) = tags_in(all, &[PIX4D_NS]) {
        let n = |name: &str| first_number("Camera", &t, &[name]);
        return Ok(BodyTags {
            angles: angles_of((n("Yaw")?, n("Pitch")?, n("Roll")?), BodySchema::Pix4d),
            xy_accuracy_m: n("GPSXYAccuracy")?,
            z_accuracy_m: n("GPSZAccuracy")?,
            ..BodyTags::default()
        });
    }
    Ok(BodyTags::default())
}

fn angles_of(
    (yaw, pitch, roll): (Option<f64>, Option<f64>, Option<f64>),
    schema: BodySchema,
) -> Option<BodyAngles> {
    Some(BodyAngles {
        yaw_deg: yaw?,
        pitch_deg: pitch?,
        roll_deg: roll?,
        schema,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metadata::xmp::xmp_tags;

    /// The packet of /work/shared/data/flights/snowpeak/img/IMG_2188.JPG (senseFly eBee, Canon
    /// IXUS 125 HS), as ExifTool 8.71 wrote it.
    const SNOWPEAK_2188: &str = r#"<x:xmpmeta xmlns:x='adobe:ns:meta/' x:xmptk='Image::ExifTool 8.71'>
<rdf:RDF xmlns:rdf='http://www.w3.org/1999/02/22-rdf-syntax-ns#'>
 <rdf:Description rdf:about='' xmlns:sensefly='http://ns.sensefly.com/sensefly/1.0/'>
  <sensefly:CamID>5</sensefly:CamID>
  <sensefly:GPSXYAccuracy>5.789999961853027</sensefly:GPSXYAccuracy>
  <sensefly:GPSZAccuracy>5.585999965667725</sensefly:GPSZAccuracy>
  <sensefly:Pitch>3.402446031570435</sensefly:Pitch>
  <sensefly:Roll>12.880300521850586</sensefly:Roll>
  <sensefly:Yaw>304.457611083984375</sensefly:Yaw>
 </rdf:Description>
</rdf:RDF></x:xmpmeta>"#;

    fn tags(x: &str) -> Result<BodyTags, MetadataError> {
        body_tags(&xmp_tags(x).expect("xml"))
    }

    #[test]
    fn sensefly_roll_pitch_yaw_in_either_namespace() {
        let t = tags(SNOWPEAK_2188).expect("numbers");
        let a = t.angles.expect("angles");
        assert_eq!(
            (a.yaw_deg, a.pitch_deg, a.roll_deg),
            (304.4576110839844, 3.402446031570435, 12.880300521850586)
        );
        assert_eq!(a.schema, BodySchema::Sensefly);
        assert_eq!(t.xy_accuracy_m, Some(5.789999961853027));
        assert_eq!(t.z_accuracy_m, Some(5.585999965667725));
        let camera_ns = SNOWPEAK_2188.replace("sensefly/1.0/", "Camera/1.0/");
        assert_eq!(tags(&camera_ns).expect("numbers"), t);
    }

    #[test]
    fn older_sensefly_heading_with_altitude_and_height() {
        let x = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">
  <rdf:Description xmlns:sf="http://ns.sensefly.com/Camera/1.0/" sf:RollAngle="-2.5"
    sf:PitchAngle="4" sf:Heading="47.25" sf:AltitudeWGS84="312.4" sf:Height="151.2"/>
  </rdf:RDF></x:xmpmeta>"#;
        let t = tags(x).expect("numbers");
        let a = t.angles.expect("angles");
        assert_eq!((a.yaw_deg, a.pitch_deg, a.roll_deg), (47.25, 4.0, -2.5));
        assert_eq!(a.schema, BodySchema::SenseflyLegacy);
        assert_eq!((t.altitude_wgs84_m, t.height_m), (Some(312.4), Some(151.2)));
    }

    #[test]
    fn pix4d_camera_yaw_pitch_roll_as_micasense_writes_them() {
        // MicaSense RedEdge: the Camera: prefix bound to Pix4D's namespace.
        let x = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">
  <rdf:Description xmlns:Camera="http://pix4d.com/camera/1.0/">
   <Camera:Yaw>-171.2</Camera:Yaw><Camera:Pitch>2.1</Camera:Pitch><Camera:Roll>-0.7</Camera:Roll>
   <Camera:GPSXYAccuracy>1.4</Camera:GPSXYAccuracy>
  </rdf:Description></rdf:RDF></x:xmpmeta>"#;
        let t = tags(x).expect("numbers");
        let a = t.angles.expect("angles");
        assert_eq!((a.yaw_deg, a.pitch_deg, a.roll_deg), (-171.2, 2.1, -0.7));
        assert_eq!(a.schema, BodySchema::Pix4d);
        assert_eq!(t.xy_accuracy_m, Some(1.4));
        // Another prefix on another namespace is not Pix4D's.
        let other = x.replace("http://pix4d.com/camera/1.0/", "http://example.com/cam/");
        assert_eq!(tags(&other).expect("numbers"), BodyTags::default());
    }

    #[test]
    fn a_bad_angle_names_the_tag_and_value() {
        let bad = SNOWPEAK_2188.replace("12.880300521850586", "12,88");
        let e = tags(&bad).unwrap_err().to_string();
        assert!(e.contains("sensefly:Roll = '12,88'"), "{e}");
    }
}
