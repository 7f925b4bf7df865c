//! Undistortion: each output (ideal) pixel mapped to its observed position through the lens
//! model and resampled by the warp engine.

use crate::{Error, warp_any};
use aerorect_core::{Camera, ImageSize, Intrinsics};
use aerorect_raster::{AnyRaster, LensDirection, LensMap, WarpOptions};

/// Largest output of `--fit`, relative to the input's pixel count.
const MAX_FIT_GROWTH: f64 = 16.0;

/// One camera's undistortion, planned once for frames of the camera's size.
#[derive(Debug, Clone)]
pub struct UndistortPlan {
    pub map: LensMap,
    /// The ideal pinhole of the output: the same focal lengths; the principal point and size
    /// changed when fitting.
    pub output: Camera,
}

impl UndistortPlan {
    /// Keeps the input's size and intrinsics, or with `fit` grows the output to hold every
    /// valid input pixel (the undistorted image of the input's border) at the same focal lengths.
    /// A camera without a lens model is refused (there is nothing to undistort).
    pub fn new(camera: &Camera, fit: bool) -> Result<Self, Error> {
        let Some(model) = camera.distortion.clone() else {
            return Err(Error::Invalid(
                "the camera has no lens model: nothing to undistort".into(),
            ));
        };
        let k = camera.intrinsics;
        let (mut out_k, mut size) = (k, camera.size);
        if fit {
            (out_k, size) = fitted(camera)?;
        }
        let map = LensMap::new(out_k, k, model, LensDirection::ObservedFromIdeal);
        Ok(Self {
            map,
            output: Camera::new(out_k, None, size),
        })
    }

    pub fn run(&self, input: &AnyRaster, warp: &WarpOptions) -> Result<AnyRaster, Error> {
        warp_any(input, &self.map, self.output.size, warp)
    }
}

/// Bounds of the undistorted border of the input (clipped to the lens's valid domain), in ideal
/// pixels of the camera's intrinsics.
fn fitted(camera: &Camera) -> Result<(Intrinsics, ImageSize), Error> {
    let (k, size) = (&camera.intrinsics, camera.size);
    let rays = camera.border_rays(size.width.max(size.height));
    if rays.is_empty() {
        return Err(Error::Invalid(
            "the lens model cannot undistort the image border".into(),
        ));
    }
    let ideal = rays
        .iter()
        .map(|r| k.pixel_from_normalized(r.x / -r.z, r.y / r.z));
    let ([x0, y0], [nw, nh]) = crate::covering_grid(ideal, Some)
        .map_err(|p| Error::Invalid(format!("the lens model cannot undistort pixel {p:?}")))?;
    // NaN-safe: a non-finite size fails `is_finite` and is refused too.
    let pixels = nw * nh;
    if !pixels.is_finite() || pixels > MAX_FIT_GROWTH * size.pixels() as f64 {
        return Err(Error::advice(format!(
            "`fit` would make a {nw} x {nh} image: the lens model is not plausible for this frame"
        )));
    }
    let mut out = *k;
    out.cx -= x0;
    out.cy -= y0;
    Ok((out, ImageSize::new(nw as usize, nh as usize)))
}
