//! Ground control point files in the formats users have: ODM's `gcp_list.txt` (odm.rs),
//! Pix4D's GCP coordinates CSV and its image-marks CSV (pix4d.rs), Metashape's marker
//! reference CSV (metashape.rs) and our own CSV (aerorect.rs). The format is found from the
//! content; every error names the file, the line and the value.
//!
//! Marks are read into the project's pixel convention (x right, y down, pixel centres at
//! integers): ODM's `im_x, im_y` are OpenSfM's pixel coordinates, which are that convention
//! already (OpenSfM's doc/source/geometry.rst: "the origin is at the center of the top-left
//! pixel"), as are our CSV's `u, v`; Pix4D counts from the image's upper-left corner, so its
//! marks are read as `x - 0.5, y - 0.5`.
//!
//! Rows naming one point must agree on its coordinates within 1 mm (1e-8 degrees, about
//! 1.1 mm, horizontally when the coordinates are degrees); one image may mark a point once.

mod aerorect;
mod fields;
mod metashape;
mod odm;
mod pix4d;

use crate::error::IoError;
use crate::table_error::TableError;
use aerorect_geo::Crs;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// Which file format a GCP file is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GcpFormat {
    /// ODM's `gcp_list.txt`: a CRS line, then `geo_x geo_y geo_z im_x im_y image_name [gcp_name]`.
    Odm,
    /// Pix4D's `label,x,y,z[,accuracy_horz,accuracy_vert]` (or its marks file
    /// `imagename,gcplabel,x,y`).
    Pix4d,
    /// Metashape's marker reference export: a `#Label,X/...,Y/...,Z/...` header.
    Metashape,
    /// Ours: `name,image,u,v,x,y,z[,sigma_xy_m,sigma_z_m,check]`.
    Aerorect,
}

/// One surveyed point.
#[derive(Debug, Clone, PartialEq)]
pub struct SurveyPoint {
    pub name: String,
    /// In the file's CRS: x easting (or longitude), y northing (or latitude), z height.
    pub xyz: [f64; 3],
    /// Horizontal and vertical standard deviation (m) from the file, if it gives them.
    pub sigma_m: Option<[f64; 2]>,
    /// True when the file marks it as a check point.
    pub check: bool,
    /// 1-based line where it is first defined.
    pub line: usize,
}

/// One observation of a point in a photo. `pixel` is x right, y down, pixel centres at
/// integers (the project's convention, OpenCV's and OpenSfM's).
#[derive(Debug, Clone, PartialEq)]
pub struct ImageMark {
    pub point: String,
    pub image: String,
    pub pixel: [f64; 2],
    /// 1-based line of the file that holds the mark.
    pub line: usize,
}

/// A GCP file's points and marks.
#[derive(Debug, Clone, PartialEq)]
pub struct GcpFile {
    pub path: PathBuf,
    pub format: GcpFormat,
    /// `None` when the file gives none (the caller then assumes the flight's CRS).
    pub crs: Option<Crs>,
    pub points: Vec<SurveyPoint>,
    pub marks: Vec<ImageMark>,
}

/// One data line as a format reads it: a point's definition, a mark, or both.
#[derive(Debug, Clone)]
struct Row {
    line: usize,
    /// `None`: ODM's line without a gcp_name (grouped by coordinates).
    name: Option<String>,
    /// `None`: a mark of a point defined elsewhere (Pix4D's marks file).
    xyz: Option<[f64; 3]>,
    sigma_m: Option<[f64; 2]>,
    check: bool,
    mark: Option<(String, [f64; 2])>,
}

impl Row {
    fn point(line: usize, name: String, xyz: [f64; 3]) -> Row {
        Row {
            line,
            name: Some(name),
            xyz: Some(xyz),
            sigma_m: None,
            check: false,
            mark: None,
        }
    }
}

/// The format of a file's text, from its first lines that are not blank.
pub fn detect_format(text: &str) -> GcpFormat {
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let Some(first) = lines.clone().next() else {
        return GcpFormat::Odm;
    };
    // Metashape writes `#`-lines before its data; its header is the one starting `#Label`.
    let hashed_label = lines
        .by_ref()
        .take_while(|l| l.starts_with('#'))
        .any(metashape::is_header);
    if hashed_label || metashape::is_header(first) {
        return GcpFormat::Metashape;
    }
    let data = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .unwrap_or("");
    if aerorect::is_header(data) {
        GcpFormat::Aerorect
    } else if data.contains(',') {
        GcpFormat::Pix4d
    } else {
        GcpFormat::Odm
    }
}

/// Reads a GCP file, its format found from the content. Errors name the file, the line and
/// the value; a file with no points is an error (a Pix4D marks file alone too: read it with
/// its coordinates file by [`read_gcp_files`]).
pub fn read_gcp_file(path: &Path) -> Result<GcpFile, IoError> {
    let text = crate::read_text(path)?;
    gcp_from_text(&text, &path.display().to_string())
}

/// [`read_gcp_file`] of text already read; `name` names it in errors and becomes `path`.
pub fn gcp_from_text(text: &str, name: &str) -> Result<GcpFile, IoError> {
    let file = parse(text, name)?;
    require_points(&file, name)?;
    Ok(file)
}

/// Reads several GCP files as one: typically Pix4D's coordinates file and its marks file.
/// Points named in more than one file must agree within 1 mm; every mark must name a point
/// some file defines; the CRSs the files name must agree. `path` and `format` are those of
/// the first file that defines points, `crs` the first one named; each point's and mark's
/// `line` is in the file that holds it.
pub fn read_gcp_files(paths: &[PathBuf]) -> Result<GcpFile, IoError> {
    let mut files = Vec::with_capacity(paths.len());
    for p in paths {
        let text = crate::read_text(p)?;
        let name = p.display().to_string();
        files.push((name.clone(), parse(&text, &name)?));
    }
    merge(files)
}

fn merge(files: Vec<(String, GcpFile)>) -> Result<GcpFile, IoError> {
    let Some(lead) = files.iter().position(|(_, f)| !f.points.is_empty()) else {
        let name = files.first().map_or("GCP files".into(), |(n, _)| n.clone());
        return Err(IoError::field(
            name,
            "no points defined in any of the files",
        ));
    };
    let mut crs: Option<(String, Crs)> = None;
    for (name, f) in &files {
        match (&crs, &f.crs) {
            (None, Some(c)) => crs = Some((name.clone(), c.clone())),
            (Some((first, c0)), Some(c)) if !c0.same_as(c) => {
                return Err(IoError::field(
                    name,
                    format!("CRS '{c}' differs from {first}'s '{c0}'"),
                ));
            }
            _ => {}
        }
    }
    let degrees = in_degrees(
        crs.as_ref().map(|(_, c)| c),
        files
            .iter()
            .flat_map(|(_, f)| f.points.iter().map(|p| p.xyz)),
    );
    let mut points: Vec<SurveyPoint> = vec![];
    let mut from: HashMap<String, (usize, String)> = HashMap::new();
    for (name, f) in &files {
        for p in &f.points {
            if let Some(&(i, ref other)) = from.get(&p.name) {
                let q: &SurveyPoint = &points[i];
                if !same_place(q.xyz, p.xyz, degrees) {
                    return Err(IoError::field(
                        name,
                        format!(
                            "line {}: point '{}' at {} differs from {other} line {}: {} (more than 1 mm apart)",
                            p.line,
                            p.name,
                            show(p.xyz),
                            q.line,
                            show(q.xyz)
                        ),
                    ));
                }
                continue;
            }
            from.insert(p.name.clone(), (points.len(), name.clone()));
            points.push(p.clone());
        }
    }
    let mut marks: Vec<ImageMark> = vec![];
    let mut seen: HashMap<(String, String), (usize, String)> = HashMap::new();
    for (name, f) in &files {
        for m in &f.marks {
            if !from.contains_key(&m.point) {
                return Err(IoError::field(
                    name,
                    format!(
                        "line {}: point '{}' is not defined in any coordinates file",
                        m.line, m.point
                    ),
                ));
            }
            let key = (m.point.clone(), m.image.clone());
            if let Some((l, other)) = seen.get(&key) {
                return Err(IoError::field(
                    name,
                    format!(
                        "line {}: point '{}' is marked twice in image '{}' (also {other} line {l})",
                        m.line, m.point, m.image
                    ),
                ));
            }
            seen.insert(key, (m.line, name.clone()));
            marks.push(m.clone());
        }
    }
    let (_, first) = &files[lead];
    Ok(GcpFile {
        path: first.path.clone(),
        format: first.format,
        crs: crs.map(|(_, c)| c),
        points,
        marks,
    })
}

/// One file's points and marks, a marks-only file giving no points.
fn parse(text: &str, name: &str) -> Result<GcpFile, IoError> {
    if text.lines().all(|l| {
        let l = l.trim();
        l.is_empty() || l.starts_with('#')
    }) {
        let empty = TableError::Table("the file is empty (no data lines)".into());
        return Err(IoError::table(name, empty));
    }
    let format = detect_format(text);
    let (crs, rows) = match format {
        GcpFormat::Odm => odm::parse(text),
        GcpFormat::Pix4d => pix4d::parse(text).map(|rows| (None, rows)),
        GcpFormat::Metashape => metashape::parse(text).map(|rows| (None, rows)),
        GcpFormat::Aerorect => aerorect::parse(text).map(|rows| (None, rows)),
    }
    .map_err(|e| IoError::table(name, e))?;
    let (points, marks) = assemble(rows, crs.as_ref()).map_err(|e| IoError::table(name, e))?;
    Ok(GcpFile {
        path: PathBuf::from(name),
        format,
        crs,
        points,
        marks,
    })
}

fn require_points(file: &GcpFile, name: &str) -> Result<(), IoError> {
    if !file.points.is_empty() {
        return Ok(());
    }
    let why = if file.marks.is_empty() {
        "no points".to_string()
    } else {
        "only image marks, no point coordinates: read it together with its coordinates file"
            .to_string()
    };
    Err(IoError::field(name, why))
}

/// Points (in order of first appearance) and marks from rows: lines of one name are one
/// point; ODM lines without a name are grouped by identical coordinates and named `gcp1`,
/// `gcp2`, ... in order of appearance.
fn assemble(
    rows: Vec<Row>,
    crs: Option<&Crs>,
) -> Result<(Vec<SurveyPoint>, Vec<ImageMark>), TableError> {
    let degrees = in_degrees(crs, rows.iter().filter_map(|r| r.xyz));
    let named: BTreeMap<&str, usize> = rows
        .iter()
        .rev()
        .filter_map(|r| r.name.as_deref().map(|n| (n, r.line)))
        .collect();
    let mut unnamed: Vec<([u64; 3], String)> = vec![];
    let mut points: Vec<SurveyPoint> = vec![];
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut marks = vec![];
    let mut marked: HashMap<(String, String), usize> = HashMap::new();
    for r in &rows {
        let name = match (&r.name, r.xyz) {
            (Some(n), _) => n.clone(),
            (None, Some(xyz)) => {
                let bits = xyz.map(f64::to_bits);
                if let Some((_, n)) = unnamed.iter().find(|(b, _)| *b == bits) {
                    n.clone()
                } else {
                    let n = format!("gcp{}", unnamed.len() + 1);
                    if let Some(l) = named.get(n.as_str()) {
                        let what = format!(
                            "a point without a name would be called '{n}', the name line {l} gives another point: name every point or none"
                        );
                        return Err(TableError::line(r.line, what));
                    }
                    unnamed.push((bits, n.clone()));
                    n
                }
            }
            (None, None) => {
                return Err(TableError::line(r.line, "neither a name nor coordinates"));
            }
        };
        if let Some(xyz) = r.xyz {
            if let Some(&i) = index.get(&name) {
                let p: &SurveyPoint = &points[i];
                if !same_place(p.xyz, xyz, degrees) {
                    return Err(TableError::Table(format!(
                        "point '{name}' is at {} on line {} and at {} on line {} (more than 1 mm apart)",
                        show(p.xyz),
                        p.line,
                        show(xyz),
                        r.line
                    )));
                }
                if p.check != r.check {
                    return Err(TableError::Table(format!(
                        "point '{name}' is a check point on one of lines {} and {} and not on the other",
                        p.line, r.line
                    )));
                }
            } else {
                index.insert(name.clone(), points.len());
                points.push(SurveyPoint {
                    name: name.clone(),
                    xyz,
                    sigma_m: r.sigma_m,
                    check: r.check,
                    line: r.line,
                });
            }
        }
        if let Some((image, pixel)) = &r.mark {
            let key = (name.clone(), image.clone());
            if let Some(l) = marked.get(&key) {
                return Err(TableError::Table(format!(
                    "point '{name}' is marked twice in image '{image}' (lines {l} and {})",
                    r.line
                )));
            }
            marked.insert(key, r.line);
            marks.push(ImageMark {
                point: name,
                image: image.clone(),
                pixel: *pixel,
                line: r.line,
            });
        }
    }
    Ok((points, marks))
}

/// Whether coordinates are degrees: a geographic CRS, or with no CRS every point within
/// longitude and latitude ranges.
fn in_degrees(crs: Option<&Crs>, mut xyz: impl Iterator<Item = [f64; 3]>) -> bool {
    match crs {
        Some(c) => c.is_geographic(),
        None => xyz.all(|p| p[0].abs() <= 180.0 && p[1].abs() <= 90.0),
    }
}

/// Within 1 mm (1e-8 degrees horizontally when `degrees`).
fn same_place(a: [f64; 3], b: [f64; 3], degrees: bool) -> bool {
    let h = if degrees { 1e-8 } else { 1e-3 };
    (a[0] - b[0]).abs() <= h && (a[1] - b[1]).abs() <= h && (a[2] - b[2]).abs() <= 1e-3
}

fn show(p: [f64; 3]) -> String {
    format!("({}, {}, {})", p[0], p[1], p[2])
}

#[cfg(test)]
mod tests;
