//! Undistortion: each output (ideal) pixel mapped to its observed position through the lens
//! model and resampled by the warp engine.

use crate::{Error, warp_any};
use aerorect_core::distortion::Distortion;
use aerorect_core::{ImageSize, Intrinsics};
use aerorect_raster::{AnyRaster, LensDirection, LensMap, PixelMap, WarpOptions};

/// Largest output of `--fit`, relative to the input's pixel count.
const MAX_FIT_GROWTH: f64 = 16.0;

/// One camera's undistortion, planned once for frames of `input_size`.
#[derive(Debug, Clone)]
pub struct UndistortPlan {
    pub map: LensMap,
    pub output_size: ImageSize,
    /// The output's intrinsics (same focal lengths; principal point moved when fitting).
    pub output_intrinsics: Intrinsics,
}

impl UndistortPlan {
    /// Keeps the input's size and intrinsics, or with `fit` grows the output to hold every
    /// valid input pixel (the undistorted image of the input's border) at the same focal lengths.
    pub fn new(
        k: Intrinsics,
        input_size: ImageSize,
        model: Distortion,
        fit: bool,
    ) -> Result<Self, Error> {
        let (mut out_k, mut size) = (k, input_size);
        if fit {
            (out_k, size) = fitted(&k, input_size, &model)?;
        }
        let map = LensMap {
            from: out_k,
            to: k,
            model,
            direction: LensDirection::ObservedFromIdeal,
        };
        Ok(Self {
            map,
            output_size: size,
            output_intrinsics: out_k,
        })
    }

    pub fn run(&self, input: &AnyRaster, warp: &WarpOptions) -> Result<AnyRaster, Error> {
        warp_any(input, &self.map, self.output_size, warp)
    }
}

/// Bounds of the undistorted border of the input, in ideal pixels of `k`.
fn fitted(
    k: &Intrinsics,
    size: ImageSize,
    model: &Distortion,
) -> Result<(Intrinsics, ImageSize), Error> {
    let back = LensMap {
        from: *k,
        to: *k,
        model: model.clone(),
        direction: LensDirection::IdealFromObserved,
    };
    let (w, h) = (size.width as f64 - 1.0, size.height as f64 - 1.0);
    let border = (0..size.width)
        .flat_map(|x| [[x as f64, 0.0], [x as f64, h]])
        .chain((0..size.height).flat_map(|y| [[0.0, y as f64], [w, y as f64]]));
    let ([x0, y0], [nw, nh]) = crate::covering_grid(border, |p| back.source_of(p[0], p[1]))
        .map_err(|p| {
            Error::Invalid(format!(
                "the lens model cannot undistort border pixel ({}, {})",
                p[0], p[1]
            ))
        })?;
    // NaN-safe: a non-finite size fails `is_finite` and is refused too.
    let pixels = nw * nh;
    if !pixels.is_finite() || pixels > MAX_FIT_GROWTH * size.pixels() as f64 {
        return Err(Error::Invalid(format!(
            "--fit would make a {nw} x {nh} image: the lens model is not plausible for this frame"
        )));
    }
    let mut out = *k;
    out.cx -= x0;
    out.cy -= y0;
    Ok((out, ImageSize::new(nw as usize, nh as usize)))
}
