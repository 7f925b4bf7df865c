//! Metashape's marker reference export (Reference pane, Export Reference, CSV): `#`-lines
//! first, the last of them the header naming the columns, e.g. PhotoScan's
//! `#Label,X/East,Y/North,Z/Altitude,Accuracy_(m),Error_(m),X_error,Y_error,Z_error,X_est,Y_est,Z_est`
//! or `#Label,X/Longitude,Y/Latitude,Z/Altitude,Accuracy_X/Y_(m),Accuracy_Z_(m),...`; then
//! one marker a line. Columns are found by name (any case): `Label`; x as `X`, `X/...`,
//! `Longitude`, `Easting` or `East`; y as `Y`, `Y/...`, `Latitude`, `Northing` or `North`; z as
//! `Z`, `Z/...`, `Altitude`, `Elevation` or `Height`; accuracies (m) from a column naming
//! `acc`: one for all (`Accuracy_(m)`), horizontal (`..X/Y..` or `..XY..`), vertical (`..Z..`),
//! or per axis (`X_accuracy`, `Y_accuracy`: horizontal is the larger); `Enable`/`Enabled`
//! (`1/0`, `true/false`, `yes/no`): a marker not enabled is a check point, as Metashape uses
//! an unchecked marker. Estimates and errors (`X_est`, `Error_(m)`, ...) are ignored.
//! Commas separate fields (tabs or semicolons when the header has no comma); a label may be
//! quoted. A marker with x, y, z all empty has no reference coordinates and is skipped.
//! Marker projections live in the project file, not in this CSV: the file gives points only.

use super::Row;
use super::fields::{boolean, number, repeated, sigma, split_fields};
use crate::table_error::TableError;

/// Whether a line is the header: its first field, `#` stripped, is `Label`.
pub(super) fn is_header(line: &str) -> bool {
    let l = line.trim().trim_start_matches('#');
    split_fields(l, delimiter(l))
        .first()
        .is_some_and(|f| f.eq_ignore_ascii_case("label"))
}

fn delimiter(header: &str) -> char {
    if header.contains(',') {
        ','
    } else if header.contains('\t') {
        '\t'
    } else if header.contains(';') {
        ';'
    } else {
        ','
    }
}

#[derive(Default)]
struct Columns {
    label: usize,
    xyz: [Option<usize>; 3],
    all: Option<usize>,
    horizontal: Option<usize>,
    vertical: Option<usize>,
    x_acc: Option<usize>,
    y_acc: Option<usize>,
    enable: Option<usize>,
}

fn columns(n: usize, names: &[String]) -> Result<Columns, TableError> {
    if let Some(r) = repeated(names.iter().map(String::as_str)) {
        return Err(TableError::RepeatedColumn {
            line: n,
            column: r.to_string(),
        });
    }
    let mut c = Columns::default();
    let axes: [(&str, &[&str]); 3] = [
        ("x", &["longitude", "easting", "east"]),
        ("y", &["latitude", "northing", "north"]),
        ("z", &["altitude", "elevation", "height"]),
    ];
    for (i, raw) in names.iter().enumerate() {
        let name = raw.to_ascii_lowercase();
        if name == "label" {
            c.label = i;
        } else if name == "enable" || name == "enabled" {
            c.enable = Some(i);
        } else if name.contains("acc") {
            let slot = if name.contains("x/y") || name.contains("xy") {
                &mut c.horizontal
            } else if name.contains('z') {
                &mut c.vertical
            } else if name.starts_with('x') {
                &mut c.x_acc
            } else if name.starts_with('y') {
                &mut c.y_acc
            } else {
                &mut c.all
            };
            *slot = Some(i);
        } else if let Some(k) = axes.iter().position(|(a, words)| {
            name == *a || name.starts_with(&format!("{a}/")) || words.contains(&name.as_str())
        }) {
            if c.xyz[k].is_some() {
                let what = format!("the header has two {} columns ('{raw}')", axes[k].0);
                return Err(TableError::line(n, what));
            }
            c.xyz[k] = Some(i);
        }
    }
    Ok(c)
}

pub(super) fn parse(text: &str) -> Result<Vec<Row>, TableError> {
    let mut header: Option<(Columns, char, [usize; 3])> = None;
    let mut rows = vec![];
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        let l = l.trim();
        if l.is_empty() {
            continue;
        }
        let Some((c, delim, xyz_at)) = &header else {
            if is_header(l) {
                let h = l.trim_start_matches('#');
                let delim = delimiter(h);
                let names = split_fields(h, delim);
                let c = columns(n, &names)?;
                let mut at = [0; 3];
                for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                    at[k] = c.xyz[k].ok_or_else(|| {
                        TableError::line(n, format!("the header '{l}' has no {axis} column"))
                    })?;
                }
                header = Some((c, delim, at));
            } else if !l.starts_with('#') {
                let what = format!("'{l}' comes before the header (#Label,X,Y,Z,...)");
                return Err(TableError::line(n, what));
            }
            continue;
        };
        if l.starts_with('#') {
            continue;
        }
        let f = split_fields(l, *delim);
        let get = |k: usize| f.get(k).map_or("", String::as_str);
        let label = get(c.label);
        if label.is_empty() {
            return Err(TableError::line(n, "the label is empty"));
        }
        let raw = xyz_at.map(get);
        if raw.iter().all(|v| v.is_empty()) {
            continue;
        }
        let mut xyz = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            xyz[k] = number(n, axis, raw[k])?;
        }
        let mut row = Row::point(n, label.to_string(), xyz);
        let acc = |col: Option<usize>, what: &str| -> Result<Option<f64>, TableError> {
            match col.map(get).filter(|v| !v.is_empty()) {
                Some(v) => sigma(n, what, v).map(Some),
                None => Ok(None),
            }
        };
        let all = acc(c.all, "accuracy")?;
        let per_axis = match (acc(c.x_acc, "x accuracy")?, acc(c.y_acc, "y accuracy")?) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        let h = acc(c.horizontal, "horizontal accuracy")?
            .or(per_axis)
            .or(all);
        let v = acc(c.vertical, "vertical accuracy")?.or(all);
        if let (Some(h), Some(v)) = (h, v) {
            row.sigma_m = Some([h, v]);
        }
        if let Some(e) = c.enable.map(get).filter(|v| !v.is_empty()) {
            row.check = !boolean(n, "enable", e)?;
        }
        rows.push(row);
    }
    if header.is_none() {
        return Err(TableError::Table(
            "no header line (#Label,X,Y,Z,...)".into(),
        ));
    }
    Ok(rows)
}
