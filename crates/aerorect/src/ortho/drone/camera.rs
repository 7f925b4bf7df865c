//! A photo's camera from its own tags (DJI's DewarpData or calibration tags, the sensor
//! database, or the 35 mm equivalent), sized from the image the tags were written for, and its
//! rotation from the tags.

use super::DroneOptions;
use crate::Error;
use crate::photo_source;
use aerorect_core::distortion::Distortion;
use aerorect_core::{Camera, CameraRotation, ImageSize, Intrinsics};
use aerorect_io::{CameraFormat, PhotoMetadata};
use serde::Serialize;

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
