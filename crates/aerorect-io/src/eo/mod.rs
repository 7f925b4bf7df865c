//! External-orientation files: per photo a position and, where the file has them, yaw, pitch,
//! roll (Pix4D's convention, as in the photos' XMP) and accuracies. The format is found from
//! the content, one reader a file: ODM's `geo.txt` (geo_txt.rs), Pix4D's geolocation CSV
//! (pix4d_csv.rs), senseFly's `geoinfo.txt` (geoinfo.rs); the omega-phi-kappa pose CSV is
//! recognised and read by [`crate::read_poses`].

mod geo_txt;
mod geoinfo;
mod pix4d_csv;

use crate::error::IoError;
use crate::metadata::BodyAngles;
use crate::table_error::TableError;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Which reader a file needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum EoFormat {
    OdmGeoTxt,
    Pix4dCsv,
    SenseflyGeoinfo,
    /// `filename,x,y,z,omega,phi,kappa` (read with [`crate::read_poses`]).
    PoseCsv,
}

/// One photo's line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EoRecord {
    pub name: String,
    /// 1-based line in the file.
    pub line: usize,
    /// x, y in the table's CRS: longitude, latitude (degrees) when `crs` is `None`.
    pub position: [f64; 2],
    /// Height (m): geo.txt's geo_z, the CSV's altitude, geoinfo's altitude_amsl.
    pub z_m: Option<f64>,
    pub angles: Option<BodyAngles>,
    /// Horizontal and vertical accuracy (m).
    pub accuracy_m: Option<[f64; 2]>,
}

/// A file's photos by name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EoTable {
    pub path: String,
    pub format: EoFormat,
    /// The positions' CRS as the file names it (`None`: WGS84 longitude, latitude).
    pub crs: Option<String>,
    pub records: BTreeMap<String, EoRecord>,
}

impl EoTable {
    /// The record of a photo by file name, else by stem.
    pub fn record_for(&self, photo: &Path) -> Option<&EoRecord> {
        let name = photo.file_name()?.to_str()?;
        let stem = photo.file_stem()?.to_str()?;
        self.records.get(name).or_else(|| self.records.get(stem))
    }
}

/// The format of a file's text, from its first lines.
pub fn detect_format(text: &str) -> EoFormat {
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("");
    let lower = first.to_ascii_lowercase();
    if lower.starts_with("#rev:") || lower.starts_with("filename\tlatitude") {
        EoFormat::SenseflyGeoinfo
    } else if lower.replace(' ', "").starts_with("filename,x,y,z,omega") {
        EoFormat::PoseCsv
    } else if first.contains(',') {
        EoFormat::Pix4dCsv
    } else {
        EoFormat::OdmGeoTxt
    }
}

/// Reads an external-orientation file (not a pose CSV: its format says so and the caller reads
/// it with [`crate::read_poses`]). Errors name the file, line and field; a photo listed twice
/// is an error naming both lines.
pub fn read_eo_file(path: &Path) -> Result<EoTable, IoError> {
    let text = crate::read_text(path)?;
    eo_from_text(&text, &path.display().to_string())
}

/// [`read_eo_file`] of text already read; `name` names it in errors.
pub fn eo_from_text(text: &str, name: &str) -> Result<EoTable, IoError> {
    let format = detect_format(text);
    let bad = |m: String| IoError::table(name, TableError::Table(m));
    let (crs, rows) = match format {
        EoFormat::OdmGeoTxt => geo_txt::parse(text),
        EoFormat::Pix4dCsv => pix4d_csv::parse(text).map(|rows| (None, rows)),
        EoFormat::SenseflyGeoinfo => geoinfo::parse(text).map(|rows| (None, rows)),
        EoFormat::PoseCsv => {
            return Err(bad(
                "is an omega-phi-kappa pose table (filename,x,y,z,omega,phi,kappa): read it as poses".into(),
            ));
        }
    }
    .map_err(|e| IoError::table(name, e))?;
    if rows.is_empty() {
        return Err(bad("no photos listed".into()));
    }
    let mut records = BTreeMap::new();
    for r in rows {
        if let Some(prev) = records.get(&r.name) {
            let prev: &EoRecord = prev;
            return Err(bad(format!(
                "photo '{}' is listed twice (lines {} and {})",
                r.name, prev.line, r.line
            )));
        }
        records.insert(r.name.clone(), r);
    }
    Ok(EoTable {
        path: name.to_string(),
        format,
        crs,
        records,
    })
}

/// A field as a finite number; the error names the line, the column and the value.
pub(crate) fn number(line: usize, column: &str, value: &str) -> Result<f64, TableError> {
    match value.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(TableError::not_a_number(line, column, value)),
    }
}

/// Optional numbers at `at..at + n`: all present or none (a partial group is an error).
pub(crate) fn group(
    line: usize,
    fields: &[&str],
    at: usize,
    names: &[&str],
) -> Result<Option<Vec<f64>>, TableError> {
    let got: Vec<&str> = fields.iter().skip(at).take(names.len()).copied().collect();
    if got.is_empty() || got.iter().all(|f| f.trim().is_empty()) {
        return Ok(None);
    }
    if got.len() < names.len() {
        let what = format!(
            "{} without {}",
            names[..got.len()].join(", "),
            names[got.len()..].join(", ")
        );
        return Err(TableError::line(line, what));
    }
    names
        .iter()
        .zip(got)
        .map(|(n, v)| number(line, n, v))
        .collect::<Result<Vec<f64>, TableError>>()
        .map(Some)
}

/// Yaw, pitch, roll of a group.
pub(crate) fn angles(
    v: Option<Vec<f64>>,
    schema: crate::metadata::BodySchema,
) -> Option<BodyAngles> {
    v.map(|v| BodyAngles {
        yaw_deg: v[0],
        pitch_deg: v[1],
        roll_deg: v[2],
        schema,
    })
}

#[cfg(test)]
mod tests;
