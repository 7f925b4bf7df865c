use super::*;

#[test]
fn an_epsg_code_is_the_same_crs_as_its_prj_and_not_another_zones() {
    let utm35 = Crs::from_epsg(32635).expect("utm35");
    let prj = Crs::parse(&utm35.to_wkt().expect("wkt")).expect("prj");
    assert!(matches!(prj.form(), CrsForm::Wkt(_)));
    assert!(utm35.same_as(&prj) && prj.same_as(&utm35));
    let utm36 = Crs::from_epsg(32636).expect("utm36");
    let utm36 = Crs::parse(&utm36.to_wkt().expect("wkt")).expect("prj");
    assert!(!utm35.same_as(&utm36) && !prj.same_as(&utm36));
    let wkt2 = CrsForm::Wkt("PROJCRS[\"x\",BASEGEOGCRS[\"y\"],ID[\"EPSG\",32635]]".into());
    assert_eq!(text::epsg_equivalent(&wkt2), Some(32635));
    let inner = CrsForm::Wkt("PROJCS[\"x\",GEOGCS[\"y\",AUTHORITY[\"EPSG\",\"4326\"]]]".into());
    assert_eq!(
        text::epsg_equivalent(&inner),
        None,
        "only the outermost authority"
    );
}

#[test]
fn parse_accepts_the_three_forms_and_names_bad_text() {
    assert_eq!(
        Crs::parse("epsg:32651").expect("epsg").form(),
        &CrsForm::Epsg(32651)
    );
    assert_eq!(Crs::parse(" EPSG:4326 ").expect("epsg").epsg(), Some(4326));
    let p = "+proj=tmerc +lon_0=25 +datum=WGS84 +units=m";
    assert_eq!(
        Crs::parse(p).expect("proj").form(),
        &CrsForm::Proj(p.into())
    );
    let e = Crs::parse("+proj=nonsense +ellps=WGS84")
        .unwrap_err()
        .to_string();
    assert!(e.contains("+proj=nonsense"), "{e}");
    let e = Crs::parse("EPSG:1").unwrap_err().to_string();
    assert!(e.contains("EPSG:1 "), "{e}");
    // A number that is no EPSG code is unknown, not "not a number".
    let e = Crs::parse("EPSG:999999").unwrap_err().to_string();
    assert!(e.contains("EPSG:999999 is an unknown EPSG code"), "{e}");
    let e = Crs::parse("EPSG:32x").unwrap_err().to_string();
    assert!(e.contains("'32x' is not a whole number"), "{e}");
    let e = Crs::parse("UTM 35").unwrap_err().to_string();
    assert!(e.contains("'UTM 35'"), "{e}");
}

#[test]
fn utm_wkt_is_the_same_projection() {
    let p = Crs::from_proj_string("+proj=utm +zone=35 +south +datum=WGS84 +units=m").expect("proj");
    let w = Crs::from_wkt(p.to_wkt().expect("wkt")).expect("wkt crs");
    let e = Crs::from_epsg(32735).expect("epsg");
    let [x, y] = p.from_lon_lat(27.0, -30.0).expect("proj");
    for other in [w, e] {
        let [x2, y2] = other.from_lon_lat(27.0, -30.0).expect("other");
        assert!((x - x2).abs() < 1e-6 && (y - y2).abs() < 1e-6, "{other}");
    }
}

/// `utm_for` builds the EPSG code's own definition, so a flight in its UTM zone and a DEM or
/// GCP file in the same EPSG code share one definition (no transform between them).
#[test]
fn each_utm_zone_is_its_epsg_code_with_the_usual_definition() {
    for zone in 1..=60u16 {
        for (lat, base, south) in [(10.0, 32600, ""), (-10.0, 32700, " +south")] {
            let lon = -180.0 + 6.0 * (zone as f64 - 0.5);
            let crs = Crs::utm_for(lon, lat).expect("utm");
            assert_eq!(crs.epsg(), Some(base + zone));
            assert_eq!(
                crs.definition(),
                format!("+proj=utm +zone={zone}{south} +datum=WGS84 +units=m +no_defs")
            );
        }
    }
}

/// Found by the fuzzer (tests/fuzz.rs, a WKT with 4096 '[' inserted): proj4wkt parses by
/// recursion and overflowed the stack, aborting the process; a GeoTIFF's WKT citation or
/// a .prj beside a pose table reaches it as well.
#[test]
fn deeply_nested_wkt_is_refused_not_a_stack_overflow() {
    let w = format!("PROJCS[\"x\",{}", "GEOGCS[".repeat(100_000));
    let e = Crs::parse(&w).unwrap_err().to_string();
    assert!(e.contains("nested 100001 deep"), "{e}");
    let e = Crs::from_wkt(w).unwrap_err().to_string();
    assert!(e.contains("nested 100001 deep"), "{e}");
}
