//! Drone photos rectified from their own metadata: the camera (built-in sensor table, DJI's
//! calibration tags, or the 35 mm equivalent), the gimbal's world-frame rotation, the height above
//! ground, and a north-up grid in the UTM zone of the position.

use crate::Error;
use crate::rectify::RectifyPlan;
use aerorect_core::distortion::{Distortion, OpenCv};
use aerorect_core::orientation::standard_from_rotation;
use aerorect_core::{
    CameraRotation, Homography, ImageSize, Intrinsics, Mat3, RectifyGeometry, RectifyLimits,
};
use aerorect_io::{CameraFile, Crs, GeoReference, PhotoMetadata};
use aerorect_raster::WarpOptions;
use serde::Serialize;

/// A camera of the built-in table: sensor width in mm (the 4:3 native frame; 16:9 modes crop
/// the height and keep the width).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sensor {
    pub model: &'static str,
    pub name: &'static str,
    pub width_mm: f64,
    pub height_mm: f64,
}

/// Common drone cameras (EXIF Model).
pub const SENSORS: [Sensor; 7] = [
    Sensor {
        model: "FC220",
        name: "DJI Mavic Pro, 1/2.3\"",
        width_mm: 6.17,
        height_mm: 4.55,
    },
    Sensor {
        model: "FC330",
        name: "DJI Phantom 4, 1/2.3\"",
        width_mm: 6.17,
        height_mm: 4.55,
    },
    Sensor {
        model: "FC300X",
        name: "DJI Phantom 3 Pro, 1/2.3\"",
        width_mm: 6.17,
        height_mm: 4.55,
    },
    Sensor {
        model: "FC6310",
        name: "DJI Phantom 4 Pro, 1\"",
        width_mm: 13.2,
        height_mm: 8.8,
    },
    Sensor {
        model: "L1D-20c",
        name: "DJI Mavic 2 Pro (Hasselblad), 1\"",
        width_mm: 13.2,
        height_mm: 8.8,
    },
    Sensor {
        model: "FC3170",
        name: "DJI Mavic Air 2, 1/2\"",
        width_mm: 6.4,
        height_mm: 4.8,
    },
    Sensor {
        model: "FC7303",
        name: "DJI Mini 2, 1/2.3\"",
        width_mm: 6.17,
        height_mm: 4.55,
    },
];

/// Where the focal length in pixels came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum CameraSource {
    CameraFile,
    DjiCalibrated,
    DewarpData,
    SensorTable(&'static str),
    Equivalent35mm,
}

/// The camera of one photo, with any warnings about how it was found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhotoCamera {
    pub intrinsics: Intrinsics,
    pub source: CameraSource,
    pub distortion: Option<Distortion>,
    pub warnings: Vec<String>,
}

/// DJI's DewarpData "date;fx,fy,cx,cy,k1,k2,p1,p2,k3", cx/cy offsets from the image centre.
pub fn parse_dewarp(text: &str, size: ImageSize) -> Result<(Intrinsics, Distortion), String> {
    let body = text.split(';').next_back().unwrap_or(text);
    let v: Vec<f64> = body
        .split(',')
        .map(|t| t.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("DewarpData '{text}' is not nine numbers"))?;
    let [fx, fy, dcx, dcy, k1, k2, p1, p2, k3] = v[..] else {
        return Err(format!(
            "DewarpData '{text}' has {} numbers, not nine",
            v.len()
        ));
    };
    let [cx, cy] = size.centre();
    let intr = Intrinsics::new(fx, fy, cx + dcx, cy + dcy)
        .map_err(|e| format!("DewarpData '{text}': {e}"))?;
    let d = Distortion::OpenCv(OpenCv {
        k1,
        k2,
        p1,
        p2,
        k3,
        ..OpenCv::default()
    });
    Ok((intr, d))
}

/// The camera of a photo of `size` from its metadata (see the module's order of sources).
pub fn camera_from_metadata(
    meta: &PhotoMetadata,
    size: ImageSize,
    file: &str,
) -> Result<PhotoCamera, Error> {
    let [cx, cy] = size.centre();
    let bad = |e: aerorect_core::GeometryError| Error::Invalid(format!("{file}: camera: {e}"));
    let dji = &meta.dji;
    if let Some(f) = dji.calibrated_focal_length_px {
        let (x, y) = (
            dji.calibrated_optical_center_x_px.unwrap_or(cx),
            dji.calibrated_optical_center_y_px.unwrap_or(cy),
        );
        return Ok(PhotoCamera {
            intrinsics: Intrinsics::new(f, f, x, y).map_err(bad)?,
            source: CameraSource::DjiCalibrated,
            distortion: None,
            warnings: vec![],
        });
    }
    if let Some(text) = &dji.dewarp_data {
        let (intrinsics, d) =
            parse_dewarp(text, size).map_err(|e| Error::Invalid(format!("{file}: {e}")))?;
        return Ok(PhotoCamera {
            intrinsics,
            source: CameraSource::DewarpData,
            distortion: Some(d),
            warnings: vec![],
        });
    }
    let model = meta.model.as_deref().unwrap_or("").trim();
    if let (Some(s), Some(f)) = (
        SENSORS.iter().find(|s| s.model == model),
        meta.focal_length_mm,
    ) {
        let pitch_mm = s.width_mm / size.width as f64;
        let fpx = f / pitch_mm;
        return Ok(PhotoCamera {
            intrinsics: Intrinsics::new(fpx, fpx, cx, cy).map_err(bad)?,
            source: CameraSource::SensorTable(s.model),
            distortion: None,
            warnings: vec![],
        });
    }
    if let Some(f35) = meta.focal_length_35mm {
        let diag = (size.width as f64).hypot(size.height as f64);
        let fpx = f35 * diag / 36f64.hypot(24.0);
        return Ok(PhotoCamera {
            intrinsics: Intrinsics::new(fpx, fpx, cx, cy).map_err(bad)?,
            source: CameraSource::Equivalent35mm,
            distortion: None,
            warnings: vec![format!(
                "camera '{model}' is not in the sensor table: focal length from the 35 mm equivalent {f35} mm, assuming the image spans the sensor's diagonal (wrong for cropped modes)"
            )],
        });
    }
    Err(Error::Invalid(format!(
        "{file}: no focal length in pixels: no DJI calibration tags, camera model '{model}' is not in the sensor table, and no 35 mm equivalent; give --camera"
    )))
}

/// The gimbal's rotation. DJI's gimbal angles are world-frame and already include the
/// aircraft's attitude: the Flight angles are deliberately not used.
pub fn rotation_from_metadata(meta: &PhotoMetadata, file: &str) -> Result<CameraRotation, Error> {
    let d = &meta.dji;
    let (Some(yaw), Some(pitch)) = (d.gimbal_yaw_deg, d.gimbal_pitch_deg) else {
        return Err(Error::Invalid(format!(
            "{file}: no XMP drone-dji:GimbalYawDegree / GimbalPitchDegree; give --attitude"
        )));
    };
    CameraRotation::dji_gimbal(yaw, pitch, d.gimbal_roll_deg.unwrap_or(0.0))
        .map_err(Error::geometry(format!("{file}: gimbal angles")))
}

/// Height of the camera above the ground and how it was found.
pub fn height_above_ground(
    meta: &PhotoMetadata,
    ground_height_m: Option<f64>,
    file: &str,
) -> Result<(f64, String), Error> {
    let h = match ground_height_m {
        Some(g) => {
            let abs = meta
                .dji
                .absolute_altitude_m
                .or(meta.gps_altitude_m)
                .ok_or_else(|| {
                    Error::Invalid(format!(
                        "{file}: --ground-height-m needs AbsoluteAltitude or EXIF GPSAltitude"
                    ))
                })?;
            (abs - g, format!("AbsoluteAltitude {abs} m - ground {g} m"))
        }
        None => {
            let r = meta.dji.relative_altitude_m.ok_or_else(|| {
                Error::Invalid(format!(
                    "{file}: no XMP drone-dji:RelativeAltitude; give --ground-height-m"
                ))
            })?;
            (r, "RelativeAltitude (above the take-off point)".to_string())
        }
    };
    if !(h.0.is_finite() && h.0 > 0.5) {
        return Err(Error::Invalid(format!(
            "{file}: height above ground {} m ({}) is not positive",
            h.0, h.1
        )));
    }
    Ok(h)
}

/// UTM zone (1-60) and EPSG code (326zz north, 327zz south) of a position.
pub fn utm_zone(lat_deg: f64, lon_deg: f64) -> (u8, u16) {
    let zone = (((lon_deg + 180.0) / 6.0).floor() as i64).clamp(0, 59) as u8 + 1;
    let epsg = if lat_deg >= 0.0 { 32600 } else { 32700 } + zone as u16;
    (zone, epsg)
}

/// Easting and northing (m) of a WGS84 position in its UTM zone, with proj4rs.
pub fn utm_from_wgs84(lat_deg: f64, lon_deg: f64) -> Result<([f64; 2], u16), Error> {
    if !(lat_deg.abs() <= 84.0 && lon_deg.abs() <= 180.0) {
        return Err(Error::Invalid(format!(
            "position ({lat_deg}, {lon_deg}) is outside UTM's range (|lat| <= 84, |lon| <= 180)"
        )));
    }
    let (zone, epsg) = utm_zone(lat_deg, lon_deg);
    let south = if lat_deg < 0.0 { " +south" } else { "" };
    let err = |e: proj4rs::errors::Error| Error::Invalid(format!("UTM projection: {e}"));
    let from =
        proj4rs::Proj::from_proj_string("+proj=longlat +datum=WGS84 +no_defs").map_err(err)?;
    let to = proj4rs::Proj::from_proj_string(&format!(
        "+proj=utm +zone={zone}{south} +datum=WGS84 +units=m +no_defs"
    ))
    .map_err(err)?;
    let mut p = (lon_deg.to_radians(), lat_deg.to_radians(), 0.0);
    proj4rs::transform::transform(&from, &to, &mut p).map_err(err)?;
    Ok(([p.0, p.1], epsg))
}

/// Everything the georeferenced rectification of one photo needs, and what it found.
#[derive(Debug, Clone, Serialize)]
pub struct DronePlanInfo {
    pub camera: PhotoCamera,
    pub gimbal_yaw_pitch_roll_deg: [f64; 3],
    pub off_nadir_deg: f64,
    pub height_m: f64,
    pub height_source: String,
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    pub easting_northing_m: [f64; 2],
    pub gsd_m: f64,
    pub geo: GeoReference,
    pub clipped: bool,
    pub warnings: Vec<String>,
}

/// Inputs to [`plan_from_metadata`] that do not come from the photo.
#[derive(Debug, Clone, Default)]
pub struct DroneOptions {
    /// Output ground sample distance; default: the frame's own at nadir (H / f).
    pub gsd_m: Option<f64>,
    pub ground_height_m: Option<f64>,
    /// Overrides the camera from metadata (sized for each photo as it is read).
    pub camera: Option<CameraFile>,
    pub limits: RectifyLimits,
    pub warp: WarpOptions,
}

/// The north-up, georeferenced rectification of a photo of `size` from its metadata. The output
/// grid is aligned to multiples of the GSD in UTM, so every photo at one GSD shares one grid.
pub fn plan_from_metadata(
    meta: &PhotoMetadata,
    size: ImageSize,
    opts: &DroneOptions,
    file: &str,
) -> Result<(RectifyPlan, DronePlanInfo), Error> {
    let camera = match &opts.camera {
        Some(cam) => {
            let size = cam.frame_size(Some(size))?;
            PhotoCamera {
                intrinsics: cam.intrinsics(size)?,
                source: CameraSource::CameraFile,
                distortion: cam.distortion.clone(),
                warnings: vec![],
            }
        }
        None => camera_from_metadata(meta, size, file)?,
    };
    let rotation = rotation_from_metadata(meta, file)?;
    let (height_m, height_source) = height_above_ground(meta, opts.ground_height_m, file)?;
    let (Some(lat), Some(lon)) = (meta.latitude_deg, meta.longitude_deg) else {
        return Err(Error::Invalid(format!(
            "{file}: no GPS position (EXIF GPS or XMP GpsLatitude/GpsLongitude)"
        )));
    };
    let (en, epsg) =
        utm_from_wgs84(lat, lon).map_err(|e| Error::Invalid(format!("{file}: {e}")))?;
    let k = camera.intrinsics;
    let gsd = opts.gsd_m.unwrap_or(height_m / k.fx);
    if !(gsd.is_finite() && gsd > 0.0) {
        return Err(Error::Invalid(format!(
            "--gsd-m {gsd} must be a positive number of metres"
        )));
    }
    let f = standard_from_rotation(&k, &rotation);
    // Standard pixel -> ground grid index: east = E0 + (u - cx) H / fx = (i + 0.5) gsd,
    // north = N0 - (v - cy) H / fy = -(j + 0.5) gsd.
    let (sx, sy) = (height_m / k.fx / gsd, height_m / k.fy / gsd);
    let grid_from_standard = Homography::new(Mat3::new(
        sx,
        0.0,
        en[0] / gsd - sx * k.cx - 0.5,
        0.0,
        sy,
        -en[1] / gsd - sy * k.cy - 0.5,
        0.0,
        0.0,
        1.0,
    ))
    .map_err(Error::geometry(format!("{file}: ground grid")))?;
    let geometry =
        RectifyGeometry::from_base_homography(f, grid_from_standard.after(&f), size, opts.limits)
            .map_err(Error::geometry(format!("{file}: rectify")))?;
    let [i0, j0] = geometry.standard_origin;
    let geo = GeoReference {
        crs: Crs::Epsg(epsg),
        pixel_size: [gsd, gsd],
        top_left: [i0 * gsd, -j0 * gsd],
        rotation: [0.0, 0.0],
        nodata: (!opts.warp.alpha).then_some(opts.warp.nodata),
    };
    let mut warnings = camera.warnings.clone();
    if geometry.clipped {
        warnings
            .push("the far field near the horizon was cut to respect the output size limit".into());
    }
    if let Some(o) = meta.orientation.filter(|&o| o != 1) {
        warnings.push(format!(
            "EXIF Orientation {o}: the pixels are used as stored, the camera angles assume the sensor's own orientation"
        ));
    }
    if opts.ground_height_m.is_none() {
        warnings.push(
            "height from RelativeAltitude: assumes the ground is level with the take-off point"
                .into(),
        );
    }
    let info = DronePlanInfo {
        gimbal_yaw_pitch_roll_deg: [
            meta.dji.gimbal_yaw_deg.unwrap_or(f64::NAN),
            meta.dji.gimbal_pitch_deg.unwrap_or(f64::NAN),
            meta.dji.gimbal_roll_deg.unwrap_or(0.0),
        ],
        off_nadir_deg: rotation.off_nadir_deg(),
        height_m,
        height_source,
        latitude_deg: lat,
        longitude_deg: lon,
        easting_northing_m: en,
        gsd_m: gsd,
        geo,
        clipped: geometry.clipped,
        warnings,
        camera: camera.clone(),
    };
    let plan = RectifyPlan::from_geometry(k, size, geometry, opts.limits, opts.warp)
        .with_distortion(camera.distortion);
    Ok((plan, info))
}

/// What rectifying one photo produced.
#[derive(Debug, Clone, Serialize)]
pub struct PhotoResult {
    pub input: String,
    pub output: String,
    pub info: DronePlanInfo,
    pub input_size: [usize; 2],
    pub output_size: [usize; 2],
    /// The rectified part of the frame on the ground (easting, northing), a convex polygon.
    pub footprint_en: Vec<[f64; 2]>,
    pub seconds: f64,
    /// PNG thumbnails of the input and of the output, when asked for.
    #[serde(skip)]
    pub thumbnails: Option<(Vec<u8>, Vec<u8>)>,
}

/// Reads a photo, rectifies it from its metadata onto its georeferenced grid, and writes
/// `output` (GeoTIFF, or PNG + world file) atomically.
pub fn rectify_photo(
    input: &std::path::Path,
    output: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
) -> Result<PhotoResult, Error> {
    let t = std::time::Instant::now();
    let file = input.display().to_string();
    let meta = aerorect_io::read_photo_metadata(input)?;
    let image = aerorect_io::read_image(input)?;
    opts.warp
        .nodata_as_for(&image)
        .map_err(|e| Error::Invalid(format!("--nodata {}: {e}", opts.warp.nodata)))?;
    let size = image.size();
    let (plan, info) = plan_from_metadata(&meta, size, opts, &file)?;
    let (out, _) = plan.run(&image)?;
    aerorect_io::write_image_geo(output, &out, Some(&info.geo))?;
    let g = &plan.geometry;
    let footprint_en = g
        .footprint
        .iter()
        .filter_map(|p| g.base_from_oblique.map(p[0], p[1]))
        .map(|b| [(b[0] + 0.5) * info.gsd_m, -(b[1] + 0.5) * info.gsd_m])
        .collect();
    let thumbnails = match thumbnail_side {
        Some(s) => {
            let err = |e: String| Error::Invalid(format!("{file}: thumbnail: {e}"));
            Some((
                aerorect_io::thumbnail_png(&image, s).map_err(err)?,
                aerorect_io::thumbnail_png(&out, s).map_err(err)?,
            ))
        }
        None => None,
    };
    Ok(PhotoResult {
        input: file,
        output: output.display().to_string(),
        input_size: [size.width, size.height],
        output_size: [g.output_size.width, g.output_size.height],
        footprint_en,
        info,
        seconds: t.elapsed().as_secs_f64(),
        thumbnails,
    })
}

/// The misalignment of two georeferenced frames on one grid, measured on their overlap.
#[derive(Debug, Clone, Serialize)]
pub struct OverlapShift {
    /// Patches matched (both frames valid and textured, a clear correlation peak).
    pub patches: usize,
    /// Median shift of B relative to A, pixels (x east, y south) and metres (east, north).
    pub median_px: [f64; 2],
    pub median_m: [f64; 2],
    /// RMS of the patch shifts' length, pixels.
    pub rms_px: f64,
    pub gsd_m: f64,
    pub overlap_px: [usize; 2],
}

/// Measures where frame B's content sits relative to frame A's over their common area, with
/// the phase correlator on `patch` x `patch` tiles. Both must share a CRS and GSD.
pub fn overlap_shift(
    a: &std::path::Path,
    b: &std::path::Path,
    patch: usize,
) -> Result<OverlapShift, Error> {
    use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
    let geo = |p: &std::path::Path| -> Result<GeoReference, Error> {
        aerorect_io::read_georeference(p)?
            .ok_or_else(|| Error::Invalid(format!("{}: not a GeoTIFF", p.display())))
    };
    let (ga, gb) = (geo(a)?, geo(b)?);
    if ga.crs != gb.crs || (ga.pixel_size[0] - gb.pixel_size[0]).abs() > 1e-9 * ga.pixel_size[0] {
        return Err(Error::Invalid(format!(
            "{} and {} are not on one grid (CRS {} / {}, GSD {} / {})",
            a.display(),
            b.display(),
            ga.crs,
            gb.crs,
            ga.pixel_size[0],
            gb.pixel_size[0]
        )));
    }
    let gsd = ga.pixel_size[0];
    let ia = crate::motion::gray(&aerorect_io::read_image(a)?)?;
    let ib = crate::motion::gray(&aerorect_io::read_image(b)?)?;
    // Offset of B's pixel grid in A's pixels (integral when both are aligned to the GSD).
    let off = [
        ((gb.top_left[0] - ga.top_left[0]) / gsd).round() as i64,
        ((ga.top_left[1] - gb.top_left[1]) / gsd).round() as i64,
    ];
    let (sa, sb) = (ia.size(), ib.size());
    let x0 = off[0].max(0);
    let y0 = off[1].max(0);
    let x1 = (sa.width as i64).min(off[0] + sb.width as i64);
    let y1 = (sa.height as i64).min(off[1] + sb.height as i64);
    if x1 - x0 < patch as i64 || y1 - y0 < patch as i64 {
        return Err(Error::Invalid(
            "the frames do not overlap by one patch".into(),
        ));
    }
    let mut pc = PhaseCorrelator::new(
        patch,
        patch,
        PhaseOptions {
            weighting: Weighting::Phase,
            window: true,
        },
    )
    .map_err(|e| Error::Invalid(e.to_string()))?;
    let (mut pa, mut pb) = (vec![0f32; patch * patch], vec![0f32; patch * patch]);
    let mut shifts = Vec::new();
    let step = patch as i64;
    let mut y = y0;
    while y + step <= y1 {
        let mut x = x0;
        while x + step <= x1 {
            for r in 0..patch {
                let ra = (y as usize + r) * sa.width + x as usize;
                let rb = (y - off[1]) as usize * sb.width + r * sb.width + (x - off[0]) as usize;
                pa[r * patch..(r + 1) * patch].copy_from_slice(&ia.plane(0)[ra..ra + patch]);
                pb[r * patch..(r + 1) * patch].copy_from_slice(&ib.plane(0)[rb..rb + patch]);
            }
            // Tiles with nodata (0) in either frame are not compared.
            let valid = !pa.iter().chain(pb.iter()).any(|&v| v == 0.0);
            if valid
                && let Ok(e) = pc.estimate(&pa, &pb)
                && e.confidence > 0.05
                && e.dx.abs().max(e.dy.abs()) < patch as f64 / 4.0
            {
                shifts.push([e.dx, e.dy]);
            }
            x += step;
        }
        y += step;
    }
    if shifts.is_empty() {
        return Err(Error::Invalid(
            "no overlapping patch could be matched".into(),
        ));
    }
    let median = |d: usize| {
        let mut v: Vec<f64> = shifts.iter().map(|s| s[d]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mx, my) = (median(0), median(1));
    let rms = (shifts
        .iter()
        .map(|s| s[0] * s[0] + s[1] * s[1])
        .sum::<f64>()
        / shifts.len() as f64)
        .sqrt();
    Ok(OverlapShift {
        patches: shifts.len(),
        median_px: [mx, my],
        median_m: [mx * gsd, -my * gsd],
        rms_px: rms,
        gsd_m: gsd,
        overlap_px: [(x1 - x0) as usize, (y1 - y0) as usize],
    })
}
