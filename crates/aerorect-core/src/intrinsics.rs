//! Image size and pinhole intrinsics.
//!
//! Camera frame (the paper's S-Xs Ys Zs): x right, y up on the image plane, the optical axis
//! along -Z, so an image point is the ray (x, y, -f). Pixel frame: u right, v down, pixel centres
//! at integer coordinates. In focal units a ray is (x/f, y/f, -1) and
//! `u = fx x/f - skew y/f + cx`, `v = -fy y/f + cy` (eq. 1 with fx = f/dx, fy = f/dy).

use crate::error::{GeometryError, require_finite, require_magnitude, require_positive};
use crate::{Mat3, Vec3};
use serde::{Deserialize, Serialize};

/// The longest side an image may have, pixels (a camera file's `image_size_px`, `--image-size`).
pub const MAX_IMAGE_SIDE_PX: u64 = 1_000_000;
/// The most pixels an image may have, W x H (ten times the largest aerial sensors').
pub const MAX_IMAGE_PX: u64 = 4_000_000_000;
/// The range of a focal length in pixels, and the largest |principal point| and |skew|.
pub const FOCAL_RANGE_PX: (f64, f64) = (1e-3, 1e7);
const FOCAL_REASON: &str = "outside the sane range 0.001 ..= 1e7 px";
const OFFSET_REASON: &str = "outside the sane range |value| <= 1e7 px";

/// Width and height of an image in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ImageSize {
    pub width: usize,
    pub height: usize,
}

impl ImageSize {
    pub fn new(width: usize, height: usize) -> Self {
        Self { width, height }
    }

    /// Refuses a size of zero, a side over [`MAX_IMAGE_SIDE_PX`] or more than [`MAX_IMAGE_PX`]
    /// pixels in all.
    pub fn validate(&self) -> Result<(), GeometryError> {
        Self::validate_sides(self.width as u64, self.height as u64)
    }

    /// [`ImageSize::validate`] for sides not yet known to fit a `usize`.
    pub fn validate_sides(width: u64, height: u64) -> Result<(), GeometryError> {
        let reason = if width == 0 || height == 0 {
            "both sides must be at least 1 px".to_string()
        } else if width.max(height) > MAX_IMAGE_SIDE_PX {
            format!("a side over {MAX_IMAGE_SIDE_PX} px")
        } else if width.saturating_mul(height) > MAX_IMAGE_PX {
            format!("over {MAX_IMAGE_PX} px in all")
        } else {
            return Ok(());
        };
        Err(GeometryError::InvalidImageSize {
            width,
            height,
            reason,
        })
    }

    /// Number of pixels, width x height.
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// The image centre ((W-1)/2, (H-1)/2) in the pixel-centre convention.
    pub fn centre(&self) -> [f64; 2] {
        [
            (self.width as f64 - 1.0) / 2.0,
            (self.height as f64 - 1.0) / 2.0,
        ]
    }

    /// The centres of the four corner pixels: top-left, top-right, bottom-right, bottom-left.
    pub fn corner_pixels(&self) -> [[f64; 2]; 4] {
        let (w, h) = (self.width as f64 - 1.0, self.height as f64 - 1.0);
        [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]
    }
}

/// Pinhole intrinsics in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub skew: f64,
}

impl Intrinsics {
    /// Intrinsics in pixels; focal lengths must be positive and everything finite.
    pub fn new(fx: f64, fy: f64, cx: f64, cy: f64) -> Result<Self, GeometryError> {
        Ok(Self {
            fx: require_positive("fx_px", fx)?,
            fy: require_positive("fy_px", fy)?,
            cx: require_finite("cx_px", cx)?,
            cy: require_finite("cy_px", cy)?,
            skew: 0.0,
        })
    }

    /// Refuses intrinsics outside the sane ranges: focal lengths within [`FOCAL_RANGE_PX`],
    /// |principal point| and |skew| at most its upper end.
    pub fn validate(&self) -> Result<(), GeometryError> {
        require_magnitude("fx_px", self.fx, FOCAL_RANGE_PX, FOCAL_REASON)?;
        require_magnitude("fy_px", self.fy, FOCAL_RANGE_PX, FOCAL_REASON)?;
        let offsets = (0.0, FOCAL_RANGE_PX.1);
        require_magnitude("cx_px", self.cx, offsets, OFFSET_REASON)?;
        require_magnitude("cy_px", self.cy, offsets, OFFSET_REASON)?;
        require_magnitude("skew_px", self.skew, offsets, OFFSET_REASON)?;
        Ok(())
    }

    /// The paper's parameters: focal length f (mm), pixel pitch dx, dy (um), principal point
    /// (u0, v0) in pixels. fx = f/dx, fy = f/dy.
    pub fn from_physical(
        focal_length_mm: f64,
        pixel_pitch_um: [f64; 2],
        principal_point_px: [f64; 2],
    ) -> Result<Self, GeometryError> {
        let f = require_positive("focal_length_mm", focal_length_mm)?;
        let dx = require_positive("pixel_pitch_um[0]", pixel_pitch_um[0])? * 1e-3;
        let dy = require_positive("pixel_pitch_um[1]", pixel_pitch_um[1])? * 1e-3;
        Self::new(f / dx, f / dy, principal_point_px[0], principal_point_px[1])
    }

    /// K in focal units: maps a ray (x/f, y/f, -1) of the camera frame to homogeneous pixels.
    /// It is the paper's K (eq. 1) multiplied by f; a homography K R K^-1 is the same for both.
    pub fn pixel_from_camera(&self) -> Mat3 {
        Mat3::new(
            self.fx, -self.skew, -self.cx, 0.0, -self.fy, -self.cy, 0.0, 0.0, -1.0,
        )
    }

    /// K^-1: homogeneous pixel (u, v, 1) -> camera ray with z = -1.
    pub fn camera_from_pixel(&self) -> Mat3 {
        let (fx, fy, s) = (self.fx, self.fy, self.skew);
        Mat3::new(
            1.0 / fx,
            -s / (fx * fy),
            -self.cx / fx + s * self.cy / (fx * fy),
            0.0,
            -1.0 / fy,
            self.cy / fy,
            0.0,
            0.0,
            -1.0,
        )
    }

    /// The ray (z = -1) through pixel (u, v).
    pub fn ray_from_pixel(&self, u: f64, v: f64) -> Vec3 {
        self.camera_from_pixel() * Vec3::new(u, v, 1.0)
    }

    /// Normalised image coordinates (x right, y down, skew removed) of pixel (u, v): the
    /// coordinates the distortion models work in.
    pub fn normalized_from_pixel(&self, u: f64, v: f64) -> [f64; 2] {
        let y = (v - self.cy) / self.fy;
        [(u - self.cx - self.skew * y) / self.fx, y]
    }

    /// Pixel of normalised coordinates (x, y): u = fx x + skew y + cx, v = fy y + cy.
    pub fn pixel_from_normalized(&self, x: f64, y: f64) -> [f64; 2] {
        [self.fx * x + self.skew * y + self.cx, self.fy * y + self.cy]
    }

    /// Principal point as an array.
    pub fn principal_point(&self) -> [f64; 2] {
        [self.cx, self.cy]
    }

    /// Horizontal and vertical full field of view in degrees for an image of `size`.
    pub fn field_of_view_deg(&self, size: ImageSize) -> [f64; 2] {
        let half =
            |n: usize, c: f64, f: f64| ((c + 0.5) / f).atan() + ((n as f64 - 0.5 - c) / f).atan();
        [
            half(size.width, self.cx, self.fx).to_degrees(),
            half(size.height, self.cy, self.fy).to_degrees(),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// The paper's K and K^-1 in millimetres, written from the spec.
    fn paper_k(f: f64, dx: f64, dy: f64, u0: f64, v0: f64) -> (Mat3, Mat3) {
        let k = Mat3::new(
            1.0 / dx,
            0.0,
            -u0 / f,
            0.0,
            -1.0 / dy,
            -v0 / f,
            0.0,
            0.0,
            -1.0 / f,
        );
        let kinv = Mat3::new(dx, 0.0, -u0 * dx, 0.0, -dy, v0 * dy, 0.0, 0.0, -f);
        (k, kinv)
    }

    #[test]
    fn k_matches_the_paper_up_to_the_focal_scale() {
        let (f, dx, dy, u0, v0) = (50.0, 0.0074, 0.0065, 255.5, 250.0);
        let intr = Intrinsics::from_physical(f, [7.4, 6.5], [u0, v0]).expect("valid");
        let (k, kinv) = paper_k(f, dx, dy, u0, v0);
        assert_relative_eq!(intr.pixel_from_camera() / f, k, max_relative = 1e-12);
        assert_relative_eq!(intr.camera_from_pixel() * f, kinv, max_relative = 1e-12);
        assert_relative_eq!(k * kinv, Mat3::identity(), epsilon = 1e-12);
    }

    #[test]
    fn k_inverse_is_inverse_with_skew() {
        let mut intr = Intrinsics::new(1200.0, 1100.0, 320.0, 240.0).expect("valid");
        intr.skew = 3.5;
        let prod = intr.pixel_from_camera() * intr.camera_from_pixel();
        assert_relative_eq!(prod, Mat3::identity(), epsilon = 1e-12);
    }

    #[test]
    fn eq1_pixel_from_image_plane() {
        // u = x/dx + u0, v = -y/dy + v0 for the image point (x, y) in mm.
        let (f, u0, v0) = (35.0, 100.0, 80.0);
        let intr = Intrinsics::from_physical(f, [10.0, 12.0], [u0, v0]).expect("valid");
        let (x, y) = (0.3, -0.45);
        let p = intr.pixel_from_camera() * Vec3::new(x / f, y / f, -1.0);
        assert_relative_eq!(p.x / p.z, x / 0.010 + u0, epsilon = 1e-9);
        assert_relative_eq!(p.y / p.z, -y / 0.012 + v0, epsilon = 1e-9);
    }

    #[test]
    fn refuses_bad_physical_parameters() {
        let e = Intrinsics::from_physical(0.0, [5.0, 5.0], [0.0, 0.0]).unwrap_err();
        assert!(matches!(
            e,
            GeometryError::InvalidParameter {
                field: "focal_length_mm",
                ..
            }
        ));
        let e = Intrinsics::from_physical(10.0, [-5.0, 5.0], [0.0, 0.0]).unwrap_err();
        assert!(matches!(
            e,
            GeometryError::InvalidParameter {
                field: "pixel_pitch_um[0]",
                ..
            }
        ));
        let e = Intrinsics::from_physical(10.0, [5.0, f64::NAN], [0.0, 0.0]).unwrap_err();
        assert!(matches!(
            e,
            GeometryError::InvalidParameter {
                field: "pixel_pitch_um[1]",
                ..
            }
        ));
    }

    #[test]
    fn normalised_coordinates_round_trip_with_skew() {
        let mut k = Intrinsics::new(800.0, 790.0, 320.0, 240.0).expect("valid");
        k.skew = 1.5;
        let n = k.normalized_from_pixel(100.0, 400.0);
        let p = k.pixel_from_normalized(n[0], n[1]);
        assert!((p[0] - 100.0).abs() < 1e-12 && (p[1] - 400.0).abs() < 1e-12);
        assert_eq!(k.normalized_from_pixel(320.0, 240.0), [0.0, 0.0]);
    }

    #[test]
    fn centre_is_pixel_centre_convention() {
        assert_eq!(ImageSize::new(512, 480).centre(), [255.5, 239.5]);
        assert_eq!(ImageSize::new(3, 1).corner_pixels()[2], [2.0, 0.0]);
    }

    #[test]
    fn field_of_view_closed_form() {
        let intr = Intrinsics::new(1000.0, 1000.0, 255.5, 255.5).expect("valid");
        let fov = intr.field_of_view_deg(ImageSize::new(512, 512));
        assert_relative_eq!(
            fov[0],
            2.0 * (256.0f64 / 1000.0).atan().to_degrees(),
            epsilon = 1e-12
        );
    }
}
