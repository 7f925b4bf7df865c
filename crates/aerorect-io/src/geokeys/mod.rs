//! The GeoTIFF GeoKey directory (tag 34735, with its doubles in 34736 and text in 34737):
//! read into a [`Crs`] and written from one.
//!
//! Read: EPSG codes (ProjectedCSTypeGeoKey, GeographicTypeGeoKey); user-defined CRSs as GDAL
//! writes them, either as projection keys (transverse Mercator, Mercator, Lambert conformal
//! conic, Albers; UTM by ProjectionGeoKey) turned into a PROJ string, or as a WKT in a citation
//! key ("ESRI PE String = <WKT>"). Written: an EPSG code in its key; a WKT as a user-defined
//! CRS with that citation (GDAL reads it); a transverse Mercator / UTM / longlat PROJ string as
//! the projection keys GDAL itself writes.

pub(crate) mod error;
mod keys;
mod write;

pub use error::GeoKeyError;
pub(crate) use keys::{GEO_ASCII_PARAMS, GEO_DOUBLE_PARAMS, GEO_KEY_DIRECTORY};
pub(crate) use write::encode;

use aerorect_geo::{Crs, CrsForm, proj_params};
use keys::*;
use std::collections::BTreeMap;

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

impl GeoKeys {
    /// Parses the directory; `doubles` and `ascii` are the contents of tags 34736 and 34737.
    pub(crate) fn parse(dir: &[u16], doubles: &[f64], ascii: &str) -> Result<GeoKeys, GeoKeyError> {
        let count = *dir.get(3).ok_or(GeoKeyError::ShortDirectory)? as usize;
        let mut keys = BTreeMap::new();
        for k in dir[4..].chunks_exact(4).take(count) {
            let (id, loc, n, off) = (k[0], k[1], k[2] as usize, k[3] as usize);
            let value = match loc {
                0 => Value::Short(off as u16),
                GEO_DOUBLE_PARAMS => Value::Doubles(
                    doubles
                        .get(off..off + n)
                        .ok_or(GeoKeyError::PastParams {
                            key: id,
                            tag: "GeoDoubleParams",
                        })?
                        .to_vec(),
                ),
                GEO_ASCII_PARAMS => {
                    let s = ascii.get(off..off + n).ok_or(GeoKeyError::PastParams {
                        key: id,
                        tag: "GeoAsciiParams",
                    })?;
                    Value::Ascii(s.trim_end_matches(['|', '\0']).to_string())
                }
                GEO_KEY_DIRECTORY => Value::Short(dir.get(off).copied().unwrap_or(0)),
                tag => return Err(GeoKeyError::UnknownTag { key: id, tag }),
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
    pub(crate) fn crs(&self) -> Result<Crs, GeoKeyError> {
        Ok(Crs::from_form(self.form()?)?)
    }

    /// The form of the CRS the keys describe, not yet built.
    fn form(&self) -> Result<CrsForm, GeoKeyError> {
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
            return Err(GeoKeyError::Unsupported {
                key: MODEL_TYPE,
                value: model.unwrap_or_default(),
            });
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
            Some(value) => {
                return Err(GeoKeyError::Unsupported {
                    key: LINEAR_UNITS,
                    value,
                });
            }
        };
        Ok(CrsForm::Proj(format!("{proj} {geog} +units={units}")))
    }

    /// The datum/ellipsoid part of a PROJ string.
    fn geographic_params(&self) -> Result<String, GeoKeyError> {
        if let Some(value) = self.short(GEOG_ANGULAR_UNITS).filter(|v| *v != 9102) {
            return Err(GeoKeyError::NotDegrees { value });
        }
        if let Some(value) = self.short(GEOG_PRIME_MERIDIAN).filter(|v| *v != 8901) {
            return Err(GeoKeyError::NotGreenwich { value });
        }
        match self.short(GEOGRAPHIC_TYPE) {
            Some(code) if code != USER_DEFINED && code != 0 => {
                let def = crs_definitions::from_code(code)
                    .ok_or(GeoKeyError::UnknownGeographic { code })?;
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
        let a = self
            .double(GEOG_SEMI_MAJOR)
            .ok_or(GeoKeyError::NoEllipsoid)?;
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
    fn projection_params(&self) -> Result<String, GeoKeyError> {
        let d = |ids: &[u16]| ids.iter().find_map(|id| self.double(*id)).unwrap_or(0.0);
        let ct = match self.short(COORD_TRANS) {
            Some(ct) => ct,
            None => {
                return match self.short(PROJECTION) {
                    Some(p @ 16001..=16060) => Ok(format!("+proj=utm +zone={}", p - 16000)),
                    Some(p @ 16101..=16160) => Ok(format!("+proj=utm +zone={} +south", p - 16100)),
                    Some(value) => Err(GeoKeyError::Unsupported {
                        key: PROJECTION,
                        value,
                    }),
                    None => Err(GeoKeyError::NoProjection),
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
            value => {
                return Err(GeoKeyError::Unsupported {
                    key: COORD_TRANS,
                    value,
                });
            }
        })
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
        assert_eq!(
            e,
            GeoKeyError::Unsupported {
                key: 3075,
                value: 99
            }
        );
        assert!(
            e.to_string().contains("ProjCoordTransGeoKey (3075) = 99"),
            "{e}"
        );
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
