//! The sensor database: OpenSfM's key rules, the DJI cameras, the entry count.

use aerorect_io::{sensor_count, sensor_key, sensor_width_mm};

fn width(make: &str, model: &str) -> Option<f64> {
    sensor_width_mm(make, model).map(|m| m.width_mm)
}

#[test]
fn the_database_has_the_readmes_count() {
    // data/README.md: 3,709 cameras; normalising the keys must not merge any of them.
    assert_eq!(sensor_count(), 3709);
}

#[test]
fn dji_drones_are_found() {
    let m = sensor_width_mm("DJI", "FC220").expect("FC220 is in the database");
    assert_eq!(m.key, "DJI FC220");
    assert_eq!(m.width_mm, 6.17);
    assert_eq!(width("DJI", "FC6310"), Some(13.2));
    assert_eq!(width("DJI", "FC6540"), Some(23.5));
}

#[test]
fn case_and_whitespace_do_not_matter() {
    assert_eq!(width("dji", "fc220"), Some(6.17));
    assert_eq!(width("  Dji ", "Fc6310\t"), Some(13.2));
    assert_eq!(width("Canon", "EOS   1000D"), Some(22.2));
    // Database keys with stray spaces ("Leica  X1", "Nikon Coolpix S2800 ") match too.
    let leica = sensor_width_mm("Leica", "X1").expect("Leica X1");
    assert_eq!(leica.key, "Leica  X1");
    assert_eq!(leica.width_mm, 23.6);
    assert_eq!(width("Nikon", "Coolpix S2800"), Some(6.16));
}

#[test]
fn a_model_that_repeats_the_make_is_found() {
    assert_eq!(sensor_key("Canon", "Canon EOS 1000D"), "canon eos 1000d");
    assert_eq!(width("Canon", "Canon EOS 1000D"), Some(22.2));
    assert_eq!(width("CANON", "Canon EOS 1000D"), Some(22.2));
    assert_eq!(width("DJI", "DJI FC6310"), Some(13.2));
    // Only a whole leading word is the make: "Canonet" keeps its letters.
    assert_eq!(sensor_key("Canon", "Canonet QL17"), "canon canonet ql17");
    // No make (empty or EXIF's "unknown"): the model alone.
    assert_eq!(sensor_key("", "Canon EOS 1000D"), "canon eos 1000d");
    assert_eq!(sensor_key("unknown", "X"), "x");
}

#[test]
fn unknown_cameras_give_none() {
    assert_eq!(sensor_width_mm("DJI", "FC9999"), None);
    assert_eq!(sensor_width_mm("", ""), None);
    assert_eq!(sensor_width_mm("NoSuchMake", "FC220"), None);
}
