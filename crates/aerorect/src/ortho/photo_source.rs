//! Where a photo's first orientation comes from, in order: an external-orientation file
//! (`--geo`), DJI's gimbal angles, senseFly's or Pix4D's body angles, and, for a photo with GPS
//! only, nadir with the heading of its GPS track and a wide prior. The pose table (`--poses`)
//! is handled by `drone::plan_from_pose` before any of these.

use crate::Error;
use crate::drone_options::DroneOptions;
use aerorect_core::{CameraRotation, GeometryError, Mat3};
use aerorect_geo::Crs;
use aerorect_io::{BodyAngles, BodySchema, EoTable, PhotoMetadata};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod flight_inputs;
pub use flight_inputs::prepare_flight;

/// The prior standard deviation (degrees, each axis) of a photo that had no attitude: nadir and
/// its GPS track's heading. A fixed wing crabs by up to ~30 degrees in wind and rolls and
/// pitches by ~5-10 in turbulence, so the prior must let an adjustment move that far.
pub const GPS_TRACK_PRIOR_SIGMA_DEG: f64 = 30.0;

/// The prior standard deviation (degrees, each axis) of body angles (senseFly, Pix4D's
/// `Camera:` tags): an autopilot's attitude, not a gimbal's, and the camera's mounting in the
/// airframe is not recorded. On a senseFly eBee flight a reconstruction (COLMAP) puts the
/// cameras 3-4 degrees rms from the recorded roll and pitch and a median 9 from the heading.
pub const BODY_PRIOR_SIGMA_DEG: f64 = 10.0;

pub use crate::drone_options::SenseflyRoll;

/// Where a photo's attitude came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum AttitudeSource {
    /// DJI's XMP GimbalYaw/Pitch/RollDegree (world frame).
    DjiGimbal,
    /// Body yaw, pitch, roll of this schema (XMP or an external-orientation file).
    Body(BodySchema),
    /// No attitude recorded: nadir, heading along the GPS track.
    GpsTrack,
    /// The pose table's omega, phi, kappa.
    Pose,
}

/// A photo's first orientation and how much to trust it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhotoAttitude {
    #[serde(skip)]
    pub rotation: CameraRotation,
    pub source: AttitudeSource,
    /// The angles as used (gimbal yaw, pitch, roll; body yaw, pitch, roll after the roll
    /// reading; omega, phi, kappa for poses).
    pub angles_deg: [f64; 3],
    /// The prior standard deviation (degrees) this source needs; `None`: the adjustment's own
    /// (`--attitude-sigma-deg`).
    pub prior_sigma_deg: Option<f64>,
}

/// Pix4D's yaw, pitch, roll (degrees) of a camera fixed looking down, the image top towards
/// the nose: `ned_from_body = Rz(yaw) Ry(pitch) Rx(roll)`, camera x (right) = body y, camera y
/// (image top) = body x, camera z (back) = -body z. Pitch 0 is nadir, pitch +90 looks forward,
/// positive roll (right wing down) turns the view to the left.
pub fn rotation_from_body_ypr(
    yaw_deg: f64,
    pitch_deg: f64,
    roll_deg: f64,
) -> Result<CameraRotation, GeometryError> {
    for (field, v) in [
        ("yaw (deg)", yaw_deg),
        ("pitch (deg)", pitch_deg),
        ("roll (deg)", roll_deg),
    ] {
        if !v.is_finite() || v.abs() > 360.0 {
            return Err(GeometryError::InvalidParameter {
                field,
                value: v,
                reason: "not a finite angle within [-360, 360]",
            });
        }
    }
    let body_from_camera = Mat3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0);
    let enu_from_body = aerorect_core::orientation::enu_from_body_zyx(
        yaw_deg.to_radians(),
        pitch_deg.to_radians(),
        roll_deg.to_radians(),
    );
    CameraRotation::from_matrix(enu_from_body * body_from_camera)
}

/// Body angles with senseFly's roll read as `roll` says.
fn read_body(a: &BodyAngles, roll: SenseflyRoll) -> [f64; 3] {
    let flip = a.schema.is_sensefly() && roll == SenseflyRoll::Flipped;
    let r = if flip { -a.roll_deg } else { a.roll_deg };
    [a.yaw_deg, a.pitch_deg, r]
}

/// The attitude of a photo whose metadata has had its `--geo` record merged
/// ([`with_geo_record`]).
pub fn attitude_from_metadata(
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    file: &str,
) -> Result<PhotoAttitude, Error> {
    let d = &meta.dji;
    if let (Some(yaw), Some(pitch)) = (d.gimbal_yaw_deg, d.gimbal_pitch_deg) {
        let roll = d.gimbal_roll_deg.unwrap_or(0.0);
        let rotation = CameraRotation::dji_gimbal(yaw, pitch, roll)
            .map_err(Error::geometry(format!("{file}: gimbal angles")))?;
        return Ok(PhotoAttitude {
            rotation,
            source: AttitudeSource::DjiGimbal,
            angles_deg: [yaw, pitch, roll],
            prior_sigma_deg: None,
        });
    }
    if let Some(a) = &meta.body.angles {
        let [y, p, r] = read_body(a, opts.sensefly_roll);
        let rotation = rotation_from_body_ypr(y, p, r).map_err(Error::geometry(format!(
            "{file}: {:?} yaw, pitch, roll",
            a.schema
        )))?;
        return Ok(PhotoAttitude {
            rotation,
            source: AttitudeSource::Body(a.schema),
            angles_deg: [y, p, r],
            prior_sigma_deg: Some(BODY_PRIOR_SIGMA_DEG),
        });
    }
    gps_track_attitude(meta, opts, file)
}

/// Nadir along the GPS track, for a photo with a position and no attitude.
fn gps_track_attitude(
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    file: &str,
) -> Result<PhotoAttitude, Error> {
    let none = "no attitude: no XMP drone-dji:GimbalYawDegree / GimbalPitchDegree, no senseFly or Pix4D (Camera:) Yaw/Pitch/Roll, not in `geo` or `poses`";
    if meta.latitude_deg.is_none() || meta.longitude_deg.is_none() {
        return Err(Error::advice(format!(
            "{file}: {none}, and no GPS position to start it from; give `attitude`, `geo` or `poses`"
        )));
    }
    let name = Path::new(file)
        .file_name()
        .and_then(|n| n.to_str())
        .unwrap_or(file);
    let Some(&heading) = opts.track_headings.as_deref().and_then(|t| t.get(name)) else {
        return Err(Error::advice(format!(
            "{file}: {none}, and no neighbouring photo to take a heading from its GPS track; give it with its flight (batch, mosaic), or `attitude`, `geo` or `poses`"
        )));
    };
    let rotation = rotation_from_body_ypr(heading, 0.0, 0.0)
        .map_err(Error::geometry(format!("{file}: GPS track heading")))?;
    Ok(PhotoAttitude {
        rotation,
        source: AttitudeSource::GpsTrack,
        angles_deg: [heading, 0.0, 0.0],
        prior_sigma_deg: Some(GPS_TRACK_PRIOR_SIGMA_DEG),
    })
}

/// The aircraft body (x forward, y right, z down) in east-north-up, for the lever arm: DJI's
/// Flight angles, else the body angles. `None` without either.
pub fn enu_from_aircraft(meta: &PhotoMetadata, roll: SenseflyRoll) -> Option<Mat3> {
    let d = &meta.dji;
    let [y, p, r] = match (d.flight_yaw_deg, d.flight_pitch_deg, d.flight_roll_deg) {
        (Some(y), Some(p), Some(r)) => [y, p, r],
        _ => read_body(meta.body.angles.as_ref()?, roll),
    };
    Some(aerorect_core::orientation::enu_from_body_zyx(
        y.to_radians(),
        p.to_radians(),
        r.to_radians(),
    ))
}

/// Reads an external-orientation file for `--geo`, its positions turned to WGS84 longitude,
/// latitude (the file's own CRS dropped).
pub fn load_geo_file(path: &Path) -> Result<EoTable, Error> {
    let mut t = aerorect_io::read_eo_file(path)?;
    let Some(crs) = t.crs.take() else {
        return Ok(t);
    };
    let name = path.display();
    let bad = |e: Error| Error::context(format!("{name}: CRS '{crs}'"))(e);
    let proj = Crs::parse(&crs).map_err(|e| bad(e.into()))?;
    let wgs84 = Crs::wgs84();
    for r in t.records.values_mut() {
        r.position = proj
            .transform(&wgs84, r.position[0], r.position[1])
            .map_err(Error::context(format!("{name}: line {}", r.line)))?;
    }
    Ok(t)
}

/// The photo's metadata with its `--geo` record (position, height, angles) in place of its
/// own; an error naming the photo and the file when the file does not list it.
pub fn with_geo_record(
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    file: &str,
) -> Result<PhotoMetadata, Error> {
    let mut m = meta.clone();
    let Some(table) = opts.geo.as_deref() else {
        return Ok(m);
    };
    let Some(r) = table.record_for(Path::new(file)) else {
        return Err(Error::Invalid(format!(
            "{file}: not in the external-orientation file {}",
            table.path
        )));
    };
    m.longitude_deg = Some(r.position[0]);
    m.latitude_deg = Some(r.position[1]);
    if let Some(z) = r.z_m {
        m.gps_altitude_m = Some(z);
        m.dji.absolute_altitude_m = None;
    }
    if let Some(a) = r.angles {
        m.body.angles = Some(a);
        m.dji.gimbal_yaw_deg = None;
        m.dji.gimbal_pitch_deg = None;
        m.dji.gimbal_roll_deg = None;
    }
    if let Some([h, v]) = r.accuracy_m {
        m.body.xy_accuracy_m = Some(h);
        m.body.z_accuracy_m = Some(v);
    }
    Ok(m)
}

/// The heading (degrees clockwise from true north) along the GPS track of every photo that has
/// a position and no attitude, by file name: from the previous to the next photo in time
/// (EXIF DateTimeOriginal, then file name), or to/from the one neighbour at a strip's ends.
/// Photos at one point (a hover) have no track: they are left out.
pub fn track_headings(frames: &[(PathBuf, PhotoMetadata)]) -> BTreeMap<String, f64> {
    let mut order: Vec<(&str, String, [f64; 2], bool)> = frames
        .iter()
        .filter_map(|(p, m)| {
            let name = p.file_name()?.to_str()?;
            let ll = [m.latitude_deg?, m.longitude_deg?];
            let posed = m.dji.gimbal_yaw_deg.is_some() || m.body.angles.is_some();
            Some((name, m.time.clone().unwrap_or_default(), ll, posed))
        })
        .collect();
    order.sort_by(|a, b| (&a.1, a.0).cmp(&(&b.1, b.0)));
    let mut out = BTreeMap::new();
    for i in 0..order.len() {
        if order[i].3 {
            continue;
        }
        let a = order[i.saturating_sub(1)].2;
        let b = order[(i + 1).min(order.len() - 1)].2;
        if let Some(h) = bearing_deg(a, b) {
            out.insert(order[i].0.to_string(), h);
        }
    }
    out
}

/// The bearing from `a` to `b` (latitude, longitude in degrees), clockwise from north, on a
/// local tangent plane; `None` when they are less than 0.5 m apart.
fn bearing_deg(a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let r = 6_371_000.0;
    let north = (b[0] - a[0]).to_radians() * r;
    let east = (b[1] - a[1]).to_radians() * r * (0.5 * (a[0] + b[0])).to_radians().cos();
    (north.hypot(east) >= 0.5).then(|| east.atan2(north).to_degrees().rem_euclid(360.0))
}

#[cfg(test)]
mod tests;
