//! The six attitude angles, in degrees: a TOML file with the six keys, or an inline string
//! `azimuth=..,elevation=..,image_rotation=..,pitch=..,roll=..,yaw=..`.

use crate::error::IoError;
use aerorect_core::SixAngleAttitude;
use aerorect_core::attitude::SixAngleDegrees;
use aerorect_core::spelling::Spelling;
use std::path::Path;

/// Reads `arg` as a file when one exists at that path, else as an inline key=value list.
pub fn read_attitude(arg: &str) -> Result<SixAngleAttitude, IoError> {
    let path = Path::new(arg);
    let (degrees, source) = if path.is_file() {
        let text = crate::bounded::read_text(path)?;
        let d: SixAngleDegrees =
            toml::from_str(&text).map_err(|e| IoError::field(arg, e.message()))?;
        (d, arg.to_string())
    } else if arg.contains('=') {
        (parse_inline(arg)?, inline_name(arg))
    } else {
        return Err(IoError::field(
            inline_name(arg),
            "neither an existing file nor a list azimuth=..,elevation=..,image_rotation=..,pitch=..,roll=..,yaw=..",
        ));
    };
    SixAngleAttitude::from_degrees(&degrees).map_err(|e| IoError::field(source, e))
}

/// The option that gave `arg` and its value, as the front end spells them
/// (`--attitude 'azimuth=..'`).
fn inline_name(arg: &str) -> String {
    Spelling::current().with_value("attitude", &format!("'{arg}'"))
}

/// Parses `azimuth=1,elevation=2,...`: all six keys, each once, nothing else.
pub fn parse_inline(arg: &str) -> Result<SixAngleDegrees, IoError> {
    let src = inline_name(arg);
    let mut values: [Option<f64>; 6] = [None; 6];
    for item in arg.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (key, value) = item
            .split_once('=')
            .ok_or_else(|| IoError::field(&src, format!("'{item}' is not key=value")))?;
        let (key, value) = (key.trim(), value.trim());
        let idx = SixAngleDegrees::FIELDS
            .iter()
            .position(|f| *f == key)
            .ok_or_else(|| {
                IoError::field(
                    &src,
                    format!(
                        "unknown key '{key}', expected one of {}",
                        SixAngleDegrees::FIELDS.join(", ")
                    ),
                )
            })?;
        let v: f64 = value
            .parse()
            .map_err(|_| IoError::field(&src, format!("{key} = '{value}' is not a number")))?;
        if values[idx].replace(v).is_some() {
            return Err(IoError::field(&src, format!("key '{key}' given twice")));
        }
    }
    let get = |i: usize| {
        values[i].ok_or_else(|| {
            IoError::field(&src, format!("missing key {}", SixAngleDegrees::FIELDS[i]))
        })
    };
    Ok(SixAngleDegrees {
        azimuth: get(0)?,
        elevation: get(1)?,
        image_rotation: get(2)?,
        pitch: get(3)?,
        roll: get(4)?,
        yaw: get(5)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inline_parses_all_six_in_any_order() {
        let d = parse_inline("yaw=6, roll=5,pitch=4,image_rotation=3,elevation=2,azimuth=1")
            .expect("ok");
        assert_eq!(d.values(), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    }

    #[test]
    fn inline_errors_name_the_key() {
        let e = parse_inline("azimuth=1,elevation=2,image_rotation=3,pitch=4,roll=5")
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing key yaw"), "{e}");
        let e =
            parse_inline("azimuth=1,elevation=2,image_rotation=3,pitch=4,roll=5,yaw=6,heading=3")
                .unwrap_err()
                .to_string();
        assert!(e.contains("unknown key 'heading'"), "{e}");
        let e = parse_inline("azimuth=x").unwrap_err().to_string();
        assert!(e.contains("azimuth = 'x' is not a number"), "{e}");
        let e = read_attitude("azimuth=0,elevation=0,image_rotation=0,pitch=NaN,roll=0,yaw=0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("pitch = NaN"), "{e}");
        let e = read_attitude("azimuth=0,elevation=0,image_rotation=0,pitch=0,roll=95,yaw=0")
            .unwrap_err()
            .to_string();
        assert!(e.contains("roll = 95"), "{e}");
    }

    #[test]
    fn toml_file_needs_all_keys_and_no_others() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("att.toml");
        std::fs::write(
            &p,
            "azimuth = 1\nelevation = 20\nimage_rotation = 0\npitch = 1\nroll = 2\nyaw = 30\n",
        )
        .expect("write");
        let a = read_attitude(p.to_str().expect("utf8")).expect("ok");
        assert!((a.elevation - 20f64.to_radians()).abs() < 1e-15);
        std::fs::write(
            &p,
            "azimuth = 1\nelevation = 20\nimage_rotation = 0\npitch = 1\nroll = 2\n",
        )
        .expect("write");
        let e = read_attitude(p.to_str().expect("utf8"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("att.toml") && e.contains("yaw"), "{e}");
    }
}
