//! CRS text: reading user text into a [`CrsForm`], the PROJ definition and WKT of each form,
//! and PROJ strings taken apart.
//!
//! EPSG codes are resolved with the `crs-definitions` table (PROJ and WKT forms), WKT with
//! `proj4wkt`. A PROJ string gets a WKT (for `.prj` sidecars) only for the forms written here:
//! longlat, transverse Mercator and UTM on a named or explicit ellipsoid, in metres.

use super::CrsForm;
use crate::CrsError;
use std::collections::BTreeMap;

/// The form of user text: "EPSG:32651" (any case), a "+proj=..." string, or WKT (PROJCS,
/// PROJCRS, GEOGCS, GEOGCRS, COMPD_CS, ...). Not yet built.
pub(super) fn form_of_text(text: &str) -> Result<CrsForm, CrsError> {
    let t = text.trim();
    if let Some(code) = strip_prefix_ci(t, "EPSG:") {
        let code = code.trim();
        if code.is_empty() || !code.bytes().all(|b| b.is_ascii_digit()) {
            return Err(CrsError::Text(format!(
                "'{t}': the EPSG code '{code}' is not a whole number"
            )));
        }
        // Every EPSG code of the table fits 16 bits: a longer one is unknown.
        match code.parse::<u16>() {
            Ok(c) => Ok(CrsForm::Epsg(c)),
            Err(_) => Err(unknown_epsg(code)),
        }
    } else if t.starts_with('+') {
        Ok(CrsForm::Proj(t.to_string()))
    } else if looks_like_wkt(t) {
        Ok(CrsForm::Wkt(t.to_string()))
    } else {
        Err(CrsError::Text(format!(
            "'{t}' is not EPSG:<code>, a +proj= string or WKT"
        )))
    }
}

/// The EPSG code, or the one a WKT names for itself (its last, outermost
/// `AUTHORITY["EPSG","N"]` or `ID["EPSG",N]`).
pub(super) fn epsg_equivalent(form: &CrsForm) -> Option<u16> {
    match form {
        CrsForm::Epsg(c) => Some(*c),
        CrsForm::Wkt(w) => {
            let w = w.trim().strip_suffix(']')?.trim_end();
            let (head, code) = w.strip_suffix(']')?.rsplit_once(',')?;
            let authority = head.trim_end().strip_suffix("\"EPSG\"")?;
            let authority = authority.trim_end();
            if !(authority.ends_with("AUTHORITY[") || authority.ends_with("ID[")) {
                return None;
            }
            code.trim().trim_matches('"').parse().ok()
        }
        CrsForm::Proj(_) => None,
    }
}

/// The PROJ string of a form; an error names a CRS that does not convert.
pub(super) fn definition_of(form: &CrsForm) -> Result<String, CrsError> {
    let s = match form {
        CrsForm::Epsg(c) => epsg_definition(*c)?.proj4.to_string(),
        CrsForm::Wkt(w) => {
            check_wkt_depth(w)?;
            proj4wkt::wkt_to_projstring(w)
                .map_err(|e| CrsError::Text(format!("WKT '{}' does not convert: {e}", short(w))))?
        }
        CrsForm::Proj(p) => p.clone(),
    };
    Ok(s)
}

/// OGC WKT1 of a form (for `.prj` and `.aux.xml` sidecars). PROJ strings are converted for
/// longlat, tmerc and utm only.
pub(super) fn wkt_of(form: &CrsForm) -> Result<String, CrsError> {
    match form {
        CrsForm::Epsg(c) => Ok(epsg_definition(*c)?.wkt.to_string()),
        CrsForm::Wkt(w) => Ok(w.clone()),
        CrsForm::Proj(p) => wkt_of_proj(p),
    }
}

fn strip_prefix_ci<'a>(t: &'a str, prefix: &str) -> Option<&'a str> {
    let head = t.get(..prefix.len())?;
    head.eq_ignore_ascii_case(prefix)
        .then(|| &t[prefix.len()..])
}

fn looks_like_wkt(t: &str) -> bool {
    const HEADS: [&str; 10] = [
        "PROJCS",
        "PROJCRS",
        "GEOGCS",
        "GEOGCRS",
        "GEODCRS",
        "COMPD_CS",
        "COMPOUNDCRS",
        "PROJECTEDCRS",
        "GEODETICCRS",
        "BOUNDCRS",
    ];
    let head: String = t
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    HEADS.iter().any(|h| head.eq_ignore_ascii_case(h)) && t.contains('[')
}

/// proj4wkt parses nested brackets by recursion, so a text nested deep enough overflows the
/// stack (an abort, not an error); real WKT nests less than ten deep.
const MAX_WKT_DEPTH: usize = 64;

/// Refuses a WKT whose brackets (outside quoted names) nest deeper than [`MAX_WKT_DEPTH`].
fn check_wkt_depth(w: &str) -> Result<(), CrsError> {
    let (mut depth, mut deepest, mut quoted) = (0usize, 0usize, false);
    for c in w.chars() {
        match c {
            '"' => quoted = !quoted,
            '[' | '(' if !quoted => {
                depth += 1;
                deepest = deepest.max(depth);
            }
            ']' | ')' if !quoted => depth = depth.saturating_sub(1),
            _ => {}
        }
    }
    if deepest > MAX_WKT_DEPTH {
        return Err(CrsError::Text(format!(
            "WKT '{}' is nested {deepest} deep (at most {MAX_WKT_DEPTH} is read)",
            short(w)
        )));
    }
    Ok(())
}

/// The first 80 characters of a long CRS text, for messages.
pub(crate) fn short(s: &str) -> String {
    if s.chars().count() <= 80 {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(80).collect::<String>())
    }
}

fn epsg_definition(code: u16) -> Result<crs_definitions::Def, CrsError> {
    crs_definitions::from_code(code).ok_or_else(|| unknown_epsg(&code.to_string()))
}

fn unknown_epsg(code: &str) -> CrsError {
    CrsError::Text(format!(
        "EPSG:{code} is an unknown EPSG code (not in the EPSG table this build carries)"
    ))
}

/// The `+key=value` (or bare `+flag`) parameters of a PROJ string.
pub fn proj_params(p: &str) -> BTreeMap<String, String> {
    p.split_whitespace()
        .filter_map(|t| t.strip_prefix('+'))
        .map(|t| match t.split_once('=') {
            Some((k, v)) => (k.to_string(), v.to_string()),
            None => (t.to_string(), String::new()),
        })
        .collect()
}

/// A transverse Mercator (or longlat) definition in its parts, from a PROJ string.
#[derive(Debug, Clone, PartialEq)]
pub struct TmParams {
    /// None for longlat.
    pub tm: Option<[f64; 5]>, // lat_0, lon_0, k, x_0, y_0
    /// Semi-major axis and inverse flattening.
    pub a: f64,
    pub rf: f64,
    pub ellps_name: &'static str,
}

/// Splits a longlat / tmerc / utm PROJ string in metres; `None` for other forms.
pub fn tm_params(p: &str) -> Result<Option<TmParams>, CrsError> {
    let m = proj_params(p);
    let num = |k: &str, default: f64| -> Result<f64, CrsError> {
        match m.get(k) {
            None => Ok(default),
            Some(v) => v
                .parse::<f64>()
                .map_err(|_| CrsError::Text(format!("'{p}': +{k}={v} is not a number"))),
        }
    };
    let units_ok = m.get("units").is_none_or(|u| u == "m");
    let tm = match m.get("proj").map(String::as_str) {
        Some("longlat") | Some("latlong") | Some("lonlat") | Some("latlon") => None,
        Some("tmerc") | Some("etmerc") if units_ok => Some([
            num("lat_0", 0.0)?,
            num("lon_0", 0.0)?,
            num("k", num("k_0", 1.0)?)?,
            num("x_0", 0.0)?,
            num("y_0", 0.0)?,
        ]),
        Some("utm") if units_ok => {
            let zone = num("zone", f64::NAN)?;
            if !(1.0..=60.0).contains(&zone) || zone.fract() != 0.0 {
                return Err(CrsError::Text(format!("'{p}': bad or no +zone")));
            }
            let y0 = if m.contains_key("south") {
                10_000_000.0
            } else {
                0.0
            };
            Some([0.0, zone * 6.0 - 183.0, 0.9996, 500_000.0, y0])
        }
        _ => return Ok(None),
    };
    let ellps = m.get("ellps").or(m.get("datum")).map(String::as_str);
    let (a, rf, ellps_name) = match (ellps, m.get("a")) {
        (Some("WGS84"), _) => (6_378_137.0, 298.257_223_563, "WGS 84"),
        (Some("GRS80"), _) | (Some("NAD83"), _) => (6_378_137.0, 298.257_222_101, "GRS 1980"),
        (None, Some(_)) => {
            let a = num("a", f64::NAN)?;
            let rf = match (m.get("rf"), m.get("b")) {
                (Some(_), _) => num("rf", f64::NAN)?,
                (None, Some(_)) => a / (a - num("b", f64::NAN)?),
                (None, None) => 0.0,
            };
            (a, rf, "unnamed")
        }
        _ => return Ok(None),
    };
    Ok(Some(TmParams {
        tm,
        a,
        rf,
        ellps_name,
    }))
}

fn wkt_of_proj(p: &str) -> Result<String, CrsError> {
    let t = tm_params(p)?.ok_or_else(|| {
        CrsError::Text(format!(
            "'{p}': no WKT for this PROJ string (longlat, tmerc or utm in metres only)"
        ))
    })?;
    let datum = if t.ellps_name == "WGS 84" {
        "WGS_1984"
    } else {
        "unknown"
    };
    let geog = format!(
        "GEOGCS[\"{n}\",DATUM[\"{datum}\",SPHEROID[\"{n}\",{a},{rf}]],PRIMEM[\"Greenwich\",0],\
         UNIT[\"degree\",0.0174532925199433]]",
        n = t.ellps_name,
        a = t.a,
        rf = t.rf
    );
    Ok(match t.tm {
        None => geog,
        Some([lat0, lon0, k, x0, y0]) => format!(
            "PROJCS[\"unnamed\",{geog},PROJECTION[\"Transverse_Mercator\"],\
             PARAMETER[\"latitude_of_origin\",{lat0}],PARAMETER[\"central_meridian\",{lon0}],\
             PARAMETER[\"scale_factor\",{k}],PARAMETER[\"false_easting\",{x0}],\
             PARAMETER[\"false_northing\",{y0}],UNIT[\"metre\",1],AXIS[\"Easting\",EAST],\
             AXIS[\"Northing\",NORTH]]"
        ),
    })
}
