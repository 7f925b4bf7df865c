//! ODM's `gcp_list.txt` (docs.opendronemap.org/gcp, "GCP file format"): the first line names
//! the CRS, as a PROJ string (`+proj=utm +zone=10 +ellps=WGS84 +datum=WGS84 +units=m
//! +no_defs`), an EPSG code (`EPSG:4326`) or `WGS84 UTM <zone>[N|S]` (EPSG 326zz / 327zz);
//! then one line per observation of a point in a photo,
//! `geo_x geo_y geo_z im_x im_y image_name [gcp_name] [extra1] [extra2]`, separated by tabs or
//! spaces; `#` starts a comment, blank lines are skipped. The 7th column, the GCP's label,
//! is optional: lines of one label are one point, lines without one are one point when their
//! coordinates are identical. ODM has no check-point column (every point is control).
//!
//! Axis order: geo_x is the easting, or with a geographic CRS such as EPSG:4326 the
//! **longitude**, and geo_y the northing or **latitude**, whatever the CRS's official axis
//! order: ODM's docs write EPSG:4326 coordinates longitude first (geo.txt's example
//! `DJI_0028.JPG -91.9942096111111 46.84252125 198.609`, docs.opendronemap.org/geo), and so
//! do the community's gcp_list.txt samples. ODM's own reading of EPSG:4326 GCPs has had axis-order faults
//! (OpenDroneMap/ODM#693; GDAL 3 takes EPSG's latitude-first order unless told otherwise);
//! the file's order as documented is what is read here. With a geographic CRS a geo_y
//! beyond +-90 is refused as not a latitude.
//!
//! ODM allows a geo_z of `NaN` for "no elevation"; a control point needs its height here, so
//! a NaN is refused like any other number that is not finite.

use super::Row;
use super::fields::number;
use crate::table_error::TableError;
use aerorect_geo::Crs;

pub(super) fn parse(text: &str) -> Result<(Option<Crs>, Vec<Row>), TableError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let Some((n, crs_line)) = lines.next() else {
        return Err(TableError::Table(
            "empty: the first line must name the CRS".into(),
        ));
    };
    let crs = crs_of(n, crs_line)?;
    let geographic = crs.is_geographic();
    let mut rows = vec![];
    for (n, l) in lines {
        let f: Vec<&str> = l.split_whitespace().collect();
        if f.len() < 6 {
            let what = format!("'{l}' needs geo_x geo_y geo_z im_x im_y image_name");
            return Err(TableError::line(n, what));
        }
        let xyz = [
            number(n, "geo_x", f[0])?,
            number(n, "geo_y", f[1])?,
            number(n, "geo_z", f[2])?,
        ];
        if geographic && xyz[1].abs() > 90.0 {
            let what = format!(
                "geo_y '{}' is not a latitude: with the geographic CRS '{crs}' geo_x is the longitude and geo_y the latitude",
                f[1]
            );
            return Err(TableError::line(n, what));
        }
        let pixel = [number(n, "im_x", f[3])?, number(n, "im_y", f[4])?];
        rows.push(Row {
            line: n,
            name: f.get(6).map(|s| s.to_string()),
            xyz: Some(xyz),
            sigma_m: None,
            check: false,
            mark: Some((f[5].to_string(), pixel)),
        });
    }
    Ok((Some(crs), rows))
}

/// The CRS line: `WGS84 UTM 32N` is EPSG:32632 (`S`: 32732); anything else is read by
/// [`Crs::parse`] (EPSG codes, PROJ strings, WKT), a PROJ string in single quotes unquoted as
/// ODM does.
fn crs_of(n: usize, line: &str) -> Result<Crs, TableError> {
    let words: Vec<String> = line
        .split_whitespace()
        .map(str::to_ascii_uppercase)
        .collect();
    if words.len() == 3 && words[0] == "WGS84" && words[1] == "UTM" {
        let zone = &words[2];
        let (num, hemi) = zone.split_at(zone.len().saturating_sub(1));
        let z: u16 = num
            .parse()
            .ok()
            .filter(|z| (1..=60).contains(z))
            .ok_or_else(|| {
                let what =
                    format!("CRS '{line}': UTM zone '{zone}' is not 1..60 followed by N or S");
                TableError::line(n, what)
            })?;
        let code = match hemi {
            "N" => 32600 + z,
            "S" => 32700 + z,
            _ => {
                let what = format!("CRS '{line}': UTM zone '{zone}' must end in N or S");
                return Err(TableError::line(n, what));
            }
        };
        return Crs::from_epsg(code).map_err(|error| TableError::Crs {
            line: n,
            text: line.to_string(),
            error,
        });
    }
    let unquoted = line
        .strip_prefix('\'')
        .and_then(|l| l.strip_suffix('\''))
        .unwrap_or(line);
    Crs::parse(unquoted).map_err(|error| TableError::NotACrs {
        line: n,
        text: line.to_string(),
        error,
    })
}
