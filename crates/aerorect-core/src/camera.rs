//! The one frame-camera type: pinhole intrinsics, an optional lens model and the image size it
//! was calibrated for. Every pipeline (rectify, simulate, evaluate, undistort, drone,
//! calibration) takes its camera from here; `resized` carries it to another image size.
//!
//! Camera frame as in [`crate::intrinsics`]: x right, y up, z backwards; a point in front of the
//! camera has z < 0. Distortion works in normalised coordinates (x right, y down).

use crate::Vec3;
use crate::distortion::{Distortion, ValidDomain};
use crate::error::{GeometryError, require_magnitude};
use crate::intrinsics::{ImageSize, Intrinsics};
use serde::Serialize;

/// The largest |coefficient| a lens model may have.
pub const MAX_LENS_COEFFICIENT: f64 = 1e4;

/// A frame camera.
#[derive(Debug, Clone, Serialize)]
pub struct Camera {
    pub intrinsics: Intrinsics,
    /// The lens model, `None` for an ideal pinhole.
    pub distortion: Option<Distortion>,
    /// The image size the intrinsics are in pixels of.
    pub size: ImageSize,
    /// The lens's valid domain, with the model it was computed for (recomputed on the fly when
    /// `distortion` has been changed since).
    #[serde(skip)]
    domain: (Option<Distortion>, Option<ValidDomain>),
}

impl PartialEq for Camera {
    fn eq(&self, other: &Self) -> bool {
        (self.intrinsics, &self.distortion, self.size)
            == (other.intrinsics, &other.distortion, other.size)
    }
}

impl Camera {
    pub fn new(intrinsics: Intrinsics, distortion: Option<Distortion>, size: ImageSize) -> Self {
        let domain = distortion.as_ref().map(Distortion::valid_domain);
        Self {
            intrinsics,
            domain: (distortion.clone(), domain),
            distortion,
            size,
        }
    }

    /// Refuses a camera outside the sane ranges: its size ([`ImageSize::validate`]), its
    /// intrinsics ([`Intrinsics::validate`]) and every lens coefficient within
    /// +-[`MAX_LENS_COEFFICIENT`] (in normalised coordinates, where 1 is a focal length from
    /// the centre).
    pub fn validate(&self) -> Result<(), GeometryError> {
        self.size.validate()?;
        self.intrinsics.validate()?;
        if let Some(d) = &self.distortion {
            let model = d.model();
            for (name, v) in model.names().iter().zip(model.params()) {
                require_magnitude(
                    name,
                    v,
                    (0.0, MAX_LENS_COEFFICIENT),
                    "outside the sane range |value| <= 1e4",
                )?;
            }
        }
        Ok(())
    }

    /// The lens model's valid domain (see [`ValidDomain`]), `None` for an ideal pinhole.
    /// Cached: cheap while `distortion` is the model the camera was made with.
    #[inline]
    pub fn lens_domain(&self) -> Option<ValidDomain> {
        if self.domain.0 == self.distortion {
            self.domain.1
        } else {
            self.distortion.as_ref().map(Distortion::valid_domain)
        }
    }

    /// The same camera for the image resampled to `size`. Pixel centres sit at integer
    /// coordinates, so a position u becomes (u + 0.5) s - 0.5 with s = new / old; focal lengths
    /// and skew scale by s. The lens model works in normalised coordinates and is unchanged.
    /// Refuses a change of aspect ratio of more than one pixel (the image was cropped, not
    /// resized).
    pub fn resized(&self, size: ImageSize) -> Result<Self, GeometryError> {
        if size == self.size {
            return Ok(self.clone());
        }
        let sx = size.width as f64 / self.size.width as f64;
        let sy = size.height as f64 / self.size.height as f64;
        let predicted_h = self.size.height as f64 * sx;
        if size.width == 0 || size.height == 0 || (predicted_h - size.height as f64).abs() > 1.0 {
            return Err(GeometryError::AspectMismatch {
                from: [self.size.width, self.size.height],
                to: [size.width, size.height],
            });
        }
        let k = &self.intrinsics;
        let mut intrinsics = Intrinsics::new(
            k.fx * sx,
            k.fy * sy,
            (k.cx + 0.5) * sx - 0.5,
            (k.cy + 0.5) * sy - 0.5,
        )?;
        intrinsics.skew = k.skew * sx;
        Ok(Self::new(intrinsics, self.distortion.clone(), size))
    }

    /// The observed pixel of a point in the camera frame; `None` behind the camera, outside the
    /// lens's valid domain or where the lens model has no answer.
    #[inline]
    pub fn pixel_from_camera_point(&self, p: Vec3) -> Option<[f64; 2]> {
        if p.z >= 0.0 || p.z.is_nan() {
            return None;
        }
        let n = [p.x / -p.z, p.y / p.z];
        let q = match (&self.distortion, self.lens_domain()) {
            (Some(d), Some(domain)) => d.model().observed_from_ideal_within(&domain, n)?,
            _ => n,
        };
        Some(self.intrinsics.pixel_from_normalized(q[0], q[1]))
    }

    /// The ray (camera frame, z = -1) through observed pixel (u, v), the lens removed; `None`
    /// outside the lens's valid domain or where the lens model's inverse does not converge.
    pub fn ray_from_pixel(&self, u: f64, v: f64) -> Option<Vec3> {
        let n = self.intrinsics.normalized_from_pixel(u, v);
        let q = match (&self.distortion, self.lens_domain()) {
            (Some(d), Some(domain)) => d.model().ideal_from_observed_within(&domain, n)?,
            _ => n,
        };
        Some(Vec3::new(q[0], -q[1], -1.0))
    }

    /// Points along the outline through the corner pixels' centres (the convention of the
    /// output grid), `per_side` intervals on every side, clockwise from the top-left corner.
    pub fn border_pixels(&self, per_side: usize) -> Vec<[f64; 2]> {
        let n = per_side.max(1);
        let corners = self.size.corner_pixels();
        let mut out = Vec::with_capacity(4 * n);
        for s in 0..4 {
            let (a, b) = (corners[s], corners[(s + 1) % 4]);
            for i in 0..n {
                let t = i as f64 / n as f64;
                out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
            }
        }
        out
    }

    /// The rays of the outline of what the camera sees: the undistorted rays of
    /// [`Camera::border_pixels`] when the whole border is inside the lens's valid domain;
    /// otherwise the border clipped to the domain's rim (the `footprint` module).
    pub fn border_rays(&self, per_side: usize) -> Vec<Vec3> {
        let border = self.border_pixels(per_side);
        let rays: Option<Vec<Vec3>> = border
            .iter()
            .map(|p| self.ray_from_pixel(p[0], p[1]))
            .collect();
        match (rays, &self.distortion, self.lens_domain()) {
            (Some(rays), _, _) => rays,
            (None, Some(d), Some(domain)) => crate::footprint::clipped_border_rays(
                &self.intrinsics,
                self.size,
                d.model(),
                &domain,
                per_side,
                |u, v| self.ray_from_pixel(u, v),
            ),
            (None, _, _) => border
                .iter()
                .filter_map(|p| self.ray_from_pixel(p[0], p[1]))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distortion::OpenCv;
    use approx::assert_abs_diff_eq;

    fn camera(d: Option<Distortion>) -> Camera {
        let k = Intrinsics::new(3000.0, 3010.0, 2010.0, 1120.0).unwrap();
        Camera::new(k, d, ImageSize::new(4000, 2250))
    }

    fn lens() -> Option<Distortion> {
        Some(Distortion::OpenCv(OpenCv {
            k1: -0.27,
            k2: 0.1,
            p1: 0.001,
            p2: -0.0005,
            ..OpenCv::default()
        }))
    }

    #[test]
    fn pixel_and_ray_round_trip_through_the_lens() {
        let cam = camera(lens());
        for &(u, v) in &[
            (0.0, 0.0),
            (2010.0, 1120.0),
            (3999.0, 100.0),
            (1234.5, 2249.0),
        ] {
            let r = cam.ray_from_pixel(u, v).unwrap();
            let p = cam.pixel_from_camera_point(r * 7.5).unwrap();
            assert_abs_diff_eq!(p[0], u, epsilon = 1e-6);
            assert_abs_diff_eq!(p[1], v, epsilon = 1e-6);
        }
        assert!(
            cam.pixel_from_camera_point(Vec3::new(0.0, 0.0, 1.0))
                .is_none()
        );
    }

    #[test]
    fn ideal_projection_is_the_pinhole_of_the_camera_module() {
        // The same point through Intrinsics::pixel_from_camera (the paper's K).
        let cam = camera(None);
        let p = Vec3::new(0.3, -0.2, -1.7);
        let h = cam.intrinsics.pixel_from_camera() * p;
        let q = cam.pixel_from_camera_point(p).unwrap();
        assert_abs_diff_eq!(q[0], h.x / h.z, epsilon = 1e-9);
        assert_abs_diff_eq!(q[1], h.y / h.z, epsilon = 1e-9);
    }

    #[test]
    fn resizing_keeps_every_ray_on_the_same_image_feature() {
        // A 4x downsample: the outer corners of the image stay the outer corners, so a ray
        // seen at pixel p in the big image is at (p + 0.5) / 4 - 0.5 in the small one.
        let big = camera(lens());
        let small = big.resized(ImageSize::new(1000, 563)).unwrap();
        for &(u, v) in &[(0.0, 0.0), (1999.5, 1000.0), (3999.0, 2249.0)] {
            let r = big.ray_from_pixel(u, v).unwrap();
            let p = small.pixel_from_camera_point(r).unwrap();
            let sy = 563.0 / 2250.0;
            assert_abs_diff_eq!(p[0], (u + 0.5) / 4.0 - 0.5, epsilon = 1e-9);
            assert_abs_diff_eq!(p[1], (v + 0.5) * sy - 0.5, epsilon = 1e-9);
        }
        assert!(matches!(
            big.resized(ImageSize::new(1000, 1000)),
            Err(GeometryError::AspectMismatch { .. })
        ));
    }

    #[test]
    fn a_camera_outside_the_sane_ranges_is_refused() {
        assert!(camera(lens()).validate().is_ok());
        let refused = |c: Camera| c.validate().unwrap_err().to_string();
        let mut c = camera(None);
        c.intrinsics.fx = 1e308;
        assert!(refused(c).contains("fx_px = 1e308"));
        let mut c = camera(None);
        c.intrinsics.fy = 1e-4;
        assert!(refused(c).contains("fy_px = 0.0001"));
        let mut c = camera(None);
        c.intrinsics.cy = -2e7;
        assert!(refused(c).contains("cy_px = -20000000"));
        let mut c = camera(lens());
        if let Some(Distortion::OpenCv(m)) = c.distortion.as_mut() {
            m.k1 = 1e308;
        }
        assert!(refused(c).contains("k1 = 1e308"));
        // Sides up to 1e6 px, at most 4e9 px in all.
        let sized = |w, h| Camera::new(camera(None).intrinsics, None, ImageSize::new(w, h));
        assert!(sized(1_000_000, 4_000).validate().is_ok());
        assert!(refused(sized(1_000_001, 1)).contains("1000001 x 1 px"));
        assert!(refused(sized(100_000, 50_000)).contains("in all"));
        assert!(refused(sized(0, 10)).contains("at least 1 px"));
        assert!(ImageSize::validate_sides(4_000_000_000, 3_000_000_000).is_err());
    }

    #[test]
    fn border_walks_through_the_corner_pixel_centres_clockwise() {
        let cam = Camera::new(
            Intrinsics::new(10.0, 10.0, 1.5, 0.5).unwrap(),
            None,
            ImageSize::new(4, 2),
        );
        let b = cam.border_pixels(2);
        assert_eq!(b.len(), 8);
        assert_eq!(b[0], [0.0, 0.0]);
        assert_eq!(b[1], [1.5, 0.0]);
        assert_eq!(b[2], [3.0, 0.0]);
        assert_eq!(b[3], [3.0, 0.5]);
        assert_eq!(b[4], [3.0, 1.0]);
        assert_eq!(b[6], [0.0, 1.0]);
    }
}
