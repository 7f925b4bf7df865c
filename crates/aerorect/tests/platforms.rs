//! (extended) The senseFly eBee photos of ../shared/data/flights/snowpeak: their XMP angles
//! against the flight's own geoinfo.txt, the Canon compact's camera from the sensor database,
//! and the heading of the GPS track against the recorded heading.
#![allow(clippy::unwrap_used)]

use aerorect::core::ImageSize;
use aerorect::drone::{CameraSource, camera_from_metadata};
use aerorect::io::{BodySchema, EoFormat, read_eo_file, read_photo_metadata};
use aerorect_testkit::shared_data as shared;

const PHOTOS: [&str; 11] = [
    "IMG_2168", "IMG_2171", "IMG_2186", "IMG_2188", "IMG_2189", "IMG_2212", "IMG_2213", "IMG_2244",
    "IMG_2280", "IMG_2281", "IMG_2282",
];

#[test]
fn snowpeak_xmp_angles_are_the_geoinfo_angles_and_the_camera_resolves() {
    let Some(dir) = shared("flights/snowpeak") else {
        return;
    };
    let geoinfo = read_eo_file(&dir.join("snowpea1_geoinfo.txt")).unwrap();
    assert_eq!(geoinfo.format, EoFormat::SenseflyGeoinfo);
    assert_eq!(geoinfo.records.len(), 140);
    for name in PHOTOS {
        let path = dir.join(format!("img/{name}.JPG"));
        let m = read_photo_metadata(&path).unwrap();
        let a = m.body.angles.unwrap();
        assert_eq!(a.schema, BodySchema::Sensefly, "{name}");
        let g = geoinfo.record_for(&path).unwrap();
        let b = g.angles.unwrap();
        // geoinfo writes 10 decimals of the same float32 values.
        for (x, y) in [
            (a.yaw_deg, b.yaw_deg),
            (a.pitch_deg, b.pitch_deg),
            (a.roll_deg, b.roll_deg),
        ] {
            assert!((x - y).abs() < 1e-6, "{name}: XMP {x} geoinfo {y}");
        }
        // EXIF GPS is the geoinfo position (EXIF keeps fewer digits).
        let (lat, lon) = (m.latitude_deg.unwrap(), m.longitude_deg.unwrap());
        assert!(
            (lat - g.position[1]).abs() < 1e-5 && (lon - g.position[0]).abs() < 1e-5,
            "{name}"
        );
        assert!(m.body.xy_accuracy_m.is_some() && m.body.z_accuracy_m.is_some());
        // The Canon IXUS 125 HS: 4.3 mm over the database's 6.16 mm sensor width, 4608 px.
        let c = camera_from_metadata(&m, ImageSize::new(4608, 3456), name).unwrap();
        assert_eq!(
            c.source,
            CameraSource::SensorDatabase("Canon IXUS 125 HS".into(), 6.16)
        );
        let f = m.focal_length_mm.unwrap();
        assert!((c.camera.intrinsics.fx - f * 4608.0 / 6.16).abs() < 1e-9);
    }
}

#[test]
fn sensefly_height_is_the_flat_default_and_without_it_the_ground_is_asked_for() {
    use aerorect::drone::{DroneOptions, plan_from_metadata};
    use aerorect::io::{BodyAngles, PhotoMetadata};
    let mut m = PhotoMetadata {
        make: Some("Canon".into()),
        model: Some("Canon IXUS 125 HS".into()),
        focal_length_mm: Some(4.3),
        latitude_deg: Some(37.54),
        longitude_deg: Some(139.04),
        gps_altitude_m: Some(261.0),
        ..Default::default()
    };
    m.body.angles = Some(BodyAngles {
        yaw_deg: 304.5,
        pitch_deg: 3.4,
        roll_deg: 1.0,
        schema: BodySchema::SenseflyLegacy,
    });
    let size = ImageSize::new(4608, 3456);
    let e = plan_from_metadata(&m, size, &DroneOptions::default(), "IMG_1.JPG")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("IMG_1.JPG")
            && e.contains("sensefly:Height")
            && e.contains("give ground_height_m"),
        "{e}"
    );
    m.body.height_m = Some(151.2);
    let (_, info) = plan_from_metadata(&m, size, &DroneOptions::default(), "IMG_1.JPG").unwrap();
    assert_eq!(info.height_m, 151.2);
    let ground = DroneOptions {
        ground_height_m: Some(160.0),
        ..Default::default()
    };
    let (_, info) = plan_from_metadata(&m, size, &ground, "IMG_1.JPG").unwrap();
    assert!(
        (info.height_m - 101.0).abs() < 1e-9,
        "GPSAltitude 261 over ground 160"
    );
}
