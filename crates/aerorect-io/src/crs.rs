//! Coordinate reference systems as users and files give them: an EPSG code, a WKT text or a
//! PROJ string. Every CRS is checked by building it with `proj4rs`, so one that would not
//! project is refused where it is read, naming the text.
//!
//! EPSG codes are resolved with the `crs-definitions` table (PROJ and WKT forms), WKT with
//! `proj4wkt`. A PROJ string gets a WKT (for `.prj` sidecars) only for the forms written here:
//! longlat, transverse Mercator and UTM on a named or explicit ellipsoid, in metres.

use crate::error::IoError;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt;

/// A coordinate reference system.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Crs {
    /// An EPSG code, e.g. 32635 for WGS 84 / UTM zone 35N.
    Epsg(u16),
    /// OGC or ESRI WKT (WKT1 or WKT2).
    Wkt(String),
    /// A PROJ string, e.g. "+proj=tmerc +lon_0=25 +datum=WGS84 +units=m".
    Proj(String),
}

const SOURCE: &str = "CRS";

impl Crs {
    /// Reads a CRS from user input: "EPSG:32651" (any case), a "+proj=..." string, or WKT
    /// (PROJCS, PROJCRS, GEOGCS, GEOGCRS, COMPD_CS, ...). The result is checked with proj4rs.
    pub fn parse(text: &str) -> Result<Crs, IoError> {
        let t = text.trim();
        let crs = if let Some(code) = strip_prefix_ci(t, "EPSG:") {
            let code = code.trim();
            if code.is_empty() || !code.bytes().all(|b| b.is_ascii_digit()) {
                return Err(IoError::field(
                    SOURCE,
                    format!("'{t}': the EPSG code '{code}' is not a whole number"),
                ));
            }
            // Every EPSG code of the table fits 16 bits: a longer one is unknown.
            match code.parse::<u16>() {
                Ok(c) => Crs::Epsg(c),
                Err(_) => return Err(unknown_epsg(code)),
            }
        } else if t.starts_with('+') {
            Crs::Proj(t.to_string())
        } else if looks_like_wkt(t) {
            Crs::Wkt(t.to_string())
        } else {
            return Err(IoError::field(
                SOURCE,
                format!("'{t}' is not EPSG:<code>, a +proj= string or WKT"),
            ));
        };
        crs.to_proj()?;
        Ok(crs)
    }

    /// Whether `other` is this CRS: the same text, or the same PROJ parameters (an EPSG code
    /// and the WKT of a `.prj` written for it).
    pub fn same_as(&self, other: &Crs) -> bool {
        if self == other {
            return true;
        }
        if let (Some(a), Some(b)) = (self.epsg_equivalent(), other.epsg_equivalent()) {
            return a == b;
        }
        match (self.to_proj_string(), other.to_proj_string()) {
            (Ok(a), Ok(b)) => proj_params(&a) == proj_params(&b),
            _ => false,
        }
    }

    /// The EPSG code, or the one a WKT names for itself (its last, outermost
    /// `AUTHORITY["EPSG","N"]` or `ID["EPSG",N]`).
    fn epsg_equivalent(&self) -> Option<u16> {
        match self {
            Crs::Epsg(c) => Some(*c),
            Crs::Wkt(w) => {
                let w = w.trim().strip_suffix(']')?.trim_end();
                let (head, code) = w.strip_suffix(']')?.rsplit_once(',')?;
                let authority = head.trim_end().strip_suffix("\"EPSG\"")?;
                let authority = authority.trim_end();
                if !(authority.ends_with("AUTHORITY[") || authority.ends_with("ID[")) {
                    return None;
                }
                code.trim().trim_matches('"').parse().ok()
            }
            Crs::Proj(_) => None,
        }
    }

    /// The EPSG code, when the CRS is given by one.
    pub fn epsg(&self) -> Option<u16> {
        match self {
            Crs::Epsg(c) => Some(*c),
            _ => None,
        }
    }

    /// The PROJ string of this CRS; an error names a CRS that does not convert.
    pub fn to_proj_string(&self) -> Result<String, IoError> {
        let s = match self {
            Crs::Epsg(c) => epsg_definition(*c)?.proj4.to_string(),
            Crs::Wkt(w) => {
                check_wkt_depth(w)?;
                proj4wkt::wkt_to_projstring(w).map_err(|e| {
                    IoError::field(SOURCE, format!("WKT '{}' does not convert: {e}", short(w)))
                })?
            }
            Crs::Proj(p) => p.clone(),
        };
        Ok(s)
    }

    /// The CRS built by proj4rs (which also checks that it parses).
    pub fn to_proj(&self) -> Result<proj4rs::Proj, IoError> {
        let s = self.to_proj_string()?;
        proj4rs::Proj::from_proj_string(&s)
            .map_err(|e| IoError::field(SOURCE, format!("'{}' does not parse: {e}", short(&s))))
    }

    /// True for a longitude/latitude CRS.
    pub fn is_geographic(&self) -> Result<bool, IoError> {
        Ok(self.to_proj()?.is_latlong())
    }

    /// OGC WKT1 of this CRS (for `.prj` and `.aux.xml` sidecars). PROJ strings are converted
    /// for longlat, tmerc and utm only.
    pub fn to_wkt(&self) -> Result<String, IoError> {
        match self {
            Crs::Epsg(c) => Ok(epsg_definition(*c)?.wkt.to_string()),
            Crs::Wkt(w) => Ok(w.clone()),
            Crs::Proj(p) => wkt_of_proj(p),
        }
    }

    /// Projects longitude/latitude (degrees, WGS 84) into this CRS: (x, y) in its units.
    pub fn project_lon_lat(&self, lon_deg: f64, lat_deg: f64) -> Result<[f64; 2], IoError> {
        let dst = self.to_proj()?;
        let src = proj4rs::Proj::from_proj_string("+proj=longlat +datum=WGS84")
            .map_err(|e| IoError::field(SOURCE, e))?;
        let mut p = (lon_deg.to_radians(), lat_deg.to_radians(), 0.0);
        proj4rs::transform::transform(&src, &dst, &mut p)
            .map_err(|e| IoError::field(SOURCE, format!("{self}: cannot project: {e}")))?;
        if dst.is_latlong() {
            Ok([p.0.to_degrees(), p.1.to_degrees()])
        } else {
            Ok([p.0, p.1])
        }
    }
}

impl fmt::Display for Crs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Crs::Epsg(c) => write!(f, "EPSG:{c}"),
            Crs::Wkt(w) => write!(f, "{w}"),
            Crs::Proj(p) => write!(f, "{p}"),
        }
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
fn check_wkt_depth(w: &str) -> Result<(), IoError> {
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
        return Err(IoError::field(
            SOURCE,
            format!(
                "WKT '{}' is nested {deepest} deep (at most {MAX_WKT_DEPTH} is read)",
                short(w)
            ),
        ));
    }
    Ok(())
}

/// The first 80 characters of a long CRS text, for messages.
fn short(s: &str) -> String {
    if s.chars().count() <= 80 {
        s.to_string()
    } else {
        format!("{}...", s.chars().take(80).collect::<String>())
    }
}

fn epsg_definition(code: u16) -> Result<crs_definitions::Def, IoError> {
    crs_definitions::from_code(code).ok_or_else(|| unknown_epsg(&code.to_string()))
}

fn unknown_epsg(code: &str) -> IoError {
    IoError::field(
        SOURCE,
        format!("EPSG:{code} is an unknown EPSG code (not in the EPSG table this build carries)"),
    )
}

/// The `+key=value` (or bare `+flag`) parameters of a PROJ string.
pub(crate) fn proj_params(p: &str) -> BTreeMap<String, String> {
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
pub(crate) struct TmParams {
    /// None for longlat.
    pub tm: Option<[f64; 5]>, // lat_0, lon_0, k, x_0, y_0
    /// Semi-major axis and inverse flattening.
    pub a: f64,
    pub rf: f64,
    pub ellps_name: &'static str,
}

/// Splits a longlat / tmerc / utm PROJ string in metres; `None` for other forms.
pub(crate) fn tm_params(p: &str) -> Result<Option<TmParams>, IoError> {
    let m = proj_params(p);
    let num = |k: &str, default: f64| -> Result<f64, IoError> {
        match m.get(k) {
            None => Ok(default),
            Some(v) => v
                .parse::<f64>()
                .map_err(|_| IoError::field(SOURCE, format!("'{p}': +{k}={v} is not a number"))),
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
                return Err(IoError::field(SOURCE, format!("'{p}': bad or no +zone")));
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

fn wkt_of_proj(p: &str) -> Result<String, IoError> {
    let t = tm_params(p)?.ok_or_else(|| {
        IoError::field(
            SOURCE,
            format!("'{p}': no WKT for this PROJ string (longlat, tmerc or utm in metres only)"),
        )
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_epsg_code_is_the_same_crs_as_its_prj_and_not_another_zones() {
        let utm35 = Crs::Epsg(32635);
        let prj = Crs::parse(&utm35.to_wkt().expect("wkt")).expect("prj");
        assert!(matches!(prj, Crs::Wkt(_)));
        assert!(utm35.same_as(&prj) && prj.same_as(&utm35));
        let utm36 = Crs::parse(&Crs::Epsg(32636).to_wkt().expect("wkt")).expect("prj");
        assert!(!utm35.same_as(&utm36) && !prj.same_as(&utm36));
        let wkt2 = Crs::Wkt("PROJCRS[\"x\",BASEGEOGCRS[\"y\"],ID[\"EPSG\",32635]]".into());
        assert_eq!(wkt2.epsg_equivalent(), Some(32635));
        let inner = Crs::Wkt("PROJCS[\"x\",GEOGCS[\"y\",AUTHORITY[\"EPSG\",\"4326\"]]]".into());
        assert_eq!(
            inner.epsg_equivalent(),
            None,
            "only the outermost authority"
        );
    }

    #[test]
    fn parse_accepts_the_three_forms_and_names_bad_text() {
        assert_eq!(Crs::parse("epsg:32651").expect("epsg"), Crs::Epsg(32651));
        assert_eq!(Crs::parse(" EPSG:4326 ").expect("epsg").epsg(), Some(4326));
        let p = "+proj=tmerc +lon_0=25 +datum=WGS84 +units=m";
        assert_eq!(Crs::parse(p).expect("proj"), Crs::Proj(p.into()));
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
        let p = Crs::Proj("+proj=utm +zone=35 +south +datum=WGS84 +units=m".into());
        let w = Crs::Wkt(p.to_wkt().expect("wkt"));
        let e = Crs::Epsg(32735);
        let [x, y] = p.project_lon_lat(27.0, -30.0).expect("proj");
        for other in [w, e] {
            let [x2, y2] = other.project_lon_lat(27.0, -30.0).expect("other");
            assert!((x - x2).abs() < 1e-6 && (y - y2).abs() < 1e-6, "{other}");
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
        let e = Crs::Wkt(w).to_proj().unwrap_err().to_string();
        assert!(e.contains("nested 100001 deep"), "{e}");
    }
}
