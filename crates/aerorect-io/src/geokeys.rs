//! The GeoTIFF GeoKey directory (tag 34735, with its doubles in 34736 and text in 34737):
//! read into a [`Crs`] and written from one.
//!
//! Read: EPSG codes (ProjectedCSTypeGeoKey, GeographicTypeGeoKey); user-defined CRSs as GDAL
//! writes them, either as projection keys (transverse Mercator, Mercator, Lambert conformal
//! conic, Albers; UTM by ProjectionGeoKey) turned into a PROJ string, or as a WKT in a citation
//! key ("ESRI PE String = <WKT>"). Written: an EPSG code in its key; a WKT as a user-defined
//! CRS with that citation (GDAL reads it); a transverse Mercator / UTM / longlat PROJ string as
//! the projection keys GDAL itself writes.

use crate::error::IoError;
use aerorect_geo::{Crs, CrsForm, TmParams, proj_params, tm_params};
use std::collections::BTreeMap;

pub(crate) const GEO_KEY_DIRECTORY: u16 = 34735;
pub(crate) const GEO_DOUBLE_PARAMS: u16 = 34736;
pub(crate) const GEO_ASCII_PARAMS: u16 = 34737;

const USER_DEFINED: u16 = 32767;
const ESRI_PE: &str = "ESRI PE String = ";

// GeoKey ids (GeoTIFF 1.0 / OGC 19-008).
const MODEL_TYPE: u16 = 1024;
const RASTER_TYPE: u16 = 1025;
const GT_CITATION: u16 = 1026;
const GEOGRAPHIC_TYPE: u16 = 2048;
const GEOG_DATUM: u16 = 2050;
const GEOG_PRIME_MERIDIAN: u16 = 2051;
const GEOG_ANGULAR_UNITS: u16 = 2054;
const GEOG_ELLIPSOID: u16 = 2056;
const GEOG_SEMI_MAJOR: u16 = 2057;
const GEOG_SEMI_MINOR: u16 = 2058;
const GEOG_INV_FLATTENING: u16 = 2059;
const PROJECTED_TYPE: u16 = 3072;
const PCS_CITATION: u16 = 3073;
const PROJECTION: u16 = 3074;
const COORD_TRANS: u16 = 3075;
const LINEAR_UNITS: u16 = 3076;
const STD_PARALLEL_1: u16 = 3078;
const STD_PARALLEL_2: u16 = 3079;
const NAT_ORIGIN_LONG: u16 = 3080;
const NAT_ORIGIN_LAT: u16 = 3081;
const FALSE_EASTING: u16 = 3082;
const FALSE_NORTHING: u16 = 3083;
const FALSE_ORIGIN_LONG: u16 = 3084;
const FALSE_ORIGIN_LAT: u16 = 3085;
const FALSE_ORIGIN_EASTING: u16 = 3086;
const FALSE_ORIGIN_NORTHING: u16 = 3087;
const CENTER_LONG: u16 = 3088;
const CENTER_LAT: u16 = 3089;
const SCALE_AT_NAT_ORIGIN: u16 = 3092;

#[derive(Debug, Clone, PartialEq)]
enum Value {
    Short(u16),
    Doubles(Vec<f64>),
    Ascii(String),
}

/// A parsed GeoKey directory.
#[derive(Debug, Clone, Default)]
pub(crate) struct GeoKeys {
    keys: BTreeMap<u16, Value>,
}

/// The name of a key in messages: "ProjCoordTransGeoKey (3075)".
fn key_name(id: u16) -> String {
    let name = match id {
        MODEL_TYPE => "GTModelTypeGeoKey",
        RASTER_TYPE => "GTRasterTypeGeoKey",
        GEOGRAPHIC_TYPE => "GeographicTypeGeoKey",
        GEOG_DATUM => "GeogGeodeticDatumGeoKey",
        GEOG_PRIME_MERIDIAN => "GeogPrimeMeridianGeoKey",
        GEOG_ANGULAR_UNITS => "GeogAngularUnitsGeoKey",
        GEOG_ELLIPSOID => "GeogEllipsoidGeoKey",
        PROJECTED_TYPE => "ProjectedCSTypeGeoKey",
        PROJECTION => "ProjectionGeoKey",
        COORD_TRANS => "ProjCoordTransGeoKey",
        LINEAR_UNITS => "ProjLinearUnitsGeoKey",
        _ => "GeoKey",
    };
    format!("{name} ({id})")
}

impl GeoKeys {
    /// Parses the directory; `doubles` and `ascii` are the contents of tags 34736 and 34737.
    pub(crate) fn parse(dir: &[u16], doubles: &[f64], ascii: &str) -> Result<GeoKeys, String> {
        let count = *dir
            .get(3)
            .ok_or("GeoKeyDirectory is shorter than its header")? as usize;
        let mut keys = BTreeMap::new();
        for k in dir[4..].chunks_exact(4).take(count) {
            let (id, loc, n, off) = (k[0], k[1], k[2] as usize, k[3] as usize);
            let value = match loc {
                0 => Value::Short(off as u16),
                GEO_DOUBLE_PARAMS => Value::Doubles(
                    doubles
                        .get(off..off + n)
                        .ok_or_else(|| format!("{} points past GeoDoubleParams", key_name(id)))?
                        .to_vec(),
                ),
                GEO_ASCII_PARAMS => {
                    let s = ascii
                        .get(off..off + n)
                        .ok_or_else(|| format!("{} points past GeoAsciiParams", key_name(id)))?;
                    Value::Ascii(s.trim_end_matches(['|', '\0']).to_string())
                }
                GEO_KEY_DIRECTORY => Value::Short(dir.get(off).copied().unwrap_or(0)),
                other => return Err(format!("{} is stored in unknown tag {other}", key_name(id))),
            };
            keys.insert(id, value);
        }
        Ok(GeoKeys { keys })
    }

    fn short(&self, id: u16) -> Option<u16> {
        match self.keys.get(&id)? {
            Value::Short(v) => Some(*v),
            _ => None,
        }
    }

    fn double(&self, id: u16) -> Option<f64> {
        match self.keys.get(&id)? {
            Value::Doubles(v) => v.first().copied(),
            _ => None,
        }
    }

    fn ascii(&self, id: u16) -> Option<&str> {
        match self.keys.get(&id)? {
            Value::Ascii(s) => Some(s),
            _ => None,
        }
    }

    /// GTRasterTypeGeoKey = RasterPixelIsPoint: the tie point is a pixel centre.
    pub(crate) fn pixel_is_point(&self) -> bool {
        self.short(RASTER_TYPE) == Some(2)
    }

    /// The CRS the keys describe, built; an error names the key and value that could not be
    /// used, or the CRS that does not build.
    pub(crate) fn crs(&self) -> Result<Crs, String> {
        Crs::from_form(self.form()?).map_err(|e| e.to_string())
    }

    /// The form of the CRS the keys describe, not yet built.
    fn form(&self) -> Result<CrsForm, String> {
        let model = self.short(MODEL_TYPE);
        let projected = match model {
            Some(1) => true,
            None => self.keys.contains_key(&PROJECTED_TYPE),
            _ => false,
        };
        let type_key = if projected {
            PROJECTED_TYPE
        } else {
            GEOGRAPHIC_TYPE
        };
        match self.short(type_key) {
            Some(code) if code != USER_DEFINED && code != 0 && model != Some(USER_DEFINED) => {
                return Ok(CrsForm::Epsg(code));
            }
            _ => {}
        }
        for id in [GT_CITATION, PCS_CITATION] {
            if let Some(w) = self
                .ascii(id)
                .and_then(|c| c.find(ESRI_PE).map(|i| &c[i..]))
            {
                let w = &w[ESRI_PE.len()..];
                return Ok(CrsForm::Wkt(w.trim().to_string()));
            }
        }
        if !matches!(model, Some(1) | Some(2) | None) {
            return Err(format!(
                "{} = {} is not supported",
                key_name(MODEL_TYPE),
                model.unwrap_or_default()
            ));
        }
        let geog = self.geographic_params()?;
        if !projected {
            return Ok(CrsForm::Proj(format!("+proj=longlat {geog}")));
        }
        let proj = self.projection_params()?;
        let units = match self.short(LINEAR_UNITS) {
            None | Some(9001) => "m",
            Some(9002) => "ft",
            Some(9003) => "us-ft",
            Some(v) => return Err(format!("{} = {v} is not supported", key_name(LINEAR_UNITS))),
        };
        Ok(CrsForm::Proj(format!("{proj} {geog} +units={units}")))
    }

    /// The datum/ellipsoid part of a PROJ string.
    fn geographic_params(&self) -> Result<String, String> {
        if let Some(v) = self.short(GEOG_ANGULAR_UNITS).filter(|v| *v != 9102) {
            return Err(format!(
                "{} = {v} is not degrees",
                key_name(GEOG_ANGULAR_UNITS)
            ));
        }
        if let Some(v) = self.short(GEOG_PRIME_MERIDIAN).filter(|v| *v != 8901) {
            return Err(format!(
                "{} = {v} is not Greenwich",
                key_name(GEOG_PRIME_MERIDIAN)
            ));
        }
        match self.short(GEOGRAPHIC_TYPE) {
            Some(code) if code != USER_DEFINED && code != 0 => {
                let def = crs_definitions::from_code(code).ok_or_else(|| {
                    format!(
                        "{} = {code} is not a known EPSG code",
                        key_name(GEOGRAPHIC_TYPE)
                    )
                })?;
                let rest: Vec<String> = proj_params(def.proj4)
                    .into_iter()
                    .filter(|(k, _)| !matches!(k.as_str(), "proj" | "no_defs" | "units"))
                    .map(|(k, v)| {
                        if v.is_empty() {
                            format!("+{k}")
                        } else {
                            format!("+{k}={v}")
                        }
                    })
                    .collect();
                return Ok(rest.join(" "));
            }
            _ => {}
        }
        match (self.short(GEOG_DATUM), self.short(GEOG_ELLIPSOID)) {
            (Some(6326), _) => return Ok("+datum=WGS84".into()),
            (_, Some(7030)) => return Ok("+ellps=WGS84".into()),
            (_, Some(7019)) => return Ok("+ellps=GRS80".into()),
            _ => {}
        }
        let a = self.double(GEOG_SEMI_MAJOR).ok_or_else(|| {
            "the geographic CRS has no EPSG code, datum, ellipsoid or GeogSemiMajorAxisGeoKey"
                .to_string()
        })?;
        match (
            self.double(GEOG_INV_FLATTENING),
            self.double(GEOG_SEMI_MINOR),
        ) {
            (Some(rf), _) => Ok(format!("+a={a} +rf={rf}")),
            (None, Some(b)) => Ok(format!("+a={a} +b={b}")),
            (None, None) => Ok(format!("+a={a} +b={a}")),
        }
    }

    /// The projection part of a PROJ string, from ProjCoordTransGeoKey and its parameters.
    fn projection_params(&self) -> Result<String, String> {
        let d = |ids: &[u16]| ids.iter().find_map(|id| self.double(*id)).unwrap_or(0.0);
        let ct = match self.short(COORD_TRANS) {
            Some(ct) => ct,
            None => {
                return match self.short(PROJECTION) {
                    Some(p @ 16001..=16060) => Ok(format!("+proj=utm +zone={}", p - 16000)),
                    Some(p @ 16101..=16160) => Ok(format!("+proj=utm +zone={} +south", p - 16100)),
                    Some(p) => Err(format!("{} = {p} is not supported", key_name(PROJECTION))),
                    None => Err(format!(
                        "no {} or {}",
                        key_name(COORD_TRANS),
                        key_name(PROJECTION)
                    )),
                };
            }
        };
        let lon0 = d(&[NAT_ORIGIN_LONG, FALSE_ORIGIN_LONG, CENTER_LONG]);
        let lat0 = d(&[NAT_ORIGIN_LAT, FALSE_ORIGIN_LAT, CENTER_LAT]);
        let x0 = d(&[FALSE_EASTING, FALSE_ORIGIN_EASTING]);
        let y0 = d(&[FALSE_NORTHING, FALSE_ORIGIN_NORTHING]);
        let k = self.double(SCALE_AT_NAT_ORIGIN).unwrap_or(1.0);
        let (p1, p2) = (d(&[STD_PARALLEL_1]), d(&[STD_PARALLEL_2]));
        let common = format!("+lat_0={lat0} +lon_0={lon0} +x_0={x0} +y_0={y0}");
        Ok(match ct {
            1 => format!("+proj=tmerc {common} +k={k}"),
            7 => format!("+proj=merc +lon_0={lon0} +x_0={x0} +y_0={y0} +k={k}"),
            8 => format!("+proj=lcc +lat_1={p1} +lat_2={p2} {common}"),
            9 => format!("+proj=lcc +lat_1={lat0} {common} +k_0={k}"),
            11 => format!("+proj=aea +lat_1={p1} +lat_2={p2} {common}"),
            v => return Err(format!("{} = {v} is not supported", key_name(COORD_TRANS))),
        })
    }
}

/// The GeoKey directory, doubles and text that describe `crs` (PixelIsArea).
pub(crate) fn encode(crs: &Crs) -> Result<(Vec<u16>, Vec<f64>, String), IoError> {
    let mut w = Writer::default();
    let geographic = crs.is_geographic();
    // GDAL reads the WKT citation of a user-defined model type (its ESRI_PE key flavour).
    let model = match crs.form() {
        CrsForm::Wkt(_) => USER_DEFINED,
        _ if geographic => 2,
        _ => 1,
    };
    w.short(MODEL_TYPE, model);
    w.short(RASTER_TYPE, 1);
    match crs.form() {
        CrsForm::Epsg(code) if geographic => w.short(GEOGRAPHIC_TYPE, *code),
        CrsForm::Epsg(code) => {
            w.short(PROJECTED_TYPE, *code);
            if proj_params(crs.definition())
                .get("units")
                .map(String::as_str)
                == Some("m")
            {
                w.short(LINEAR_UNITS, 9001);
            }
        }
        CrsForm::Wkt(wkt) => {
            w.ascii(PCS_CITATION, &format!("{ESRI_PE}{wkt}"));
            w.short(
                if geographic {
                    GEOGRAPHIC_TYPE
                } else {
                    PROJECTED_TYPE
                },
                USER_DEFINED,
            );
        }
        CrsForm::Proj(p) => {
            let t = tm_params(p)?.ok_or_else(|| {
                IoError::field(
                    "CRS",
                    format!("'{p}': GeoTIFF output takes an EPSG code, a WKT, or a longlat, tmerc or utm PROJ string"),
                )
            })?;
            w.proj_keys(&t);
        }
    }
    Ok(w.finish())
}

#[derive(Default)]
struct Writer {
    keys: BTreeMap<u16, [u16; 3]>,
    doubles: Vec<f64>,
    ascii: String,
}

impl Writer {
    fn short(&mut self, id: u16, v: u16) {
        self.keys.insert(id, [0, 1, v]);
    }

    fn double(&mut self, id: u16, v: f64) {
        self.keys
            .insert(id, [GEO_DOUBLE_PARAMS, 1, self.doubles.len() as u16]);
        self.doubles.push(v);
    }

    fn ascii(&mut self, id: u16, s: &str) {
        let text = format!("{s}|");
        self.keys.insert(
            id,
            [GEO_ASCII_PARAMS, text.len() as u16, self.ascii.len() as u16],
        );
        self.ascii.push_str(&text);
    }

    /// The keys GDAL writes for a user-defined transverse Mercator (or longlat) CRS.
    fn proj_keys(&mut self, t: &TmParams) {
        if t.ellps_name == "WGS 84" {
            self.short(GEOGRAPHIC_TYPE, 4326);
        } else {
            self.short(GEOGRAPHIC_TYPE, USER_DEFINED);
            self.short(GEOG_DATUM, USER_DEFINED);
            self.short(GEOG_ANGULAR_UNITS, 9102);
            self.double(GEOG_SEMI_MAJOR, t.a);
            self.double(GEOG_INV_FLATTENING, t.rf);
        }
        let Some([lat0, lon0, k, x0, y0]) = t.tm else {
            return;
        };
        self.short(PROJECTED_TYPE, USER_DEFINED);
        self.short(PROJECTION, USER_DEFINED);
        self.short(COORD_TRANS, 1);
        self.short(LINEAR_UNITS, 9001);
        self.double(NAT_ORIGIN_LONG, lon0);
        self.double(NAT_ORIGIN_LAT, lat0);
        self.double(FALSE_EASTING, x0);
        self.double(FALSE_NORTHING, y0);
        self.double(SCALE_AT_NAT_ORIGIN, k);
    }

    fn finish(self) -> (Vec<u16>, Vec<f64>, String) {
        let mut dir = vec![1, 1, 0, self.keys.len() as u16];
        for (id, [loc, n, v]) in self.keys {
            dir.extend_from_slice(&[id, loc, n, v]);
        }
        (dir, self.doubles, self.ascii)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The keys of ../shared/data/ngi/dem.tif as tifffile lists them.
    const DEM_DIR: [u16; 72] = [
        1, 1, 1, 17, 1024, 0, 1, 1, 1025, 0, 1, 1, 1026, 34737, 28, 0, 2048, 0, 1, 4326, 3072, 0,
        1, 32767, 3074, 0, 1, 32767, 3075, 0, 1, 1, 3076, 0, 1, 9001, 3080, 34736, 1, 1, 3081,
        34736, 1, 0, 3082, 34736, 1, 3, 3083, 34736, 1, 4, 3092, 34736, 1, 2, 4096, 0, 1, 32767,
        4097, 34737, 15, 28, 4098, 0, 1, 32767, 4099, 0, 1, 32767,
    ];

    #[test]
    fn gdal_user_defined_tm_becomes_a_proj_string() {
        let ascii = "Lo25 WGS84 + EGM2008 height|EGM2008 height|";
        let keys = GeoKeys::parse(&DEM_DIR, &[0.0, 25.0, 1.0, 0.0, 0.0], ascii).expect("keys");
        let crs = keys.crs().expect("crs");
        assert_eq!(
            crs.form(),
            &CrsForm::Proj(
                "+proj=tmerc +lat_0=0 +lon_0=25 +x_0=0 +y_0=0 +k=1 +datum=WGS84 +units=m".into()
            )
        );
    }

    #[test]
    fn unknown_projection_names_the_key_and_value() {
        let mut dir = DEM_DIR;
        dir[31] = 99; // ProjCoordTransGeoKey
        let ascii = "Lo25 WGS84 + EGM2008 height|EGM2008 height|";
        let keys = GeoKeys::parse(&dir, &[0.0, 25.0, 1.0, 0.0, 0.0], ascii).expect("keys");
        let e = keys.crs().unwrap_err();
        assert!(e.contains("ProjCoordTransGeoKey (3075) = 99"), "{e}");
    }

    #[test]
    fn gdals_esri_pe_flavour_gives_its_wkt() {
        // GDAL 3.10 (rasterio), GEOTIFF_KEYS_FLAVOR=ESRI_PE, CRS "+proj=tmerc +lon_0=25
        // +datum=WGS84": the directory and citations it wrote (tifffile), doubles left out.
        let dir = [
            1, 1, 0, 4, 1024, 0, 1, 32767, 1025, 0, 1, 1, 1026, 34737, 8, 0, 3073, 34737, 396, 8,
        ];
        let wkt = "PROJCS[\"unknown\",GEOGCS[\"GCS_unknown\",DATUM[\"D_WGS_1984\",\
            SPHEROID[\"WGS_1984\",6378137.0,298.257223563]],PRIMEM[\"Greenwich\",0.0],\
            UNIT[\"Degree\",0.0174532925199433]],PROJECTION[\"Transverse_Mercator\"],\
            PARAMETER[\"False_Easting\",0.0],PARAMETER[\"False_Northing\",0.0],\
            PARAMETER[\"Central_Meridian\",25.0],PARAMETER[\"Scale_Factor\",1.0],\
            PARAMETER[\"Latitude_Of_Origin\",0.0],UNIT[\"Meter\",1.0]]";
        let citation = format!("ESRI PE String = {wkt}");
        let mut dir = dir.to_vec();
        dir[18] = citation.len() as u16 + 1;
        let ascii = format!("unknown|{citation}|");
        let crs = GeoKeys::parse(&dir, &[], &ascii)
            .expect("keys")
            .crs()
            .expect("crs");
        assert_eq!(crs.form(), &CrsForm::Wkt(wkt.to_string()));
        let tm = Crs::from_proj_string("+proj=tmerc +lon_0=25 +datum=WGS84").expect("tm");
        let (a, b) = (
            crs.from_lon_lat(24.4, -33.7).expect("a"),
            tm.from_lon_lat(24.4, -33.7).expect("b"),
        );
        assert!((a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6);
    }

    #[test]
    fn written_keys_read_back() {
        let utm35s = Crs::from_epsg(32735).expect("utm");
        for crs in [
            Crs::from_epsg(32635),
            Crs::from_epsg(4326),
            Crs::from_wkt(utm35s.to_wkt().expect("wkt")),
            Crs::from_proj_string(
                "+proj=tmerc +lat_0=0 +lon_0=25 +x_0=0 +y_0=0 +k=1 +datum=WGS84 +units=m",
            ),
        ] {
            let crs = crs.expect("crs");
            let (dir, doubles, ascii) = encode(&crs).expect("encode");
            let back = GeoKeys::parse(&dir, &doubles, &ascii)
                .expect("parse")
                .crs()
                .expect("crs");
            let a = crs.from_lon_lat(26.0, -33.0).expect("a");
            let b = back.from_lon_lat(26.0, -33.0).expect("b");
            assert!(
                (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6,
                "{crs} vs {back}"
            );
        }
    }
}
