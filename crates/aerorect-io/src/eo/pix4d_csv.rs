//! Pix4D's image geolocation CSV: `image, latitude, longitude, altitude[, yaw, pitch, roll[,
//! accuracy_horz, accuracy_vert]]`, comma-separated, WGS84, with or without a header line. The
//! angles are Pix4D's yaw, pitch, roll (pitch 0 = nadir). A header naming omega/phi/kappa is
//! refused: those are poses in a projected CRS.

use super::{EoRecord, angles, group, number};
use crate::metadata::BodySchema;

pub(super) fn parse(text: &str) -> Result<Vec<EoRecord>, String> {
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
                return Err(format!(
                    "line {n}: '{l}' has omega, phi, kappa: this reader takes yaw, pitch, roll (give omega-phi-kappa as poses: filename,x,y,z,omega,phi,kappa)"
                ));
            }
            continue; // the header
        }
        if f.len() < 4 {
            return Err(format!(
                "line {n}: '{l}' needs image, latitude, longitude, altitude"
            ));
        }
        let lat = number(n, "latitude", f[1])?;
        let lon = number(n, "longitude", f[2])?;
        if lat.abs() > 90.0 || lon.abs() > 360.0 {
            return Err(format!(
                "line {n}: latitude {lat}, longitude {lon} are not degrees"
            ));
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
