use super::*;
use aerorect_core::Vec3;

fn axis(r: &CameraRotation) -> Vec3 {
    r.ground_from_camera() * Vec3::new(0.0, 0.0, -1.0)
}

#[test]
fn pix4d_zero_angles_are_nadir_north_up() {
    let r = rotation_from_body_ypr(0.0, 0.0, 0.0).unwrap();
    assert!((r.ground_from_camera() - Mat3::identity()).abs().max() < 1e-15);
}

#[test]
fn pix4d_pitch_is_dji_gimbal_pitch_plus_90_at_zero_roll() {
    // Pix4D: pitch 0 nadir, +90 forward; DJI: -90 nadir, 0 forward (an independent adapter).
    for (y, p) in [(0.0, 0.0), (37.0, 12.0), (-140.0, 60.0), (304.5, 3.4)] {
        let a = rotation_from_body_ypr(y, p, 0.0).unwrap();
        let b = CameraRotation::dji_gimbal(y, p - 90.0, 0.0).unwrap();
        let d = (a.ground_from_camera() - b.ground_from_camera())
            .abs()
            .max();
        assert!(d < 1e-12, "yaw {y} pitch {p}: {d}");
    }
}

#[test]
fn positive_roll_turns_a_nadir_view_to_the_left_and_pitch_up_forward() {
    // Heading north, right wing down by 10 degrees: the belly camera looks west of nadir.
    let a = axis(&rotation_from_body_ypr(0.0, 0.0, 10.0).unwrap());
    let s = 10f64.to_radians();
    assert!(
        (a - Vec3::new(-s.sin(), 0.0, -s.cos())).norm() < 1e-12,
        "{a}"
    );
    // Heading east, nose up 30: the view moves forward (east).
    let a = axis(&rotation_from_body_ypr(90.0, 30.0, 0.0).unwrap());
    let p = 30f64.to_radians();
    assert!(
        (a - Vec3::new(p.sin(), 0.0, -p.cos())).norm() < 1e-12,
        "{a}"
    );
    // Yaw 90 at nadir: the image top (camera +y) points east.
    let r = rotation_from_body_ypr(90.0, 0.0, 0.0).unwrap();
    let top = r.ground_from_camera() * Vec3::new(0.0, 1.0, 0.0);
    assert!((top - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-12, "{top}");
}

fn body(schema: BodySchema, roll: f64) -> PhotoMetadata {
    let mut m = PhotoMetadata {
        latitude_deg: Some(37.5),
        longitude_deg: Some(139.0),
        ..Default::default()
    };
    m.body.angles = Some(BodyAngles {
        yaw_deg: 0.0,
        pitch_deg: 0.0,
        roll_deg: roll,
        schema,
    });
    m
}

#[test]
fn only_sensefly_roll_is_flipped_by_the_flipped_reading() {
    let flipped = DroneOptions {
        sensefly_roll: SenseflyRoll::Flipped,
        ..DroneOptions::default()
    };
    for (schema, want) in [
        (BodySchema::Sensefly, -5.0),
        (BodySchema::SenseflyGeoinfo, -5.0),
        (BodySchema::Pix4d, 5.0),
        (BodySchema::OdmGeoTxt, 5.0),
    ] {
        let a = attitude_from_metadata(&body(schema, 5.0), &flipped, "x").unwrap();
        assert_eq!(a.angles_deg[2], want, "{schema:?}");
        assert_eq!(a.source, AttitudeSource::Body(schema));
        let a = attitude_from_metadata(&body(schema, 5.0), &DroneOptions::default(), "x").unwrap();
        assert_eq!(a.angles_deg[2], 5.0);
    }
}

fn gps(name: &str, lat: f64, lon: f64, time: &str) -> (PathBuf, PhotoMetadata) {
    let m = PhotoMetadata {
        latitude_deg: Some(lat),
        longitude_deg: Some(lon),
        time: Some(time.into()),
        ..Default::default()
    };
    (PathBuf::from(format!("/f/{name}")), m)
}

#[test]
fn gps_only_photos_head_along_their_track_in_time_order() {
    // East along a strip (file names out of time order), then north; one hover repeat.
    let frames = vec![
        gps("c.jpg", 37.0, 139.002, "2020:01:01 10:00:03"),
        gps("a.jpg", 37.0, 139.000, "2020:01:01 10:00:01"),
        gps("b.jpg", 37.0, 139.001, "2020:01:01 10:00:02"),
        gps("d.jpg", 37.001, 139.002, "2020:01:01 10:00:04"),
    ];
    let h = track_headings(&frames);
    assert!((h["a.jpg"] - 90.0).abs() < 1e-9, "{h:?}");
    assert!((h["b.jpg"] - 90.0).abs() < 1e-9);
    // c: from b (west) to d (north-east of b): between east and north.
    assert!(h["c.jpg"] > 0.0 && h["c.jpg"] < 90.0);
    assert!(h["d.jpg"].abs() < 1e-9 || (h["d.jpg"] - 360.0).abs() < 1e-9);
    let opts = DroneOptions {
        track_headings: Some(std::sync::Arc::new(h)),
        ..DroneOptions::default()
    };
    let a = attitude_from_metadata(&frames[1].1, &opts, "/f/a.jpg").unwrap();
    assert_eq!(a.source, AttitudeSource::GpsTrack);
    assert_eq!(a.prior_sigma_deg, Some(GPS_TRACK_PRIOR_SIGMA_DEG));
    let top = a.rotation.ground_from_camera() * Vec3::new(0.0, 1.0, 0.0);
    assert!(
        (top - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-9,
        "image top east: {top}"
    );
    // A hover (two photos at one point) has no track.
    let hover = vec![
        gps("h1.jpg", 37.0, 139.0, "1"),
        gps("h2.jpg", 37.0, 139.0, "2"),
    ];
    assert!(track_headings(&hover).is_empty());
}

#[test]
fn no_attitude_and_no_gps_is_an_error_naming_the_photo() {
    let e = attitude_from_metadata(
        &PhotoMetadata::default(),
        &DroneOptions::default(),
        "IMG_7.JPG",
    )
    .unwrap_err()
    .full_message();
    assert!(
        e.contains("IMG_7.JPG") && e.contains("no GPS position"),
        "{e}"
    );
    let (_, m) = gps("a.jpg", 37.0, 139.0, "1");
    let e = attitude_from_metadata(&m, &DroneOptions::default(), "a.jpg")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("a.jpg") && e.contains("no neighbouring photo"),
        "{e}"
    );
}

#[test]
fn a_geo_record_replaces_the_photos_position_height_and_angles() {
    let t = aerorect_io::eo::eo_from_text(
        "EPSG:4326\nIMG_1.JPG 139.5 37.25 250 90 2 -3 4 6\n",
        "geo.txt",
    )
    .unwrap();
    let opts = DroneOptions {
        geo: Some(std::sync::Arc::new(t)),
        ..DroneOptions::default()
    };
    let mut own = body(BodySchema::Sensefly, 9.0);
    own.dji.gimbal_yaw_deg = Some(10.0);
    own.dji.gimbal_pitch_deg = Some(-90.0);
    let m = with_geo_record(&own, &opts, "/x/IMG_1.JPG").unwrap();
    assert_eq!(
        (m.longitude_deg, m.latitude_deg, m.gps_altitude_m),
        (Some(139.5), Some(37.25), Some(250.0))
    );
    let a = attitude_from_metadata(&m, &opts, "IMG_1.JPG").unwrap();
    assert_eq!(a.source, AttitudeSource::Body(BodySchema::OdmGeoTxt));
    assert_eq!(a.angles_deg, [90.0, 2.0, -3.0]);
    assert_eq!(m.body.xy_accuracy_m, Some(4.0));
    let e = with_geo_record(&own, &opts, "/x/IMG_2.JPG")
        .unwrap_err()
        .full_message();
    assert!(
        e.contains("IMG_2.JPG") && e.contains("not in the external-orientation file geo.txt"),
        "{e}"
    );
}
