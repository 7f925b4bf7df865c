//! Drone photos orthorectified from their own metadata: the camera (DJI's DewarpData or
//! calibration tags, the sensor database, or the 35 mm equivalent) sized from the image the tags
//! were written for to the decoded image, the gimbal's rotation turned onto the output CRS's
//! grid (meridian convergence), the camera's height, and the ground (level or a DEM).

use crate::Error;
pub use crate::drone_options::DroneOptions;
use crate::georef::{Ground, OrthoPlan, OrthoRequest, plan_ortho};
use crate::photo_source::{self, PhotoAttitude};
use aerorect_core::distortion::Distortion;
use aerorect_core::{Camera, CameraRotation, ImageSize, Intrinsics};
use aerorect_geo::{Crs, Pose, convergence_deg, grid_from_enu};
use aerorect_io::{CameraFormat, GeoReference, PhotoMetadata, PoseRecord};
use aerorect_raster::WarpOptions;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Where the focal length in pixels came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum CameraSource {
    CameraFile,
    DewarpData,
    DjiCalibrated,
    /// The sensor database's key and sensor width (mm) with EXIF FocalLength.
    SensorDatabase(String, f64),
    Equivalent35mm,
}

/// The camera of one photo, with any warnings about how it was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhotoCamera {
    pub camera: Camera,
    pub source: CameraSource,
    /// The image size the metadata's pixel values were written for.
    pub tagged_size: [usize; 2],
    pub warnings: Vec<String>,
}

/// The size the metadata's pixel values refer to: EXIF PixelXDimension x PixelYDimension, else
/// twice DJI's calibrated optical centre (an estimate: the centre is near, not at, the middle,
/// so it only tells the whole resize factor), else the decoded size.
pub fn tagged_size(meta: &PhotoMetadata, decoded: ImageSize) -> ImageSize {
    let d = &meta.dji;
    if let (Some(w), Some(h)) = (meta.width, meta.height)
        && w > 0
        && h > 0
    {
        return ImageSize::new(w as usize, h as usize);
    }
    let (Some(x), Some(y)) = (
        d.calibrated_optical_center_x_px,
        d.calibrated_optical_center_y_px,
    ) else {
        return decoded;
    };
    // The resize factor, to the nearest eighth (users halve or quarter their photos).
    let k = (2.0 * x / decoded.width as f64 * 8.0).round() / 8.0;
    if !(k.is_finite() && k > 0.0) || (2.0 * y / decoded.height as f64 - k).abs() > 0.05 * k {
        // Twice the centre does not look like this image resized: an aspect error follows.
        return ImageSize::new((2.0 * x).round() as usize, (2.0 * y).round() as usize);
    }
    ImageSize::new(
        (decoded.width as f64 * k).round() as usize,
        (decoded.height as f64 * k).round() as usize,
    )
}

/// The camera, in pixels of the tagged size, from the photo's own tags.
fn camera_from_tags(
    meta: &PhotoMetadata,
    size: ImageSize,
    file: &str,
) -> Result<(Intrinsics, Option<Distortion>, CameraSource, Vec<String>), Error> {
    let bad = |e: aerorect_core::GeometryError| Error::context(format!("{file}: camera"))(e);
    let dji = &meta.dji;
    let [cx, cy] = size.centre();
    if let Some(text) = &dji.dewarp_data {
        // The one DewarpData reader: aerorect-io's camera format.
        let c = aerorect_io::camera_from_text(text, CameraFormat::DjiDewarp, Some(size), file)?;
        return Ok((c.intrinsics, c.distortion, CameraSource::DewarpData, vec![]));
    }
    if let Some(f) = dji.calibrated_focal_length_px {
        // DJI's optical centre is measured from the image's outer corner (W / 2 at the middle).
        let x = dji.calibrated_optical_center_x_px.map_or(cx, |x| x - 0.5);
        let y = dji.calibrated_optical_center_y_px.map_or(cy, |y| y - 0.5);
        let k = Intrinsics::new(f, f, x, y).map_err(bad)?;
        return Ok((k, None, CameraSource::DjiCalibrated, vec![]));
    }
    let make = meta.make.as_deref().unwrap_or("").trim();
    let model = meta.model.as_deref().unwrap_or("").trim();
    if let (Some(s), Some(f)) = (
        aerorect_io::sensor_width_mm(make, model),
        meta.focal_length_mm,
    ) {
        // The database's width is the sensor's long side; 16:9 modes crop the height.
        let fpx = f * size.width.max(size.height) as f64 / s.width_mm;
        let k = Intrinsics::new(fpx, fpx, cx, cy).map_err(bad)?;
        return Ok((
            k,
            None,
            CameraSource::SensorDatabase(s.key, s.width_mm),
            vec![],
        ));
    }
    if let Some(f35) = meta.focal_length_35mm {
        let diag = (size.width as f64).hypot(size.height as f64);
        let fpx = f35 * diag / 36f64.hypot(24.0);
        let k = Intrinsics::new(fpx, fpx, cx, cy).map_err(bad)?;
        let w = format!(
            "camera '{make} {model}' is not in the sensor database: focal length from the 35 mm equivalent {f35} mm, assuming the image spans the sensor's diagonal (wrong for cropped modes)"
        );
        return Ok((k, None, CameraSource::Equivalent35mm, vec![w]));
    }
    Err(Error::advice(format!(
        "{file}: no focal length in pixels: no DJI calibration tags, camera '{make} {model}' is not in the sensor database, and no 35 mm equivalent; give `camera`"
    )))
}

/// The camera of a photo decoded at `size` from its metadata, scaled from the size its tags
/// were written for.
pub fn camera_from_metadata(
    meta: &PhotoMetadata,
    size: ImageSize,
    file: &str,
) -> Result<PhotoCamera, Error> {
    let tagged = tagged_size(meta, size);
    let (k, distortion, source, mut warnings) = camera_from_tags(meta, tagged, file)?;
    let camera = Camera::new(k, distortion, tagged)
        .resized(size)
        .map_err(Error::context(format!("{file}: EXIF PixelX/YDimension")))?;
    if tagged != size {
        warnings.push(format!(
            "the calibration was written for {} x {} px; scaled to the image's {} x {}",
            tagged.width, tagged.height, size.width, size.height
        ));
    }
    Ok(PhotoCamera {
        camera,
        source,
        tagged_size: [tagged.width, tagged.height],
        warnings,
    })
}

/// The camera's rotation in local east-north-up from the photo's own tags (the sources of
/// [`crate::photo_source::attitude_from_metadata`]). DJI's gimbal angles are world-frame and
/// already include the aircraft's attitude: the Flight angles are deliberately not used.
pub fn rotation_from_metadata(meta: &PhotoMetadata, file: &str) -> Result<CameraRotation, Error> {
    photo_source::attitude_from_metadata(meta, &DroneOptions::default(), file).map(|a| a.rotation)
}

/// The camera's height in the world frame and the ground under it.
#[derive(Debug, Clone, Serialize)]
pub struct Heights {
    pub camera_z_m: f64,
    pub source: String,
    /// The level ground's height (flat), or the DEM fallback.
    pub ground_z_m: Option<f64>,
}

fn heights(
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

/// Stages a frame's output: a COG when `cog` is set, else as its extension says.
pub(crate) fn stage_output(
    staged: &mut aerorect_io::StagedOutputs,
    output: &std::path::Path,
    image: &aerorect_raster::AnyRaster,
    geo: &GeoReference,
    cog: Option<&aerorect_io::CogOptions>,
) -> Result<(), Error> {
    match cog {
        Some(c) => staged.cog(output, image, Some(geo), c)?,
        None => staged.image(output, image, Some(geo))?,
    }
    Ok(())
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

/// What rectifying one photo produced.
#[derive(Debug, Clone, Serialize)]
pub struct PhotoResult {
    pub input: String,
    pub output: String,
    pub info: DronePlanInfo,
    pub input_size: [usize; 2],
    pub output_size: [usize; 2],
    /// The ground the frame covers (easting, northing).
    pub footprint_en: Vec<[f64; 2]>,
    pub seconds: f64,
    /// Where `seconds` went.
    pub stage_seconds: StageSeconds,
    /// PNG thumbnails of the input and of the output, when asked for.
    #[serde(skip)]
    pub thumbnails: Option<(Vec<u8>, Vec<u8>)>,
}

/// Wall seconds of the stages of one frame's ortho (the report's `stage_seconds`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StageSeconds {
    /// Metadata and image decoding.
    pub read: f64,
    /// The grid, the map and the footprint.
    pub plan: f64,
    /// Resampling onto the grid.
    pub warp: f64,
    /// Encoding and writing the output (staged, before its rename).
    pub write: f64,
}

/// Seconds since `t`, and `t` reset to now.
pub(crate) fn lap(t: &mut std::time::Instant) -> f64 {
    let now = std::time::Instant::now();
    let s = (now - *t).as_secs_f64();
    *t = now;
    s
}

/// Reads a photo, rectifies it from its metadata onto its georeferenced grid, and writes
/// `output` (GeoTIFF, or PNG + world file) atomically.
pub fn rectify_photo(
    input: &std::path::Path,
    output: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
) -> Result<PhotoResult, Error> {
    let mut staged = aerorect_io::StagedOutputs::new();
    let r = rectify_photo_staged(input, output, opts, thumbnail_side, &mut staged)?;
    staged.commit()?;
    Ok(r)
}

/// [`rectify_photo`] with the output (and its sidecars) staged, to land with the caller's
/// other outputs when it commits them.
pub fn rectify_photo_staged(
    input: &std::path::Path,
    output: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
    staged: &mut aerorect_io::StagedOutputs,
) -> Result<PhotoResult, Error> {
    let t = std::time::Instant::now();
    let (out, mut r) = ortho_photo(input, opts, thumbnail_side)?;
    let mut w = std::time::Instant::now();
    stage_output(staged, output, &out, &r.info.geo, opts.cog.as_ref())?;
    r.stage_seconds.write = lap(&mut w);
    r.output = output.display().to_string();
    r.seconds = t.elapsed().as_secs_f64();
    Ok(r)
}

/// The ortho [`rectify_photo`] writes, in memory: the image (bands on the output grid) and
/// what was found (`info.geo` is its georeference; `output` is empty). Nothing is written.
pub fn ortho_photo(
    input: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
) -> Result<(aerorect_raster::AnyRaster, PhotoResult), Error> {
    let t = std::time::Instant::now();
    let mut lap_t = t;
    let mut stages = StageSeconds::default();
    let file = input.display().to_string();
    let meta = aerorect_io::read_photo_metadata(input)?;
    let image = aerorect_io::read_image(input)?;
    opts.warp
        .nodata_as_for(&image)
        .map_err(|e| crate::options::OptionError::value("nodata", opts.warp.nodata, e))?;
    let size = image.size();
    stages.read = lap(&mut lap_t);
    let posed = opts.poses.as_deref().map(|p| pose_for(p, input));
    let (plan, info) = match posed {
        Some(Some(pose)) => plan_from_pose(pose, &meta, size, opts, &file)?,
        Some(None) => {
            return Err(Error::Invalid(format!("{file}: not in the pose table")));
        }
        None => plan_from_metadata(&meta, size, opts, &file)?,
    };
    stages.plan = lap(&mut lap_t);
    let out = plan.run(&image)?;
    stages.warp = lap(&mut lap_t);
    let thumbnails = match thumbnail_side {
        Some(s) => Some((
            aerorect_io::thumbnail_png(&image, s, &file)?,
            aerorect_io::thumbnail_png(&out, s, &format!("{file} (its ortho)"))?,
        )),
        None => None,
    };
    let r = PhotoResult {
        input: file,
        output: String::new(),
        input_size: [size.width, size.height],
        output_size: [plan.grid.size.width, plan.grid.size.height],
        footprint_en: plan.footprint.clone(),
        info,
        seconds: t.elapsed().as_secs_f64(),
        stage_seconds: stages,
        thumbnails,
    };
    Ok((out, r))
}

pub use crate::overlap::{OverlapShift, overlap_shift};
