//! Simulation: the oblique frame a camera would record of a flat scene whose nadir standard
//! image is ORTHO, with ORTHO's centre ((W-1)/2, (H-1)/2) at the standard frame's principal point.

use crate::{Error, warp_any};
use aerorect_core::rectify::standard_from_oblique;
use aerorect_core::{Camera, CheckPoint, Homography, ImageSize, SixAngleAttitude};
use aerorect_raster::{AnyRaster, LensDirection, LensMap, PixelMap, Then, WarpOptions};

/// One simulated frame's geometry.
#[derive(Debug, Clone)]
pub struct SimulatePlan {
    /// The camera that records the frame (of its size); with a lens model the recorded
    /// (observed) pixels are undistorted before F.
    pub camera: Camera,
    pub ortho_size: ImageSize,
    /// F: oblique pixel -> standard pixel.
    pub standard_from_oblique: Homography,
    /// Oblique pixel -> ORTHO pixel: F then the shift that puts ORTHO's centre at (cx, cy).
    pub ortho_from_oblique: Homography,
    /// The lens, ideal from observed pixels; `None` for an ideal pinhole.
    lens: Option<LensMap>,
}

impl SimulatePlan {
    pub fn new(camera: Camera, attitude: &SixAngleAttitude, ortho_size: ImageSize) -> Self {
        let k = &camera.intrinsics;
        let f = standard_from_oblique(k, attitude);
        let [ocx, ocy] = ortho_size.centre();
        let shift = Homography::translation(ocx - k.cx, ocy - k.cy);
        let lens = LensMap::of_camera(&camera, LensDirection::IdealFromObserved);
        Self {
            camera,
            ortho_size,
            standard_from_oblique: f,
            ortho_from_oblique: shift.after(&f),
            lens,
        }
    }

    /// The recorded frame's size.
    pub fn frame_size(&self) -> ImageSize {
        self.camera.size
    }

    /// The ideal pixel of a recorded one (identity without distortion).
    fn ideal(&self, u: f64, v: f64) -> Option<[f64; 2]> {
        match &self.lens {
            None => Some([u, v]),
            Some(lens) => lens.source_of(u, v),
        }
    }

    /// Renders the frame; pixels beyond the horizon or outside ORTHO get the nodata value.
    pub fn render(&self, ortho: &AnyRaster, warp: &WarpOptions) -> Result<AnyRaster, Error> {
        if ortho.size() != self.ortho_size {
            return Err(Error::Invalid(
                "ORTHO does not have the planned size".into(),
            ));
        }
        let size = self.frame_size();
        match &self.lens {
            None => warp_any(ortho, &self.ortho_from_oblique, size, warp),
            Some(lens) => warp_any(
                ortho,
                &Then(lens.clone(), self.ortho_from_oblique),
                size,
                warp,
            ),
        }
    }

    /// True when oblique pixel (u, v) sees the ground inside ORTHO (with a `margin` in pixels).
    pub fn sees_ortho(&self, u: f64, v: f64, margin: f64) -> bool {
        let (w, h) = (self.ortho_size.width as f64, self.ortho_size.height as f64);
        let ideal = self.ideal(u, v);
        ideal
            .and_then(|q| self.ortho_from_oblique.map(q[0], q[1]))
            .is_some_and(|p| {
                p[0] >= margin
                    && p[1] >= margin
                    && p[0] <= w - 1.0 - margin
                    && p[1] <= h - 1.0 - margin
            })
    }

    /// The most check points asked of one frame: one per 16 of its pixels, at most
    /// [`MAX_CHECKPOINTS`] (the search for them grows with the count: 1e9 ran without bound).
    pub fn checkpoint_limit(&self) -> usize {
        let s = self.frame_size();
        (s.width * s.height / 16).clamp(1, MAX_CHECKPOINTS)
    }

    /// Refuses a check-point count of 0 or above [`Self::checkpoint_limit`].
    pub fn check_checkpoint_count(&self, n: usize) -> Result<(), Error> {
        let (limit, s) = (self.checkpoint_limit(), self.frame_size());
        if (1..=limit).contains(&n) {
            return Ok(());
        }
        Err(Error::advice(format!(
            "`checkpoints` {n}: give 1 to {limit} for a {} x {} frame \
             (one per 16 px, at most {MAX_CHECKPOINTS})",
            s.width, s.height
        )))
    }

    /// Up to `n` check points spread evenly over the frame (5 % margin), each on the ground
    /// inside ORTHO; the standard coordinates are exact (F of the true attitude).
    pub fn checkpoints(&self, n: usize) -> Vec<CheckPoint> {
        let mut k = (n as f64).sqrt().ceil().max(1.0) as usize;
        loop {
            let grid: Vec<[f64; 2]> = spread_grid(self.frame_size(), k)
                .into_iter()
                .filter(|p| self.sees_ortho(p[0], p[1], 2.0))
                .collect();
            if grid.len() >= n || k > 8 * (n.max(1) as f64).sqrt() as usize + 8 {
                let step = (grid.len() as f64 / n.max(1) as f64).max(1.0);
                return (0..n.min(grid.len()))
                    .filter_map(|i| grid.get((i as f64 * step) as usize))
                    .filter_map(|p| {
                        let q = self.ideal(p[0], p[1])?;
                        let s = self.standard_from_oblique.map(q[0], q[1])?;
                        Some(CheckPoint {
                            u_oblique: p[0],
                            v_oblique: p[1],
                            u_standard: s[0],
                            v_standard: s[1],
                        })
                    })
                    .collect();
            }
            k += 1;
        }
    }
}

/// The most check points [`SimulatePlan::checkpoints`] is asked for.
pub const MAX_CHECKPOINTS: usize = 100_000;

/// A k x k grid of cell centres over the frame, inside a 5 % margin.
pub fn spread_grid(frame: ImageSize, k: usize) -> Vec<[f64; 2]> {
    let (w, h) = (frame.width as f64 - 1.0, frame.height as f64 - 1.0);
    (0..k * k)
        .map(|i| {
            let (a, b) = ((i % k) as f64 + 0.5, (i / k) as f64 + 0.5);
            [
                w * (0.05 + 0.9 * a / k as f64),
                h * (0.05 + 0.9 * b / k as f64),
            ]
        })
        .collect()
}
