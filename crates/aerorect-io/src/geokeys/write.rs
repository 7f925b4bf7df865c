//! The GeoKeys that describe a CRS, written as GDAL writes them.

use super::keys::*;
use crate::error::IoError;
use aerorect_geo::{Crs, CrsForm, TmParams, proj_params, tm_params};
use std::collections::BTreeMap;

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
