//! Check-point tables: CSV with the header `u_oblique,v_oblique,u_standard,v_standard`.

use crate::error::IoError;
use aerorect_core::CheckPoint;
use std::path::Path;

const HEADER: [&str; 4] = ["u_oblique", "v_oblique", "u_standard", "v_standard"];

/// The largest magnitude a table accepts: a billion pixels (or metres, or degrees) is beyond any
/// image or survey, and keeps sums of squares of residuals far from overflowing.
pub const MAX_TABLE_VALUE: f64 = 1e9;

/// Why a table's number is refused, if it is.
pub(crate) fn bad_number(v: f64) -> Option<String> {
    let shown = aerorect_core::error::Num(v);
    if !v.is_finite() {
        Some(format!("{shown} is not a finite number"))
    } else if v.abs() > MAX_TABLE_VALUE {
        Some(format!("{shown} is out of range (magnitude above 1e9)"))
    } else {
        None
    }
}

/// Reads a CSV table whose header must be exactly `header` and whose numbers (each record's,
/// listed with their column names by `numbers`) are finite and within [`MAX_TABLE_VALUE`];
/// errors name the file and line.
fn read_table<T: serde::de::DeserializeOwned>(
    path: &Path,
    header: &[&str],
    numbers: impl Fn(&T) -> Vec<(&'static str, f64)>,
) -> Result<Vec<T>, IoError> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(crate::bounded::capped_reader(path)?);
    let got: Vec<String> = rdr
        .headers()
        .map_err(|e| IoError::field(&name, e))?
        .iter()
        .map(str::to_string)
        .collect();
    if got != header {
        return Err(IoError::field(
            &name,
            format!(
                "header is '{}', expected '{}'",
                got.join(","),
                header.join(",")
            ),
        ));
    }
    let mut rows = Vec::new();
    for (i, rec) in rdr.deserialize::<T>().enumerate() {
        let line = i + 2;
        let p = rec.map_err(|e| IoError::field(&name, format!("line {line}: {e}")))?;
        let bad = numbers(&p)
            .into_iter()
            .find_map(|(field, v)| bad_number(v).map(|why| (field, why)));
        if let Some((field, why)) = bad {
            return Err(IoError::field(
                &name,
                format!("line {line}: {field} = {why}"),
            ));
        }
        rows.push(p);
    }
    Ok(rows)
}

/// Reads check points; the header must be exactly [`HEADER`], every value finite and within
/// [`MAX_TABLE_VALUE`].
pub fn read_checkpoints(path: &Path) -> Result<Vec<CheckPoint>, IoError> {
    let points = read_table(path, &HEADER, |p: &CheckPoint| {
        HEADER
            .iter()
            .copied()
            .zip([p.u_oblique, p.v_oblique, p.u_standard, p.v_standard])
            .collect()
    })?;
    if points.is_empty() {
        return Err(IoError::field(path.display(), "no check points"));
    }
    Ok(points)
}

/// One ground control point of a polynomial correction: a pixel of the image and the same
/// ground point's pixel in the reference (output) frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct Gcp {
    pub u_image: f64,
    pub v_image: f64,
    pub u_ref: f64,
    pub v_ref: f64,
}

const GCP_HEADER: [&str; 4] = ["u_image", "v_image", "u_ref", "v_ref"];

/// Reads GCPs: CSV with the header `u_image,v_image,u_ref,v_ref`, every value finite.
pub fn read_gcps(path: &Path) -> Result<Vec<Gcp>, IoError> {
    read_table(path, &GCP_HEADER, |p: &Gcp| {
        GCP_HEADER
            .iter()
            .copied()
            .zip([p.u_image, p.v_image, p.u_ref, p.v_ref])
            .collect()
    })
}

/// Writes rows with a serde header and full f64 precision, atomically.
pub fn write_csv<T: serde::Serialize>(path: &Path, rows: &[T]) -> Result<(), IoError> {
    let mut staged = crate::StagedOutputs::new();
    staged.csv(path, rows)?;
    staged.commit()
}

impl crate::StagedOutputs {
    /// Stages rows like [`write_csv`], to land with the other staged outputs.
    pub fn csv<T: serde::Serialize>(&mut self, path: &Path, rows: &[T]) -> Result<(), IoError> {
        self.file(path, |w| {
            let mut wr = csv::Writer::from_writer(w);
            for p in rows {
                wr.serialize(p)
                    .map_err(|e| IoError::field(path.display(), e))?;
            }
            wr.flush().map_err(|e| IoError::io(path, e))
        })
    }
}

/// Writes check points with full f64 precision, atomically.
pub fn write_checkpoints(path: &Path, points: &[CheckPoint]) -> Result<(), IoError> {
    write_csv(path, points)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("cp.csv");
        let pts = vec![CheckPoint {
            u_oblique: 0.1,
            v_oblique: 1.0 / 3.0,
            u_standard: -1e-17,
            v_standard: 12345.678901234567,
        }];
        write_checkpoints(&p, &pts).expect("write");
        assert!(
            std::fs::read_to_string(&p)
                .expect("read")
                .starts_with("u_oblique,v_oblique,u_standard,v_standard\n")
        );
        assert_eq!(read_checkpoints(&p).expect("read"), pts);
    }

    #[test]
    fn bad_tables_are_refused_with_the_line() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("cp.csv");
        std::fs::write(&p, "u,v,x,y\n1,2,3,4\n").expect("write");
        assert!(
            read_checkpoints(&p)
                .unwrap_err()
                .to_string()
                .contains("header is 'u,v,x,y'")
        );
        std::fs::write(
            &p,
            "u_oblique,v_oblique,u_standard,v_standard\n1,2,3,4\n1,2,NaN,4\n",
        )
        .expect("write");
        let e = read_checkpoints(&p).unwrap_err().to_string();
        assert!(e.contains("line 3: u_standard = NaN"), "{e}");
        std::fs::write(
            &p,
            "u_oblique,v_oblique,u_standard,v_standard\n1,2,3,4\n1,-2e9,3,4\n",
        )
        .expect("write");
        let e = read_checkpoints(&p).unwrap_err().to_string();
        assert!(
            e.contains("line 3: v_oblique = -2e9 is out of range"),
            "{e}"
        );
        std::fs::write(&p, "u_oblique,v_oblique,u_standard,v_standard\n1,2,abc,4\n")
            .expect("write");
        assert!(
            read_checkpoints(&p)
                .unwrap_err()
                .to_string()
                .contains("line 2")
        );
    }
}

/// One control point of a calibration: image id, world X, Y, Z, measured pixel u, v.
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct ControlPoint {
    pub image: String,
    #[serde(rename = "X")]
    pub x: f64,
    #[serde(rename = "Y")]
    pub y: f64,
    #[serde(rename = "Z")]
    pub z: f64,
    pub u: f64,
    pub v: f64,
}

/// Reads control points: CSV with the header `image,X,Y,Z,u,v`, every value finite.
pub fn read_control_points(path: &Path) -> Result<Vec<ControlPoint>, IoError> {
    read_table(
        path,
        &["image", "X", "Y", "Z", "u", "v"],
        |p: &ControlPoint| vec![("X", p.x), ("Y", p.y), ("Z", p.z), ("u", p.u), ("v", p.v)],
    )
}

/// One frame's exterior orientation (Orthority's and Pix4D's CSV): the projection centre in the
/// world CRS and omega, phi, kappa in degrees (PATB: camera x right, y up, z back;
/// `world_from_camera = Rx(omega) Ry(phi) Rz(kappa)` about the world CRS's own axes).
#[derive(Debug, Clone, PartialEq, serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
pub struct PoseRecord {
    /// The image's file name or stem.
    pub filename: String,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub omega: f64,
    pub phi: f64,
    pub kappa: f64,
}

const POSE_HEADER: [&str; 7] = ["filename", "x", "y", "z", "omega", "phi", "kappa"];

/// Reads a pose table (header `filename,x,y,z,omega,phi,kappa`); every number finite, no file
/// named twice.
pub fn read_poses(path: &Path) -> Result<Vec<PoseRecord>, IoError> {
    let rows = read_table(path, &POSE_HEADER, |p: &PoseRecord| {
        POSE_HEADER[1..]
            .iter()
            .copied()
            .zip([p.x, p.y, p.z, p.omega, p.phi, p.kappa])
            .collect()
    })?;
    if rows.is_empty() {
        return Err(IoError::field(path.display(), "no poses"));
    }
    let mut seen = std::collections::BTreeSet::new();
    for r in &rows {
        if !seen.insert(r.filename.as_str()) {
            return Err(IoError::field(
                path.display(),
                format!("filename '{}' is listed twice", r.filename),
            ));
        }
    }
    Ok(rows)
}
