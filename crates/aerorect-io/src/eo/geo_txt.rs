//! ODM's `geo.txt`: a first line naming the CRS (`EPSG:4326`, a PROJ string, or ODM's
//! `WGS84 UTM 32N`), then `image_name geo_x geo_y [geo_z] [yaw pitch roll [horz_acc
//! vert_acc]]`, separated by spaces or tabs; `#` starts a comment. With EPSG:4326 geo_x is the
//! longitude and geo_y the latitude. Yaw, pitch, roll are ODM's, the XMP convention (pitch 0 =
//! nadir, yaw clockwise from north).

use super::{EoRecord, angles, group, number};
use crate::metadata::BodySchema;
use crate::table_error::TableError;

/// The CRS (`None` for WGS84 longitude, latitude) and the lines.
pub(super) fn parse(text: &str) -> Result<(Option<String>, Vec<EoRecord>), TableError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let Some((_, crs)) = lines.next() else {
        return Err(TableError::Table(
            "empty: the first line must name the CRS".into(),
        ));
    };
    let crs = crs_of(crs)?;
    let mut out = vec![];
    for (n, l) in lines {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() < 3 {
            let what = format!("'{l}' needs at least image_name geo_x geo_y");
            return Err(TableError::line(n, what));
        }
        let z = f.get(3).map(|z| number(n, "geo_z", z)).transpose()?;
        let ypr = group(n, &f, 4, &["yaw", "pitch", "roll"])?;
        let acc = group(n, &f, 7, &["horz_accuracy", "vert_accuracy"])?;
        out.push(EoRecord {
            name: f[0].to_string(),
            line: n,
            position: [number(n, "geo_x", f[1])?, number(n, "geo_y", f[2])?],
            z_m: z,
            angles: angles(ypr, BodySchema::OdmGeoTxt),
            accuracy_m: acc.map(|a| [a[0], a[1]]),
        });
    }
    Ok((crs, out))
}

/// ODM's CRS line: EPSG:4326 (and WGS84 alone) are longitude, latitude; `WGS84 UTM 32N`
/// becomes EPSG:32632; anything else is passed on (EPSG:code, PROJ string).
fn crs_of(line: &str) -> Result<Option<String>, TableError> {
    let up = line.to_ascii_uppercase();
    if up == "EPSG:4326" || up == "WGS84" {
        return Ok(None);
    }
    let words: Vec<&str> = up.split_whitespace().collect();
    if let ["WGS84", "UTM", zone] = words[..] {
        let (num, hemi) = zone.split_at(zone.len().saturating_sub(1));
        let z: u16 = num
            .parse()
            .ok()
            .filter(|z| (1..=60).contains(z))
            .ok_or_else(|| {
                TableError::line(
                    1,
                    format!("UTM zone '{zone}' is not 1..60 followed by N or S"),
                )
            })?;
        return match hemi {
            "N" => Ok(Some(format!("EPSG:{}", 32600 + z))),
            "S" => Ok(Some(format!("EPSG:{}", 32700 + z))),
            _ => Err(TableError::line(
                1,
                format!("UTM zone '{zone}' must end in N or S"),
            )),
        };
    }
    Ok(Some(line.to_string()))
}
