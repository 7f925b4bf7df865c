//! The camera's height in the world frame and the ground under it (level or a DEM), from the
//! photo's altitudes and the options.

use super::DroneOptions;
use crate::Error;
use crate::georef::Ground;
use aerorect_io::PhotoMetadata;
use serde::Serialize;
use std::sync::Arc;

/// The camera's height in the world frame and the ground under it.
#[derive(Debug, Clone, Serialize)]
pub struct Heights {
    pub camera_z_m: f64,
    pub source: String,
    /// The level ground's height (flat), or the DEM fallback.
    pub ground_z_m: Option<f64>,
}

pub(super) fn heights(
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    file: &str,
) -> Result<(Heights, Ground), Error> {
    let abs = meta.dji.absolute_altitude_m.or(meta.gps_altitude_m);
    let relative = meta.dji.relative_altitude_m.or(meta.body.height_m);
    let need_abs = |why: &str| {
        abs.ok_or_else(|| {
            Error::advice(format!(
                "{file}: `{why}` needs XMP AbsoluteAltitude or EXIF GPSAltitude"
            ))
        })
    };
    let (h, ground) = if let Some(dem) = &opts.dem {
        let a = need_abs("dem")?;
        let z = a + opts.vertical_offset_m;
        let fallback = relative.map(|r| a - r);
        let src = format!(
            "AbsoluteAltitude/GPSAltitude {a} m + vertical offset {} m, against DEM {}",
            opts.vertical_offset_m, dem.name
        );
        let g = Ground::Dem {
            dem: Arc::clone(dem),
            fallback,
            strict: opts.strict,
        };
        (
            Heights {
                camera_z_m: z,
                source: src,
                ground_z_m: fallback,
            },
            g,
        )
    } else if let Some(g) = opts.ground_height_m {
        let a = need_abs("ground_height_m")?;
        let src = format!("AbsoluteAltitude {a} m over ground at {g} m");
        (
            Heights {
                camera_z_m: a,
                source: src,
                ground_z_m: Some(g),
            },
            Ground::Flat(g),
        )
    } else {
        let r = relative.ok_or_else(|| {
            Error::advice(format!(
                "{file}: no height above the take-off point (XMP drone-dji:RelativeAltitude or sensefly:Height); give `ground_height_m` (the ground's height in the altitude's datum) or `dem`"
            ))
        })?;
        let src = "RelativeAltitude (above the take-off point)".to_string();
        (
            Heights {
                camera_z_m: r,
                source: src,
                ground_z_m: Some(0.0),
            },
            Ground::Flat(0.0),
        )
    };
    if let Some(z) = h.ground_z_m
        && (h.camera_z_m - z <= 0.5 || !h.camera_z_m.is_finite() || z.is_nan())
    {
        return Err(Error::Invalid(format!(
            "{file}: height above ground {} m ({}) is not positive",
            h.camera_z_m - z,
            h.source
        )));
    }
    Ok((h, ground))
}
