//! Our own GCP CSV: a header naming the columns, required first, in any order,
//! `name,image,u,v,x,y,z`, optional `sigma_xy_m,sigma_z_m,check`; one row per observation of
//! a point in an image. A row with image, u and v empty defines a point no image marks.
//! u, v are the project's pixel coordinates (pixel centres at integers, u right, v down), read
//! as they are. x, y, z are in the flight's CRS (the file
//! names none). sigma_xy_m, sigma_z_m: horizontal and vertical standard deviations (m), both or
//! neither; check: `true/false/1/0/yes/no` (empty: false). Rows of one name are one point.
//! `#` starts a comment line.

use super::Row;
use super::fields::{boolean, number, repeated, sigma, split_fields};
use crate::table_error::TableError;

/// The header's columns: required, then optional.
pub(super) const REQUIRED: [&str; 7] = ["name", "image", "u", "v", "x", "y", "z"];
pub(super) const OPTIONAL: [&str; 3] = ["sigma_xy_m", "sigma_z_m", "check"];

/// Whether a line is our header: it names every required column.
pub(super) fn is_header(line: &str) -> bool {
    let names: Vec<String> = split_fields(line, ',')
        .into_iter()
        .map(|s| s.to_ascii_lowercase())
        .collect();
    REQUIRED.iter().all(|r| names.iter().any(|n| n == r))
}

pub(super) fn parse(text: &str) -> Result<Vec<Row>, TableError> {
    let mut cols: Option<Vec<Option<usize>>> = None;
    let mut rows = vec![];
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f = split_fields(l, ',');
        let Some(c) = &cols else {
            cols = Some(header(n, &f)?);
            continue;
        };
        let get = |k: usize| c[k].and_then(|i| f.get(i)).map_or("", String::as_str);
        let name = get(0);
        if name.is_empty() {
            return Err(TableError::line(n, "the name is empty"));
        }
        let xyz = [
            number(n, "x", get(4))?,
            number(n, "y", get(5))?,
            number(n, "z", get(6))?,
        ];
        let mut row = Row::point(n, name.to_string(), xyz);
        let (image, u, v) = (get(1), get(2), get(3));
        if !(image.is_empty() && u.is_empty() && v.is_empty()) {
            if image.is_empty() {
                return Err(TableError::line(n, "u, v are given without an image"));
            }
            let px = [number(n, "u", u)?, number(n, "v", v)?];
            row.mark = Some((image.to_string(), px));
        }
        row.sigma_m = match (get(7), get(8)) {
            ("", "") => None,
            (h, "") => {
                let what = format!("sigma_xy_m '{h}' without sigma_z_m");
                return Err(TableError::line(n, what));
            }
            ("", z) => {
                let what = format!("sigma_z_m '{z}' without sigma_xy_m");
                return Err(TableError::line(n, what));
            }
            (h, z) => Some([sigma(n, "sigma_xy_m", h)?, sigma(n, "sigma_z_m", z)?]),
        };
        row.check = match get(9) {
            "" => false,
            s => boolean(n, "check", s)?,
        };
        rows.push(row);
    }
    if cols.is_none() {
        return Err(TableError::Table(format!(
            "no header: the first line must be {}",
            REQUIRED.join(",")
        )));
    }
    Ok(rows)
}

/// Each known column's index in the header (required, then optional); an unknown or repeated
/// column, or a missing required one, is an error.
fn header(n: usize, f: &[String]) -> Result<Vec<Option<usize>>, TableError> {
    let names: Vec<String> = f.iter().map(|s| s.to_ascii_lowercase()).collect();
    if let Some(r) = repeated(names.iter().map(String::as_str)) {
        return Err(TableError::RepeatedColumn {
            line: n,
            column: r.to_string(),
        });
    }
    if let Some(u) = names
        .iter()
        .find(|c| !REQUIRED.contains(&c.as_str()) && !OPTIONAL.contains(&c.as_str()))
    {
        let what = format!(
            "unknown column '{u}' (the columns are {},{})",
            REQUIRED.join(","),
            OPTIONAL.join(",")
        );
        return Err(TableError::line(n, what));
    }
    let at = |c: &str| names.iter().position(|x| x == c);
    let mut out = vec![];
    for c in REQUIRED {
        out.push(Some(at(c).ok_or_else(|| {
            let what = format!(
                "the header has no column '{c}' (it needs {})",
                REQUIRED.join(",")
            );
            TableError::line(n, what)
        })?));
    }
    out.extend(OPTIONAL.iter().map(|c| at(c)));
    Ok(out)
}
