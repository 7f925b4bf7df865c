//! senseFly's `geoinfo.txt` (eMotion's export): a `#Rev:` line, the header `fileName latitude
//! longitude altitude_amsl altitude_wgs84 heading pitch roll`, then one tab-separated line a
//! photo (a trailing tab is usual). Heights: altitude_amsl (above sea level, like EXIF
//! GPSAltitude) is the photo's z; the angles are senseFly's, read like its XMP.

use super::{EoRecord, number};
use crate::metadata::{BodyAngles, BodySchema};
use crate::table_error::TableError;

const HEADER: [&str; 8] = [
    "filename",
    "latitude",
    "longitude",
    "altitude_amsl",
    "altitude_wgs84",
    "heading",
    "pitch",
    "roll",
];

pub(super) fn parse(text: &str) -> Result<Vec<EoRecord>, TableError> {
    let mut cols: Option<Vec<usize>> = None;
    let mut out = vec![];
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        if l.trim().is_empty() || l.trim_start().starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split('\t').map(str::trim).collect();
        let Some(c) = &cols else {
            let names: Vec<String> = f.iter().map(|s| s.to_ascii_lowercase()).collect();
            let idx = HEADER
                .iter()
                .map(|h| {
                    names
                        .iter()
                        .position(|x| x == h)
                        .ok_or_else(|| TableError::MissingColumn {
                            line: n,
                            column: h.to_string(),
                        })
                })
                .collect::<Result<Vec<usize>, TableError>>()?;
            cols = Some(idx);
            continue;
        };
        let get = |k: usize| -> Result<f64, TableError> {
            let v = f.get(c[k]).copied().unwrap_or("");
            number(n, HEADER[k], v)
        };
        out.push(EoRecord {
            name: f[c[0]].to_string(),
            line: n,
            position: [get(2)?, get(1)?],
            z_m: Some(get(3)?),
            angles: Some(BodyAngles {
                yaw_deg: get(5)?,
                pitch_deg: get(6)?,
                roll_deg: get(7)?,
                schema: BodySchema::SenseflyGeoinfo,
            }),
            accuracy_m: None,
        });
    }
    Ok(out)
}
