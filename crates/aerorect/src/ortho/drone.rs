//! Drone photos orthorectified from their own metadata: the camera (DJI's DewarpData or
//! calibration tags, the sensor database, or the 35 mm equivalent) sized from the image the tags
//! were written for to the decoded image, the gimbal's rotation turned onto the output CRS's
//! grid (meridian convergence), the camera's height, and the ground (level or a DEM).

use crate::Error;
pub use crate::drone_options::DroneOptions;
use crate::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use crate::photo_source::{self, PhotoAttitude};
use aerorect_core::{CameraRotation, ImageSize};
use aerorect_geo::{Crs, Pose, convergence_deg, grid_from_enu};
use aerorect_io::{GeoReference, PhotoMetadata, PoseRecord};
use aerorect_raster::WarpOptions;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

mod camera;
mod heights;
mod rectify_photo;

pub use camera::{
    CameraSource, PhotoCamera, camera_from_metadata, rotation_from_metadata, tagged_size,
};
pub use heights::Heights;
use heights::heights;
pub use rectify_photo::{
    PhotoResult, StageSeconds, ortho_photo, rectify_photo, rectify_photo_staged,
};
pub(crate) use rectify_photo::{lap, stage_output};

/// Everything the georeferenced rectification of one photo needs, and what it found.
#[derive(Debug, Clone, Serialize)]
pub struct DronePlanInfo {
    pub camera: PhotoCamera,
    /// The attitude's angles as used (see `attitude.source`: gimbal or body yaw, pitch, roll,
    /// or a pose's omega, phi, kappa).
    pub gimbal_yaw_pitch_roll_deg: [f64; 3],
    /// Where the attitude came from and its prior.
    pub attitude: PhotoAttitude,
    pub off_nadir_deg: f64,
    /// Height of the camera above the ground (flat) or its world height (DEM).
    pub height_m: f64,
    pub height_source: String,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub easting_northing_m: [f64; 2],
    /// Angle from true north to the CRS's grid north at the camera, clockwise.
    pub convergence_deg: f64,
    pub pose: Pose,
    pub gsd_m: f64,
    pub geo: GeoReference,
    pub clipped: bool,
    pub warnings: Vec<String>,
}
/// The output CRS and the camera's position in it.
fn world_of(
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    file: &str,
) -> Result<(Crs, [f64; 2], [f64; 2]), Error> {
    let (Some(lat), Some(lon)) = (meta.latitude_deg, meta.longitude_deg) else {
        return Err(Error::Invalid(format!(
            "{file}: no GPS position (EXIF GPS or XMP GpsLatitude/GpsLongitude)"
        )));
    };
    let geo = |e: aerorect_geo::GeoError| Error::context(file)(e);
    let crs = match &opts.crs {
        Some(c) => c.clone(),
        None => Crs::utm_for(lon, lat).map_err(geo)?,
    };
    let en = crs.from_lon_lat(lon, lat).map_err(geo)?;
    Ok((crs, en, [lon, lat]))
}

/// The north-up, georeferenced ortho of a photo of `size` from its metadata, on a grid aligned
/// to multiples of the GSD in the output CRS.
pub fn plan_from_metadata(
    meta: &PhotoMetadata,
    size: ImageSize,
    opts: &DroneOptions,
    file: &str,
) -> Result<(OrthoPlan, DronePlanInfo), Error> {
    let meta = &photo_source::with_geo_record(meta, opts, file)?;
    let camera = photo_camera(meta, size, opts, file)?;
    let attitude = photo_source::attitude_from_metadata(meta, opts, file)?;
    let rotation = attitude.rotation;
    let (h, ground) = heights(meta, opts, file)?;
    let (crs, en, [lon, lat]) = world_of(meta, opts, file)?;
    let geo = |e: aerorect_geo::GeoError| Error::context(file)(e);
    let grid_from_enu = grid_from_enu(&crs, lon, lat).map_err(geo)?;
    let recorded = Pose::from_enu([en[0], en[1], h.camera_z_m], &rotation, &grid_from_enu);
    let lever = grid_from_enu
        * photo_source::enu_from_aircraft(meta, opts.sensefly_roll)
            .unwrap_or(*rotation.ground_from_camera());
    let mut frame = Frame {
        camera,
        pose: opts.mounting.camera_pose(&recorded, &lever),
        rotation,
        heights: h,
        ground,
        crs,
        lon_lat: [lon, lat],
        warnings: vec![],
    };
    if let Some(o) = meta.orientation.filter(|&o| o != 1) {
        frame.warnings.push(format!(
            "EXIF Orientation {o}: the pixels are used as stored, the camera angles assume the sensor's own orientation"
        ));
    }
    if opts.ground_height_m.is_none() && opts.dem.is_none() {
        frame.warnings.push(
            "height from RelativeAltitude: assumes the ground is level with the take-off point"
                .into(),
        );
    }
    if attitude.source == photo_source::AttitudeSource::GpsTrack {
        frame.warnings.push(format!(
            "no attitude recorded: nadir, heading {:.1} deg along the GPS track, prior {} deg",
            attitude.angles_deg[0],
            photo_source::GPS_TRACK_PRIOR_SIGMA_DEG
        ));
    }
    finish_plan(frame, attitude, opts, file)
}

/// The camera from `--camera` (sized to the image) or from the photo's tags.
fn photo_camera(
    meta: &PhotoMetadata,
    size: ImageSize,
    opts: &DroneOptions,
    file: &str,
) -> Result<PhotoCamera, Error> {
    match &opts.camera {
        Some(cam) => {
            let camera = cam.camera(Some(size))?;
            let s = cam
                .image_size_px
                .map_or(camera.size, |[w, h]| ImageSize::new(w as usize, h as usize));
            Ok(PhotoCamera {
                camera,
                source: CameraSource::CameraFile,
                tagged_size: [s.width, s.height],
                warnings: vec![],
            })
        }
        None => camera_from_metadata(meta, size, file),
    }
}

/// One frame placed in the world, ready to plan.
struct Frame {
    camera: PhotoCamera,
    pose: Pose,
    rotation: CameraRotation,
    heights: Heights,
    ground: Ground,
    crs: Crs,
    lon_lat: [f64; 2],
    warnings: Vec<String>,
}

fn finish_plan(
    frame: Frame,
    attitude: PhotoAttitude,
    opts: &DroneOptions,
    file: &str,
) -> Result<(OrthoPlan, DronePlanInfo), Error> {
    let k = frame.camera.camera.intrinsics;
    let ground_z = match (&frame.ground, frame.heights.ground_z_m) {
        (Ground::Flat(z), _) => *z,
        (Ground::Dem { .. }, Some(z)) => z,
        (Ground::Dem { dem, .. }, None) => dem.range().map_or(0.0, |r| 0.5 * (r.0 + r.1)),
    };
    let height_above = frame.heights.camera_z_m - ground_z;
    opts.validate().map_err(Error::context(&file))?;
    let (z, src) = (frame.heights.camera_z_m, &frame.heights.source);
    if opts.gsd_m.is_none() && !(height_above.is_finite() && height_above > 0.0) {
        return Err(crate::sane::camera_below_ground(file, z, src, ground_z));
    }
    // Over a DEM, the terrain under the camera (the take-off point may be far below it).
    let [x, y, _] = frame.pose.centre;
    if let Ground::Dem { dem, .. } = &frame.ground
        && let Some(under) = dem.height_in(&frame.crs, x, y)
        && z <= under
    {
        return Err(crate::sane::camera_below_ground(file, z, src, under));
    }
    let gsd = opts.gsd_m.unwrap_or(height_above / k.fx);
    let req = OrthoRequest {
        camera: &frame.camera.camera,
        pose: frame.pose,
        world: &frame.crs,
        ground: &frame.ground,
        gsd_m: gsd,
        limits: opts.limits,
        occlusion: opts.occlusion,
    };
    let plan = plan_ortho(&req, opts.warp).map_err(Error::context(&file))?;
    let mut warnings = frame.camera.warnings.clone();
    warnings.extend(frame.warnings);
    warnings.extend(plan.warnings.iter().cloned());
    let [lon, lat] = frame.lon_lat;
    let geo = |e: aerorect_geo::GeoError| Error::context(file)(e);
    let info = DronePlanInfo {
        gimbal_yaw_pitch_roll_deg: attitude.angles_deg,
        attitude,
        off_nadir_deg: frame.rotation.off_nadir_deg(),
        height_m: height_above,
        height_source: frame.heights.source,
        latitude_deg: lat,
        longitude_deg: lon,
        easting_northing_m: [frame.pose.centre[0], frame.pose.centre[1]],
        convergence_deg: convergence_deg(&frame.crs, lon, lat).map_err(geo)?,
        pose: frame.pose,
        gsd_m: gsd,
        geo: georeference(frame.crs, &plan, &opts.warp),
        clipped: plan.clipped,
        warnings,
        camera: frame.camera,
    };
    Ok((plan, info))
}

/// The ortho of a frame whose exterior orientation is given (omega-phi-kappa about the world
/// CRS's own axes, as Orthority, Pix4D and Metashape export them): no convergence is applied.
pub fn plan_from_pose(
    pose: &PoseRecord,
    meta: &PhotoMetadata,
    size: ImageSize,
    opts: &DroneOptions,
    file: &str,
) -> Result<(OrthoPlan, DronePlanInfo), Error> {
    let Some(crs) = opts.crs.clone() else {
        return Err(Error::advice(format!(
            "{file}: a pose needs the CRS it is in (`crs`, or a .prj beside the pose table)"
        )));
    };
    let camera = photo_camera(meta, size, opts, file)?;
    let rotation = CameraRotation::omega_phi_kappa(pose.omega, pose.phi, pose.kappa)
        .map_err(Error::geometry(format!("{file}: pose")))?;
    let z = pose.z + opts.vertical_offset_m;
    let (ground, ground_z_m, source) = match (&opts.dem, opts.ground_height_m) {
        (Some(dem), _) => (
            Ground::Dem {
                dem: Arc::clone(dem),
                fallback: opts.ground_height_m,
                strict: opts.strict,
            },
            opts.ground_height_m,
            format!(
                "pose z {} m + vertical offset {} m, against DEM {}",
                pose.z, opts.vertical_offset_m, dem.name
            ),
        ),
        (None, Some(g)) => (
            Ground::Flat(g),
            Some(g),
            format!("pose z {} m over ground at {g} m", pose.z),
        ),
        (None, None) => {
            return Err(Error::advice(format!(
                "{file}: a pose needs the ground: `dem` or `ground_height_m`"
            )));
        }
    };
    let recorded = Pose::new([pose.x, pose.y, z], rotation.ground_from_camera());
    let lon_lat = crs
        .transform(&Crs::wgs84(), pose.x, pose.y)
        .map_err(Error::context(&file))?;
    let frame = Frame {
        camera,
        pose: opts
            .mounting
            .camera_pose(&recorded, rotation.ground_from_camera()),
        rotation,
        heights: Heights {
            camera_z_m: z,
            source,
            ground_z_m,
        },
        ground,
        crs,
        lon_lat,
        warnings: vec![],
    };
    let attitude = PhotoAttitude {
        rotation: frame.rotation,
        source: photo_source::AttitudeSource::Pose,
        angles_deg: [pose.omega, pose.phi, pose.kappa],
        prior_sigma_deg: None,
    };
    finish_plan(frame, attitude, opts, file)
}

/// The pose of `input` in the table, by file name or stem.
pub fn pose_for<'a>(
    poses: &'a BTreeMap<String, PoseRecord>,
    input: &std::path::Path,
) -> Option<&'a PoseRecord> {
    let name = input.file_name()?.to_str()?;
    let stem = input.file_stem()?.to_str()?;
    poses.get(name).or_else(|| poses.get(stem))
}

/// The GeoTIFF georeference of a planned ortho.
pub fn georeference(crs: Crs, plan: &OrthoPlan, warp: &WarpOptions) -> GeoReference {
    GeoReference {
        crs,
        pixel_size: [plan.grid.gsd, plan.grid.gsd],
        top_left: plan.grid.top_left,
        rotation: [0.0, 0.0],
        nodata: (!warp.alpha).then_some(warp.nodata),
    }
}

pub use crate::overlap::{OverlapShift, overlap_shift};
