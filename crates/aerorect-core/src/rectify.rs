//! The six-angle rectification geometry: F and G (eq. 12-13), altitude normalisation (eq. 14),
//! and the output grid from the ground footprint (section 3), clipped near the horizon.

use crate::Mat3;
use crate::attitude::SixAngleAttitude;
use crate::error::{GeometryError, require_positive};
use crate::homography::Homography;
use crate::intrinsics::{ImageSize, Intrinsics};

/// The largest output (in pixels) that rectification produces unless told otherwise: 64 Mpx.
pub const DEFAULT_MAX_OUTPUT_PX: u64 = 64_000_000;

/// Clipping keeps at least this fraction of the frame's ground area (in frame pixels); a limit
/// that would need more cut away is refused instead.
pub const MIN_KEPT_GROUND_FRACTION: f64 = 0.25;

/// `F = K R K^-1`: oblique pixel -> standard (nadir) pixel, eq. (12). w > 0 on the ground.
pub fn standard_from_oblique(intr: &Intrinsics, attitude: &SixAngleAttitude) -> Homography {
    crate::orientation::standard_from_rotation(intr, &attitude.into())
}

/// Altitude normalisation (eq. 14): a frame taken at `altitude_m` rescaled to `base_altitude_m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AltitudeScale {
    pub altitude_m: f64,
    pub base_altitude_m: f64,
}

impl AltitudeScale {
    /// Checks both altitudes are finite and positive.
    pub fn new(altitude_m: f64, base_altitude_m: f64) -> Result<Self, GeometryError> {
        Ok(Self {
            altitude_m: require_positive("altitude_m", altitude_m)?,
            base_altitude_m: require_positive("base_altitude_m", base_altitude_m)?,
        })
    }

    /// H1 / H.
    pub fn factor(&self) -> f64 {
        self.altitude_m / self.base_altitude_m
    }

    /// `base_from_standard`: scales by H1/H about the principal point (the spec's fix of eq. 14).
    pub fn base_from_standard(&self, principal_point: [f64; 2]) -> Homography {
        let s = self.factor();
        let [u0, v0] = principal_point;
        let m = Mat3::new(
            s,
            0.0,
            u0 * (1.0 - s),
            0.0,
            s,
            v0 * (1.0 - s),
            0.0,
            0.0,
            1.0,
        );
        let i = Mat3::new(
            1.0 / s,
            0.0,
            u0 * (1.0 - 1.0 / s),
            0.0,
            1.0 / s,
            v0 * (1.0 - 1.0 / s),
            0.0,
            0.0,
            1.0,
        );
        Homography::from_pair(m, i)
    }
}

/// Limits on the output grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectifyLimits {
    /// The largest output, width x height, in pixels.
    pub max_output_px: u64,
}

impl Default for RectifyLimits {
    fn default() -> Self {
        Self {
            max_output_px: DEFAULT_MAX_OUTPUT_PX,
        }
    }
}

/// Everything about one frame's rectification that does not touch pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct RectifyGeometry {
    /// F, eq. (12).
    pub standard_from_oblique: Homography,
    /// The altitude-normalised standard frame: `base_from_standard * F`.
    pub base_from_oblique: Homography,
    /// Output pixel (col, row) -> oblique pixel: G with the altitude scale and the grid offset.
    pub oblique_from_output: Homography,
    pub output_size: ImageSize,
    /// Base-frame coordinate of output pixel (0, 0).
    pub standard_origin: [f64; 2],
    /// True when the far field was cut away to respect the limit (or the horizon).
    pub clipped: bool,
    /// The part of the oblique frame that is rectified, as a convex polygon in oblique pixels.
    pub footprint: Vec<[f64; 2]>,
}

impl RectifyGeometry {
    /// Plans the output grid for a `size` frame seen with `intr` and `attitude`.
    pub fn new(
        intr: &Intrinsics,
        size: ImageSize,
        attitude: &SixAngleAttitude,
        altitude: Option<AltitudeScale>,
        limits: RectifyLimits,
    ) -> Result<Self, GeometryError> {
        let f = standard_from_oblique(intr, attitude);
        let scale = altitude
            .map(|a| a.base_from_standard(intr.principal_point()))
            .unwrap_or_else(Homography::identity);
        Self::from_base_homography(f, scale.after(&f), size, limits)
    }

    /// Plans the output grid of any `base_from_oblique` with meaningful w (see `homography`).
    pub fn from_base_homography(
        standard_from_oblique: Homography,
        base_from_oblique: Homography,
        size: ImageSize,
        limits: RectifyLimits,
    ) -> Result<Self, GeometryError> {
        let corners = size.corner_pixels().to_vec();
        Self::from_base_homography_and_border(
            standard_from_oblique,
            base_from_oblique,
            size,
            corners,
            limits,
        )
    }

    /// As [`RectifyGeometry::from_base_homography`], with the frame's outline given as a
    /// polygon in the homography's own pixels: with a lens model, the undistorted image of the
    /// border sampled densely (it bulges or pinches between the corners).
    pub fn from_base_homography_and_border(
        standard_from_oblique: Homography,
        base_from_oblique: Homography,
        size: ImageSize,
        border: Vec<[f64; 2]>,
        limits: RectifyLimits,
    ) -> Result<Self, GeometryError> {
        if size.width == 0 || size.height == 0 || border.len() < 3 {
            return Err(GeometryError::InvalidParameter {
                field: "image_size_px",
                value: 0.0,
                reason: "the frame has no pixels",
            });
        }
        let (footprint, clipped) = clip_footprint(&base_from_oblique, border, limits)?;
        let bounds = grid_bounds(&base_from_oblique, &footprint).ok_or(GeometryError::NoGround)?;
        let origin = [bounds.u0, bounds.v0];
        let oblique_from_output = base_from_oblique
            .inverse()
            .after(&Homography::translation(origin[0], origin[1]));
        Ok(Self {
            standard_from_oblique,
            base_from_oblique,
            oblique_from_output,
            output_size: ImageSize::new(bounds.width as usize, bounds.height as usize),
            standard_origin: origin,
            clipped,
            footprint,
        })
    }
}

/// An integer output grid: origin and size.
#[derive(Debug, Clone, Copy, PartialEq)]
struct GridBounds {
    u0: f64,
    v0: f64,
    width: f64,
    height: f64,
}

impl GridBounds {
    fn pixels(&self) -> f64 {
        self.width * self.height
    }
}

/// Every integer position from floor(min) to ceil(max) of the mapped polygon (section 3, eq. 15).
fn grid_bounds(h: &Homography, polygon: &[[f64; 2]]) -> Option<GridBounds> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in polygon {
        let q = h.map(p[0], p[1])?;
        for k in 0..2 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    let (u0, v0) = (lo[0].floor(), lo[1].floor());
    let b = GridBounds {
        u0,
        v0,
        width: hi[0].ceil() - u0 + 1.0,
        height: hi[1].ceil() - v0 + 1.0,
    };
    b.pixels().is_finite().then_some(b)
}

/// The part of the frame to rectify: the whole frame when its output fits the limit, else the
/// frame cut by the line w = t with the smallest t whose output fits.
fn clip_footprint(
    h: &Homography,
    corners: Vec<[f64; 2]>,
    limits: RectifyLimits,
) -> Result<(Vec<[f64; 2]>, bool), GeometryError> {
    let w_of = |p: &[f64; 2]| h.map_homogeneous(p[0], p[1]).z;
    let w_max = corners.iter().map(w_of).fold(f64::NEG_INFINITY, f64::max);
    let w_min = corners.iter().map(w_of).fold(f64::INFINITY, f64::min);
    if w_max.is_nan() || w_max <= 0.0 {
        return Err(GeometryError::NoGround);
    }
    let limit = limits.max_output_px as f64;
    let fits = |t: f64| -> bool {
        let poly = clip_polygon(&corners, h, t);
        grid_bounds(h, &poly).is_some_and(|b| b.pixels() <= limit)
    };
    if w_min > 0.0 && fits(0.0) {
        return Ok((corners, false));
    }
    // The cut w = t_floor keeps MIN_KEPT_GROUND_FRACTION of the ground area (area falls as t grows).
    let ground_area = polygon_area(&clip_polygon(&corners, h, 0.0));
    let (mut lo, mut hi) = (w_min.max(0.0), w_max);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if polygon_area(&clip_polygon(&corners, h, mid)) >= MIN_KEPT_GROUND_FRACTION * ground_area {
            lo = mid
        } else {
            hi = mid
        }
    }
    let t_floor = lo;
    if !fits(t_floor) {
        let poly = clip_polygon(&corners, h, t_floor);
        let b = grid_bounds(h, &poly).ok_or(GeometryError::NoGround)?;
        return Err(GeometryError::OutputTooLarge {
            width: b.width as u64,
            height: b.height as u64,
            pixels: b.pixels() as u64,
            limit: limits.max_output_px,
        });
    }
    // Output area shrinks monotonically as t grows: bisect for the smallest t that fits.
    let (mut lo, mut hi) = (w_min.max(0.0), t_floor);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) { hi = mid } else { lo = mid }
    }
    Ok((clip_polygon(&corners, h, hi), true))
}

/// Area of a simple polygon (shoelace formula).
fn polygon_area(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    0.5 * twice.abs()
}

/// Sutherland-Hodgman: the convex polygon cut to the half-plane where w(u, v) >= t (w is linear).
fn clip_polygon(poly: &[[f64; 2]], h: &Homography, t: f64) -> Vec<[f64; 2]> {
    let w = |p: &[f64; 2]| h.map_homogeneous(p[0], p[1]).z - t;
    let mut out = Vec::with_capacity(poly.len() + 2);
    for (i, a) in poly.iter().enumerate() {
        let b = &poly[(i + 1) % poly.len()];
        let (wa, wb) = (w(a), w(b));
        if wa >= 0.0 {
            out.push(*a);
        }
        if (wa >= 0.0) != (wb >= 0.0) {
            let s = wa / (wa - wb);
            out.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
        }
    }
    out
}

#[cfg(test)]
mod tests;
