use super::*;
use crate::metadata::BodySchema;

/// ODM's documented example (docs.opendronemap.org, "Image Geolocation Files").
const GEO_TXT: &str = "EPSG:4326
DJI_0028.JPG -91.9942096111 46.8425581694 198.609 # a comment
DJI_0032.JPG -91.9938293055 46.8424813444 198.609 90.0 0.0 -3.1 3.0 5.0
DJI_0033.JPG\t-91.9934806111\t46.8424109583\t198.609\t0 0 0
";

#[test]
fn geo_txt_positions_angles_and_accuracies() {
    let t = eo_from_text(GEO_TXT, "geo.txt").unwrap();
    assert_eq!(t.format, EoFormat::OdmGeoTxt);
    assert_eq!(t.crs, None);
    let r = &t.records["DJI_0032.JPG"];
    assert_eq!(r.position, [-91.9938293055, 46.8424813444]);
    assert_eq!(r.z_m, Some(198.609));
    let a = r.angles.unwrap();
    assert_eq!((a.yaw_deg, a.pitch_deg, a.roll_deg), (90.0, 0.0, -3.1));
    assert_eq!(a.schema, BodySchema::OdmGeoTxt);
    assert_eq!(r.accuracy_m, Some([3.0, 5.0]));
    assert_eq!(r.line, 3);
    assert_eq!(t.records["DJI_0028.JPG"].angles, None);
    assert!(t.records["DJI_0033.JPG"].angles.is_some());
    let utm = eo_from_text("WGS84 UTM 54N\na.jpg 300000 4150000 220\n", "g").unwrap();
    assert_eq!(utm.crs.as_deref(), Some("EPSG:32654"));
}

#[test]
fn pix4d_csv_with_and_without_header() {
    let with = "imagename,latitude,longitude,altitude,yaw,pitch,roll,accuracy_horz,accuracy_vert\n\
                IMG_1.JPG,37.5,139.04,260.5,304.4,3.4,12.9,5.8,5.6\n";
    let t = eo_from_text(with, "p.csv").unwrap();
    assert_eq!(t.format, EoFormat::Pix4dCsv);
    let r = &t.records["IMG_1.JPG"];
    assert_eq!(r.position, [139.04, 37.5]);
    assert_eq!(r.z_m, Some(260.5));
    let a = r.angles.unwrap();
    assert_eq!(
        (a.yaw_deg, a.pitch_deg, a.roll_deg, a.schema),
        (304.4, 3.4, 12.9, BodySchema::Pix4dCsv)
    );
    assert_eq!(r.accuracy_m, Some([5.8, 5.6]));
    let without = eo_from_text("IMG_2.JPG, 37.5, 139.0, 250\n", "p.csv").unwrap();
    assert_eq!(without.records["IMG_2.JPG"].angles, None);
    let opk = "imagename,latitude,longitude,altitude,omega,phi,kappa\n";
    let e = eo_from_text(opk, "p.csv").unwrap_err().to_string();
    assert!(e.contains("p.csv") && e.contains("omega"), "{e}");
}

#[test]
fn geoinfo_tab_separated_with_its_revision_line() {
    let g = "#Rev: sensefly/geoinfo/2\n\
             fileName\tlatitude\tlongitude\taltitude_amsl\taltitude_wgs84\theading\tpitch\troll\n\
             IMG_9.JPG\t37.54\t139.04\t221.3\t261.0\t304.45\t3.40\t12.88\t\n";
    let t = eo_from_text(g, "geoinfo.txt").unwrap();
    assert_eq!(t.format, EoFormat::SenseflyGeoinfo);
    let r = &t.records["IMG_9.JPG"];
    assert_eq!(r.position, [139.04, 37.54]);
    assert_eq!(r.z_m, Some(221.3));
    let a = r.angles.unwrap();
    assert_eq!((a.yaw_deg, a.pitch_deg, a.roll_deg), (304.45, 3.40, 12.88));
    assert!(a.schema.is_sensefly());
}

#[test]
fn the_pose_csv_is_recognised() {
    assert_eq!(
        detect_format("filename,x,y,z,omega,phi,kappa\n"),
        EoFormat::PoseCsv
    );
}

#[test]
fn bad_files_name_the_line_field_and_photo() {
    let twice = "EPSG:4326\na.jpg 1 2 3\nb.jpg 1 2 3\na.jpg 1 2 3\n";
    let e = eo_from_text(twice, "geo.txt").unwrap_err().to_string();
    assert!(
        e.contains("geo.txt") && e.contains("'a.jpg' is listed twice (lines 2 and 4)"),
        "{e}"
    );
    let e = eo_from_text("EPSG:4326\na.jpg 1 x 3\n", "geo.txt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2: geo_y 'x' is not a number"), "{e}");
    let e = eo_from_text("EPSG:4326\na.jpg 1 2 3 90 0\n", "geo.txt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2: yaw, pitch without roll"), "{e}");
    let e = eo_from_text("EPSG:4326\n", "geo.txt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no photos"), "{e}");
    let e = eo_from_text("#Rev: x\nfileName\tlatitude\n", "g.txt")
        .unwrap_err()
        .to_string();
    assert!(e.contains("no column 'longitude'"), "{e}");
}
