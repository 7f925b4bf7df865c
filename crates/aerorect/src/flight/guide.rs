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

/// A window covers at least this fraction of `b`'s frame (about 120 of a thousand keypoints),
/// however well the priors place it, and a match is accepted only within the priors' own
/// radius ([`Guide::accept`]). The ratio test weighs a keypoint's best candidate against its
/// second best among the window's, and among a dozen a wrong best often passes; near the
/// window's centre it also lies near the epipolar line, so RANSAC keeps it. On the
/// 1,000-frame fixed-wing simulation's second step (windows of 26 px, 1.2 % of a
/// 480 x 360 frame), against matching in full (round 1's tie RMS 0.11 px, attitude error
/// 0.026 / 0.128 degrees, median / max): the priors' radius alone 0.39 px and 0.054 / 0.266;
/// a twentieth 0.29 px and 0.036 / 0.316; this fraction 0.22 px and 0.029 / 0.309; this
/// fraction with matches accepted within the priors' radius 0.17 px and 0.027 / 0.129. The
/// nadir simulation's windows (1 degree, 9 %) grow to it: 0.0057 / 0.0193 -> 0.0057 / 0.0195.
pub const MIN_GUIDE_FRACTION: f64 = 0.12;

/// A guided pair that does not tie is matched again in full when at least this fraction of
/// `a`'s keypoints were predicted inside `b`: the prediction said they overlap.
pub const GUIDE_RETRY_OVERLAP: f64 = 0.2;

/// Where `a`'s keypoints should lie in `b` (reduced pixels of `b`), and how far from it their
/// matches may be.
#[derive(Debug, Clone)]
pub(super) struct Guide {
    pub(super) query_at: Vec<Option<[f64; 2]>>,
    /// The window's radius: at least [`MIN_GUIDE_FRACTION`] of `b`.
    pub(super) radius: f64,
    /// How far from its predicted position a match may lie: the priors' own radius.
    pub(super) accept: f64,
    /// The fraction of `a`'s keypoints predicted inside `b`.
    pub(super) inside: f64,
}

impl FlightPlan {
    /// Each keypoint of frame `k` (`features`' positions, reduced by their factor) on the
    /// ground by the recorded orientation; none where its ray misses the ground.
    pub(super) fn keypoints_on_ground(&self, k: usize, f: &FrameFeatures) -> Vec<Option<[f64; 3]>> {
        self.step_ground(Basis::Recorded, k, f)
    }

    /// The window that guides matching frame `i`'s keypoints (`a`, on the ground by `basis`)
    /// with frame `j`'s (`b`); none when the priors leave it too wide
    /// ([`MAX_GUIDE_FRACTION`]) or `a` has no ground positions.
    pub(super) fn guide(
        &self,
        basis: Basis<'_>,
        (i, a): (usize, &FrameFeatures),
        (j, b): (usize, &FrameFeatures),
    ) -> Option<Guide> {
        if a.ground.len() != a.features.len() || a.features.is_empty() {
            return None;
        }
        let (radius, accept) = self.window_radius(basis, (i, j), (b.size, b.factor))?;
        let (w, h) = reduced_size(b.size, b.factor);
        let (pose, camera) = self.basis_view(basis, j);
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
            accept,
        })
    }

    /// The radii of pair (`i`, `j`)'s window in frame `j`'s reduced pixels (`j` decoded at
    /// `size`, reduced by `factor`): the window's, at least [`MIN_GUIDE_FRACTION`] of the
    /// frame, and the priors' own, within which a match is accepted; none when the priors in
    /// `basis` leave it wider than [`MAX_GUIDE_FRACTION`].
    pub(super) fn window_radius(
        &self,
        basis: Basis<'_>,
        (i, j): (usize, usize),
        (size, factor): (ImageSize, usize),
    ) -> Option<(f64, f64)> {
        let accept = self.guide_radius(basis, i, j)? / factor as f64 + GUIDE_SLACK_PX;
        let (w, h) = reduced_size(size, factor);
        let area = |fraction: f64| fraction * w * h / std::f64::consts::PI;
        (accept * accept <= area(MAX_GUIDE_FRACTION))
            .then(|| (accept.max(area(MIN_GUIDE_FRACTION).sqrt()), accept))
    }

    /// The radius of pair (`i`, `j`)'s window in frame `j`'s full-resolution pixels (see the
    /// module); none when a prior is too wide to bound it.
    fn guide_radius(&self, basis: Basis<'_>, i: usize, j: usize) -> Option<f64> {
        let [(att_i, pos_i), (att_j, pos_j)] = [i, j].map(|k| self.basis_sigmas(basis, k));
        let turn = (GUIDE_SIGMAS * std::f64::consts::SQRT_2 * att_i.max(att_j)).to_radians();
        if turn >= 1.0 {
            return None;
        }
        let ((pa, _), (pb, camera)) = (self.basis_view(basis, i), self.basis_view(basis, j));
        let f = camera.intrinsics.fx.max(camera.intrinsics.fy);
        let corner = 0.5 * (camera.size.width as f64).hypot(camera.size.height as f64);
        let height = pb.centre[2] - (self.ground)(pb.centre[0], pb.centre[1]);
        if height.is_nan() || height <= 0.0 {
            return None;
        }
        let baseline = (0..3)
            .map(|a| (pa.centre[a] - pb.centre[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        let shift_m = GUIDE_SIGMAS * std::f64::consts::SQRT_2 * pos_i.max(pos_j)
            + GUIDE_SIGMAS * self.basis_terrain_sigma_m(basis, i, j) * baseline / height;
        Some(f * turn.tan() * (1.0 + (corner / f).powi(2)) + f * shift_m / height)
    }
}

/// A frame of `size` reduced by `factor`: its width and height in reduced pixels.
fn reduced_size(size: ImageSize, factor: usize) -> (f64, f64) {
    (
        size.width as f64 / factor as f64,
        size.height as f64 / factor as f64,
    )
}
