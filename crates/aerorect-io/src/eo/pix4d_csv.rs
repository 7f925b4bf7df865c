//! Pix4D's image geolocation CSV: `image, latitude, longitude, altitude[, yaw, pitch, roll[,
//! accuracy_horz, accuracy_vert]]`, comma-separated, WGS84, with or without a header line. The
//! angles are Pix4D's yaw, pitch, roll (pitch 0 = nadir). A header naming omega/phi/kappa is
//! refused: those are poses in a projected CRS.

use super::{EoRecord, angles, group, number};
use crate::metadata::BodySchema;
use crate::table_error::TableError;

pub(super) fn parse(text: &str) -> Result<Vec<EoRecord>, TableError> {
    let mut out = vec![];
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        let l = l.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split(',').map(str::trim).collect();
        if out.is_empty() && f.get(1).is_some_and(|v| v.parse::<f64>().is_err()) {
            let lower = l.to_ascii_lowercase();
            if lower.contains("omega") || lower.contains("kappa") {
                let what = format!(
                    "'{l}' has omega, phi, kappa: this reader takes yaw, pitch, roll (give omega-phi-kappa as poses: filename,x,y,z,omega,phi,kappa)"
                );
                return Err(TableError::line(n, what));
            }
            continue; // the header
        }
        if f.len() < 4 {
            let what = format!("'{l}' needs image, latitude, longitude, altitude");
            return Err(TableError::line(n, what));
        }
        let lat = number(n, "latitude", f[1])?;
        let lon = number(n, "longitude", f[2])?;
        if lat.abs() > 90.0 || lon.abs() > 360.0 {
            let what = format!("latitude {lat}, longitude {lon} are not degrees");
            return Err(TableError::line(n, what));
        }
        let ypr = group(n, &f, 4, &["yaw", "pitch", "roll"])?;
        let acc = group(n, &f, 7, &["accuracy_horz", "accuracy_vert"])?;
        out.push(EoRecord {
            name: f[0].to_string(),
            line: n,
            position: [lon, lat],
            z_m: Some(number(n, "altitude", f[3])?),
            angles: angles(ypr, BodySchema::Pix4dCsv),
            accuracy_m: acc.map(|a| [a[0], a[1]]),
        });
    }
    Ok(out)
}
