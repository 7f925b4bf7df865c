//! The orthophoto grid and the map from its pixels to the frame's: each output pixel's ground
//! point (its grid position at the terrain's height) projected through the camera, in f64.

use crate::{Pose, Terrain};
use aerorect_core::distortion::{Distortion, DistortionModel, ValidDomain};
use aerorect_core::{Camera, ImageSize, Vec3};
use aerorect_raster::PixelMap;
use serde::Serialize;

/// A north-up grid: the centre of pixel (c, r) is (x0 + (c + 0.5) g, y0 - (r + 0.5) g), with
/// (x0, y0) the outer corner of pixel (0, 0) (the GeoTIFF tie point).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OrthoGrid {
    pub top_left: [f64; 2],
    pub gsd: f64,
    pub size: ImageSize,
}

impl OrthoGrid {
    /// The grid aligned to multiples of `gsd` that covers `bounds` = [xmin, ymin, xmax, ymax],
    /// so every frame at one GSD shares one grid.
    pub fn covering(bounds: [f64; 4], gsd: f64) -> Self {
        let (i0, i1) = ((bounds[0] / gsd).floor(), (bounds[2] / gsd).ceil());
        let (j0, j1) = ((bounds[1] / gsd).floor(), (bounds[3] / gsd).ceil());
        Self {
            top_left: [i0 * gsd, j1 * gsd],
            gsd,
            size: ImageSize::new((i1 - i0).max(1.0) as usize, (j1 - j0).max(1.0) as usize),
        }
    }

    /// World position of the centre of pixel (c, r).
    #[inline]
    pub fn centre_of(&self, c: f64, r: f64) -> [f64; 2] {
        [
            self.top_left[0] + (c + 0.5) * self.gsd,
            self.top_left[1] - (r + 0.5) * self.gsd,
        ]
    }
}

/// The pixels of A that B also covers, when B's pixel (0, 0) is A's `offset`: [c0, r0, c1, r1)
/// in A's pixels, empty (c1 <= c0 or r1 <= r0) when they do not overlap.
pub fn common_window(a: ImageSize, b: ImageSize, offset: [i64; 2]) -> [i64; 4] {
    [
        offset[0].max(0),
        offset[1].max(0),
        (a.width as i64).min(offset[0] + b.width as i64),
        (a.height as i64).min(offset[1] + b.height as i64),
    ]
}

/// Output pixel -> frame pixel through the terrain and the camera.
#[derive(Debug, Clone)]
pub struct GroundMap {
    pub camera: Camera,
    pub pose: Pose,
    pub grid: OrthoGrid,
    pub terrain: Terrain,
}

impl GroundMap {
    fn row_with<M: DistortionModel>(
        &self,
        lens: Option<(&M, ValidDomain)>,
        row: usize,
        col0: usize,
        xs: &mut [f64],
        ys: &mut [f64],
    ) {
        let k = &self.camera.intrinsics;
        let [x0, y] = self.grid.centre_of(col0 as f64, row as f64);
        // The row's heights first, in `xs`.
        for (i, x) in xs.iter_mut().enumerate() {
            *x = x0 + i as f64 * self.grid.gsd;
        }
        self.terrain.heights_along(y, xs);
        for (i, (x_out, y_out)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let x = x0 + i as f64 * self.grid.gsd;
            let z = *x_out;
            let d = self.pose.camera_from_world([x, y, z]);
            let p = if d.z < 0.0 {
                let n = [d.x / -d.z, d.y / d.z];
                let q = match &lens {
                    None => Some(n),
                    Some((m, domain)) => m.observed_from_ideal_within(domain, n),
                };
                q.map(|q| k.pixel_from_normalized(q[0], q[1]))
            } else {
                None
            };
            let p = p.unwrap_or([f64::NAN; 2]);
            (*x_out, *y_out) = (p[0], p[1]);
        }
    }
}

impl PixelMap for GroundMap {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        let [x, y] = self.grid.centre_of(col, row);
        let z = self.terrain.height_at(x, y);
        self.camera
            .pixel_from_camera_point(self.pose.camera_from_world([x, y, z]))
    }

    /// The lens model is matched once per row; the loop is monomorphised.
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        use Distortion as D;
        // The lens's valid domain, cached in the camera; ground beyond it is not seen.
        let Some(domain) = self.camera.lens_domain() else {
            return self.row_with::<aerorect_core::distortion::OpenCv>(None, row, col0, xs, ys);
        };
        match &self.camera.distortion {
            None => self.row_with::<aerorect_core::distortion::OpenCv>(None, row, col0, xs, ys),
            Some(D::Tsai(m)) => self.row_with(Some((m, domain)), row, col0, xs, ys),
            Some(D::Brown(m)) => self.row_with(Some((m, domain)), row, col0, xs, ys),
            Some(D::Improved(m)) => self.row_with(Some((m, domain)), row, col0, xs, ys),
            Some(D::OpenCv(m)) => self.row_with(Some((m, domain)), row, col0, xs, ys),
        }
    }
}

/// Where a ray from the camera centre (world direction `dir`) meets the terrain: marched in
/// steps of `step` metres of ground distance between the planes of the highest and lowest
/// terrain (`range`), then bisected. `None` for rays at or above the horizon.
pub fn march_to_ground(
    pose: &Pose,
    dir: Vec3,
    terrain: &Terrain,
    range: (f64, f64),
    step: f64,
) -> Option<[f64; 3]> {
    let c = pose.centre;
    if dir.z >= 0.0 || dir.z.is_nan() {
        return None;
    }
    let at = |t: f64| [c[0] + t * dir.x, c[1] + t * dir.y, c[2] + t * dir.z];
    let above = |t: f64| {
        let p = at(t);
        p[2] - terrain.height_at(p[0], p[1])
    };
    let t_top = ((c[2] - range.1) / -dir.z).max(0.0);
    let t_bottom = ((c[2] - range.0) / -dir.z).max(t_top);
    let dt = step / dir.xy().norm().max(1e-9) * dir.norm();
    let dt = dt.min((t_bottom - t_top).max(1e-9));
    let (mut lo, mut hi) = (t_top, t_top);
    while above(hi) > 0.0 {
        if hi >= t_bottom {
            return Some(at(t_bottom));
        }
        lo = hi;
        hi = (hi + dt).min(t_bottom);
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if above(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    Some(at(0.5 * (lo + hi)))
}
