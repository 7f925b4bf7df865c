//! Check-point tables: CSV with the header `u_oblique,v_oblique,u_standard,v_standard`.

use crate::error::IoError;
use crate::image_file::write_atomically;
use aerorect_core::CheckPoint;
use std::path::Path;

const HEADER: [&str; 4] = ["u_oblique", "v_oblique", "u_standard", "v_standard"];

/// Reads check points; the header must be exactly [`HEADER`] and every value finite.
pub fn read_checkpoints(path: &Path) -> Result<Vec<CheckPoint>, IoError> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| IoError::field(&name, e))?;
    let header = rdr.headers().map_err(|e| IoError::field(&name, e))?.clone();
    if header.iter().collect::<Vec<_>>() != HEADER {
        return Err(IoError::field(
            &name,
            format!(
                "header is '{}', expected '{}'",
                header.iter().collect::<Vec<_>>().join(","),
                HEADER.join(",")
            ),
        ));
    }
    let mut points = Vec::new();
    for (i, rec) in rdr.deserialize::<CheckPoint>().enumerate() {
        let line = i + 2;
        let p = rec.map_err(|e| IoError::field(&name, format!("line {line}: {e}")))?;
        for (field, v) in HEADER
            .iter()
            .zip([p.u_oblique, p.v_oblique, p.u_standard, p.v_standard])
        {
            if !v.is_finite() {
                return Err(IoError::field(
                    &name,
                    format!("line {line}: {field} = {v} is not a finite number"),
                ));
            }
        }
        points.push(p);
    }
    if points.is_empty() {
        return Err(IoError::field(&name, "no check points"));
    }
    Ok(points)
}

/// Writes check points with full f64 precision, atomically.
pub fn write_checkpoints(path: &Path, points: &[CheckPoint]) -> Result<(), IoError> {
    write_atomically(path, |w| {
        let mut wr = csv::Writer::from_writer(w);
        for p in points {
            wr.serialize(p)
                .map_err(|e| IoError::field(path.display(), e))?;
        }
        wr.flush().map_err(|e| IoError::io(path, e))
    })
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
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
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
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .map_err(|e| IoError::field(&name, e))?;
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| IoError::field(&name, e))?
        .iter()
        .map(str::to_string)
        .collect();
    if header != ["image", "X", "Y", "Z", "u", "v"] {
        return Err(IoError::field(
            &name,
            format!(
                "header is '{}', expected 'image,X,Y,Z,u,v'",
                header.join(",")
            ),
        ));
    }
    let mut points = vec![];
    for (i, rec) in rdr.deserialize::<ControlPoint>().enumerate() {
        let p = rec.map_err(|e| IoError::field(&name, format!("line {}: {e}", i + 2)))?;
        for (field, v) in [("X", p.x), ("Y", p.y), ("Z", p.z), ("u", p.u), ("v", p.v)] {
            if !v.is_finite() {
                return Err(IoError::field(
                    &name,
                    format!("line {}: {field} = {v} is not a finite number", i + 2),
                ));
            }
        }
        points.push(p);
    }
    Ok(points)
}
