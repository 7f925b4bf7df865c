//! Check-point evaluation, eq. (19)-(20): standard points mapped to the oblique frame with G.

use crate::Error;
use aerorect_core::error::Num;
use aerorect_core::evaluate::{residuals, stats};
use aerorect_core::rectify::standard_from_oblique;
use aerorect_core::{Camera, CheckPoint, CheckPointStats, SixAngleAttitude};
use aerorect_raster::{LensDirection, LensMap, PixelMap};

/// du_max, dv_max, URMS, VRMS and RMSE of `points` under `attitude`. With a lens model in the
/// camera, the recorded oblique points are undistorted first (residuals in ideal pixels).
pub fn evaluate(
    camera: &Camera,
    attitude: &SixAngleAttitude,
    points: &[CheckPoint],
) -> Result<CheckPointStats, Error> {
    check_inside_the_frame(camera, points)?;
    let g = standard_from_oblique(&camera.intrinsics, attitude).inverse();
    let mut ideal = points.to_vec();
    if let Some(lens) = LensMap::of_camera(camera, LensDirection::IdealFromObserved) {
        for (i, p) in ideal.iter_mut().enumerate() {
            [p.u_oblique, p.v_oblique] =
                lens.source_of(p.u_oblique, p.v_oblique).ok_or_else(|| {
                    Error::Invalid(format!(
                        "check point {}: the lens model cannot undistort it",
                        i + 1
                    ))
                })?;
        }
    }
    let points = &ideal;
    let r = residuals(points, &g);
    if let Some(i) = r.iter().position(Option::is_none) {
        return Err(Error::Invalid(format!(
            "check point {} (standard ({}, {})) lies beyond the horizon of the oblique frame",
            i + 1,
            Num(points[i].u_standard),
            Num(points[i].v_standard)
        )));
    }
    let r: Vec<[f64; 2]> = r.into_iter().flatten().collect();
    let s = stats(&r).ok_or_else(|| Error::Invalid("no check points".into()))?;
    if [s.du_max, s.dv_max, s.rmse].iter().all(|v| v.is_finite()) {
        Ok(s)
    } else {
        Err(Error::Invalid(format!(
            "the residuals overflow (RMSE = {}): a standard point is far outside the frame",
            Num(s.rmse)
        )))
    }
}

/// Every recorded oblique point must be a position in the frame (pixel centres at integers, so
/// the frame spans -0.5 .. W - 0.5).
fn check_inside_the_frame(camera: &Camera, points: &[CheckPoint]) -> Result<(), Error> {
    let (w, h) = (camera.size.width as f64, camera.size.height as f64);
    let inside = |p: &CheckPoint| {
        (-0.5..=w - 0.5).contains(&p.u_oblique) && (-0.5..=h - 0.5).contains(&p.v_oblique)
    };
    match points.iter().position(|p| !inside(p)) {
        None => Ok(()),
        Some(i) => Err(Error::Invalid(format!(
            "check point {} at oblique ({}, {}) lies outside the {} x {} frame",
            i + 1,
            Num(points[i].u_oblique),
            Num(points[i].v_oblique),
            camera.size.width,
            camera.size.height
        ))),
    }
}

/// PSNR (dB) of a rectified image against the standard scene it was simulated from, and the
/// number of pixels compared: those whose source lies at least `margin` px inside the oblique
/// frame of `camera` and inside ORTHO. The rectification must be without altitude scaling, and the grid
/// offset to ORTHO integral (ORTHO's centre and the principal point both on the pixel grid or
/// both half-way). `None` when nothing is compared.
pub fn rectified_psnr(
    rectified: &aerorect_raster::AnyRaster,
    geometry: &aerorect_core::RectifyGeometry,
    camera: &Camera,
    ortho: &aerorect_raster::AnyRaster,
    margin: f64,
) -> Option<(f64, usize)> {
    let (frame_size, principal_point) = (camera.size, camera.intrinsics.principal_point());
    let [ocx, ocy] = ortho.size().centre();
    let off = [
        geometry.standard_origin[0] + ocx - principal_point[0],
        geometry.standard_origin[1] + ocy - principal_point[1],
    ];
    if off.iter().any(|o| o.fract() != 0.0) {
        return None;
    }
    let (fw, fh) = (frame_size.width as f64, frame_size.height as f64);
    let size = geometry.output_size;
    let peak = match ortho {
        aerorect_raster::AnyRaster::U8(_) => 255.0,
        aerorect_raster::AnyRaster::U16(_) => 65535.0,
        aerorect_raster::AnyRaster::F32(_) => 1.0,
    };
    let (mut se, mut n) = (0.0f64, 0usize);
    for b in 0..ortho.bands() {
        let (a, o) = (rectified.plane_f32(b), ortho.plane_f32(b));
        for r in 0..size.height {
            for c in 0..size.width {
                let Some(p) = geometry.oblique_from_output.map(c as f64, r as f64) else {
                    continue;
                };
                if p[0] < margin
                    || p[1] < margin
                    || p[0] > fw - 1.0 - margin
                    || p[1] > fh - 1.0 - margin
                {
                    continue;
                }
                let (x, y) = (c as f64 + off[0], r as f64 + off[1]);
                if x < 0.0
                    || y < 0.0
                    || x >= ortho.size().width as f64
                    || y >= ortho.size().height as f64
                {
                    continue;
                }
                let d = a[r * size.width + c] as f64
                    - o[y as usize * ortho.size().width + x as usize] as f64;
                se += d * d;
                n += 1;
            }
        }
    }
    (n > 0).then(|| (10.0 * (peak * peak / (se / n as f64)).log10(), n))
}
