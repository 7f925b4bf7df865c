//! Guided feature matching: where the recorded orientation is known well enough (a gimbal's
//! attitude to a degree or two, positions from a pose table or RTK, a DEM), a keypoint of
//! frame `a` put on the ground by `a`'s recorded orientation and seen from `b`'s lands within
//! a few percent of `b`'s frame of its match, so it is compared only with `b`'s keypoints
//! there ([`aerorect_solve::matching::match_float_within`]). Where the window would cover a
//! large part of the frame (body angles, GPS track headings, consumer GPS at low height, no
//! DEM), every keypoint is compared with every other, as before.
//!
//! The window's radius adds, in `b`'s pixels: the relative turn of the two frames
//! ([`GUIDE_SIGMAS`] of their priors, both frames' errors, stretched towards the corners),
//! their relative shift (the positions' prior) and the relief's parallax (the ground's
//! uncertainty over the pair's baseline), plus [`GUIDE_SLACK_PX`] for the keypoints'
//! positions.

use super::*;
use crate::features::FrameFeatures;

/// Standard deviations of the priors a window spans: a pair's relative turn beyond it (both
/// frames' errors, each N(0, sigma) about each axis) has a chance of about 3e-4 (a Rayleigh
/// tail), and a pair guided wrongly is matched again in full ([`GUIDE_RETRY_OVERLAP`]).
pub const GUIDE_SIGMAS: f64 = 4.0;

/// Added to every window's radius, pixels of the reduced frame: a keypoint's position and the
/// reduction's rounding.
pub const GUIDE_SLACK_PX: f64 = 4.0;

/// A pair is guided only when its window covers at most this fraction of `b`'s frame; a
/// wider window saves little over comparing everything.
pub const MAX_GUIDE_FRACTION: f64 = 0.2;

/// A guided pair that does not tie is matched again in full when at least this fraction of
/// `a`'s keypoints were predicted inside `b`: the prediction said they overlap.
pub const GUIDE_RETRY_OVERLAP: f64 = 0.2;

/// Where `a`'s keypoints should lie in `b` (reduced pixels of `b`), and how far from it their
/// matches may be.
#[derive(Debug, Clone)]
pub struct Guide {
    pub query_at: Vec<Option<[f64; 2]>>,
    pub radius: f64,
    /// The fraction of `a`'s keypoints predicted inside `b`.
    pub inside: f64,
}

impl FlightPlan {
    /// Each keypoint of frame `k` (`features`' positions, reduced by their factor) on the
    /// ground by the recorded orientation; none where its ray misses the ground.
    pub(super) fn keypoints_on_ground(&self, k: usize, f: &FrameFeatures) -> Vec<Option<[f64; 3]>> {
        let (pose, camera) = (&self.rec.poses[k], &self.rec.cameras[self.rec.camera_of[k]]);
        f.features
            .keypoints
            .iter()
            .map(|kp| {
                let px = aerorect_raster::features::full_from_reduced(f.factor, [kp.x, kp.y]);
                on_ground(pose, camera, px, self.ground.as_ref())
            })
            .collect()
    }

    /// The window that guides matching frame `i`'s keypoints (`a`) with frame `j`'s (`b`);
    /// none when the priors leave it too wide ([`MAX_GUIDE_FRACTION`]) or `a` has no ground
    /// positions.
    pub(super) fn guide(
        &self,
        (i, a): (usize, &FrameFeatures),
        (j, b): (usize, &FrameFeatures),
    ) -> Option<Guide> {
        if a.ground.len() != a.features.len() || a.features.is_empty() {
            return None;
        }
        let radius = self.guide_radius(i, j)? / b.factor as f64 + GUIDE_SLACK_PX;
        let (w, h) = (
            b.size.width as f64 / b.factor as f64,
            b.size.height as f64 / b.factor as f64,
        );
        if std::f64::consts::PI * radius * radius > MAX_GUIDE_FRACTION * w * h {
            return None;
        }
        let (pose, camera) = (&self.rec.poses[j], &self.rec.cameras[self.rec.camera_of[j]]);
        let camera_from_world = pose.world_from_camera().transpose();
        let centre = aerorect_core::Vec3::from(pose.centre);
        let reduced = |p: [f64; 2]| p.map(|v| (v + 0.5) / b.factor as f64 - 0.5);
        let query_at: Vec<Option<[f64; 2]>> = a
            .ground
            .iter()
            .map(|g| {
                let d = camera_from_world * (aerorect_core::Vec3::from((*g)?) - centre);
                camera.pixel_from_camera_point(d).map(reduced)
            })
            .collect();
        let within =
            |p: &[f64; 2]| p[0] >= -0.5 && p[0] < w - 0.5 && p[1] >= -0.5 && p[1] < h - 0.5;
        let inside = query_at.iter().flatten().filter(|p| within(p)).count();
        Some(Guide {
            inside: inside as f64 / query_at.len() as f64,
            query_at,
            radius,
        })
    }

    /// The radius of pair (`i`, `j`)'s window in frame `j`'s full-resolution pixels (see the
    /// module); none when a prior is too wide to bound it.
    fn guide_radius(&self, i: usize, j: usize) -> Option<f64> {
        let sigma_deg = [i, j]
            .map(|k| self.frames[k].attitude_sigma_deg(self.fo.attitude_sigma_deg))
            .into_iter()
            .fold(0.0, f64::max);
        let turn = (GUIDE_SIGMAS * std::f64::consts::SQRT_2 * sigma_deg).to_radians();
        if turn >= 1.0 {
            return None;
        }
        let (pa, pb) = (&self.rec.poses[i], &self.rec.poses[j]);
        let camera = &self.rec.cameras[self.rec.camera_of[j]];
        let f = camera.intrinsics.fx.max(camera.intrinsics.fy);
        let corner = 0.5 * (camera.size.width as f64).hypot(camera.size.height as f64);
        let height = pb.centre[2] - (self.ground)(pb.centre[0], pb.centre[1]);
        if height.is_nan() || height <= 0.0 {
            return None;
        }
        let position_m = [i, j]
            .map(|k| self.frame_position_sigma_m(k).unwrap_or(0.0))
            .into_iter()
            .fold(0.0, f64::max);
        let baseline = (0..3)
            .map(|a| (pa.centre[a] - pb.centre[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        let shift_m = GUIDE_SIGMAS * std::f64::consts::SQRT_2 * position_m
            + GUIDE_SIGMAS * terrain_sigma_m(self.opts.dem.is_some()) * baseline / height;
        Some(f * turn.tan() * (1.0 + (corner / f).powi(2)) + f * shift_m / height)
    }
}
