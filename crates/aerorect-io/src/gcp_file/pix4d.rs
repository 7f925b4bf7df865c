//! Pix4D's GCP files (support.pix4d.com, "Tie points (GCPs, CPs) import format"): one point a
//! line, `label,x,y,z` or `label,x,y,z,accuracy_horz,accuracy_vert`, comma-separated, no
//! header. Pix4D takes the coordinates in the order of the chosen CRS's axes (it also allows
//! `label,y,x,z`, e.g. latitude first); the file says nothing of it, so x, y are read as given
//! (x easting or longitude, y northing or latitude) and a file in the other order must be
//! swapped before it is read. The file names no CRS and no check points.
//!
//! Pix4D's image-marks file (PIX4Dmapper's GCP/MTP marks export, "imagename,gcplabel,x,y"):
//! `image,label,x,y` with x right, y down in pixels from the image's upper-left corner (read as
//! `x - 0.5, y - 0.5`: the project's pixel centres are at integers);
//! PIX4Dmatic adds a fifth column, the mark's accuracy in pixels, which is ignored here. A
//! marks file gives marks of points its coordinates file defines: read both with
//! [`super::read_gcp_files`]. A file is a marks file when its first line's second field is not
//! a number, or its first field ends in an image extension (a label may be a number).

use super::Row;
use super::fields::{number, sigma, split_fields};
use crate::table_error::TableError;

const IMAGE_EXTENSIONS: [&str; 7] = [".jpg", ".jpeg", ".tif", ".tiff", ".png", ".dng", ".raw"];

/// Whether the data line is a mark (`image,label,x,y`) rather than a point.
fn is_mark(f: &[String]) -> bool {
    let first = f[0].to_ascii_lowercase();
    IMAGE_EXTENSIONS.iter().any(|e| first.ends_with(e))
        || f.get(1).is_some_and(|v| v.parse::<f64>().is_err())
}

pub(super) fn parse(text: &str) -> Result<Vec<Row>, TableError> {
    let mut marks: Option<bool> = None;
    let mut rows = vec![];
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f = split_fields(l, ',');
        let is_marks = *marks.get_or_insert_with(|| is_mark(&f));
        if is_marks {
            if f.len() < 4 {
                return Err(TableError::line(n, format!("'{l}' needs image,label,x,y")));
            }
            let pixel = [number(n, "x", &f[2])? - 0.5, number(n, "y", &f[3])? - 0.5];
            rows.push(Row {
                line: n,
                name: Some(label(n, &f[1])?),
                xyz: None,
                sigma_m: None,
                check: false,
                mark: Some((f[0].clone(), pixel)),
            });
            continue;
        }
        if f.len() != 4 && f.len() != 6 {
            let what = format!(
                "'{l}' has {} fields: a GCP line is label,x,y,z or label,x,y,z,accuracy_horz,accuracy_vert",
                f.len()
            );
            return Err(TableError::line(n, what));
        }
        let xyz = [
            number(n, "x", &f[1])?,
            number(n, "y", &f[2])?,
            number(n, "z", &f[3])?,
        ];
        let mut row = Row::point(n, label(n, &f[0])?, xyz);
        if f.len() == 6 {
            row.sigma_m = Some([
                sigma(n, "accuracy_horz", &f[4])?,
                sigma(n, "accuracy_vert", &f[5])?,
            ]);
        }
        rows.push(row);
    }
    Ok(rows)
}

fn label(n: usize, s: &str) -> Result<String, TableError> {
    if s.is_empty() {
        return Err(TableError::line(n, "the label is empty"));
    }
    Ok(s.to_string())
}
