//! The adjustment's model: a tie point's pixel in a frame for the blocks' values, the robust
//! (Huber) cost with the priors and the terrain, and the residual statistics.

use super::blocks::{CameraBlock, CameraParam, FrameBlock, FrameParam, Layout, State};
use super::{AdjustFrame, AdjustOptions, Observation, TiePoint};
use aerorect_core::{Camera, Mat3, Vec3};
use nalgebra::{Rotation3, SVector};

/// The rotation `world_from_camera` of frame `frame` for these blocks:
/// `Rot(w) * R0 * Rot(b)`.
pub(super) fn world_from_camera(frame: &AdjustFrame, fb: &FrameBlock, cb: &CameraBlock) -> Mat3 {
    Rotation3::new(fb.rotation).into_inner()
        * frame.world_from_camera
        * Rotation3::new(cb.boresight).into_inner()
}

/// The lens's observed normalised point of the ideal `n` with the radial terms added.
pub(super) fn distorted(camera: &Camera, cb: &CameraBlock, n: [f64; 2]) -> Option<[f64; 2]> {
    let q = match &camera.distortion {
        None => n,
        Some(m) => m.model().observed_from_ideal(n)?,
    };
    let r2 = n[0] * n[0] + n[1] * n[1];
    let radial = cb.radial[0] * r2 + cb.radial[1] * r2 * r2;
    Some([q[0] + n[0] * radial, q[1] + n[1] * radial])
}

/// The pixel of `x` in `frame` for these blocks (`None` behind the camera or beyond the lens).
pub(super) fn project(
    frame: &AdjustFrame,
    camera: &Camera,
    fb: &FrameBlock,
    cb: &CameraBlock,
    x: &Vec3,
) -> Option<[f64; 2]> {
    let r = world_from_camera(frame, fb, cb);
    let d = r.transpose() * (x - Vec3::from(frame.centre) - fb.position);
    if d.z >= 0.0 {
        return None;
    }
    let q = distorted(camera, cb, [d.x / -d.z, d.y / d.z])?;
    Some(pixel_of(camera, cb, q))
}

/// The pixel of the observed normalised point `q`.
pub(super) fn pixel_of(camera: &Camera, cb: &CameraBlock, q: [f64; 2]) -> [f64; 2] {
    let k = &camera.intrinsics;
    let s = 1.0 + cb.focal_scale;
    [
        s * (k.fx * q[0] + k.skew * q[1]) + k.cx + cb.principal_point[0],
        s * k.fy * q[1] + k.cy + cb.principal_point[1],
    ]
}

/// Whether the adjustment can add radial terms to this camera's lens.
pub fn radial_refinable(camera: &Camera) -> bool {
    match &camera.distortion {
        None => true,
        Some(aerorect_core::distortion::Distortion::OpenCv(o)) => {
            o.k4 == 0.0 && o.k5 == 0.0 && o.k6 == 0.0
        }
        Some(_) => false,
    }
}

/// The problem: data that does not change while solving.
pub(super) struct Problem<'a> {
    pub frames: &'a [AdjustFrame],
    pub cameras: &'a [Camera],
    pub ties: &'a [TiePoint],
    pub layout: Layout,
    pub opts: &'a AdjustOptions<'a>,
    /// The Huber threshold of this stage (sigma units): [`AdjustOptions::huber`] at the end,
    /// wider while the frames are far from the ties (see `adjust`).
    pub huber: f64,
}

impl Problem<'_> {
    /// An observation's residual (pixels over sigma).
    pub fn residual(&self, s: &State, o: &Observation, x: &Vec3) -> Option<SVector<f64, 2>> {
        let fr = &self.frames[o.frame];
        let p = project(
            fr,
            &self.cameras[fr.camera],
            &s.frames[o.frame],
            &s.cameras[fr.camera],
            x,
        )?;
        Some(SVector::<f64, 2>::new(p[0] - o.pixel[0], p[1] - o.pixel[1]) / self.opts.pixel_sigma)
    }

    /// Huber weight of a residual (already in sigma units), times the matcher's weight.
    pub fn weight(&self, r: &SVector<f64, 2>, o: &Observation) -> f64 {
        let n = r.norm();
        let k = self.huber;
        o.weight * if n <= k { 1.0 } else { k / n }
    }

    /// Robust cost of the whole problem (priors included); `None` if a point leaves a view.
    pub fn cost(&self, s: &State) -> Option<f64> {
        let mut c = self.prior_cost(s);
        for (tie, x) in self.ties.iter().zip(&s.points) {
            for o in &tie.observations {
                let r = self.residual(s, o, x)?;
                let (n, k) = (r.norm(), self.huber);
                c += o.weight * if n <= k { n * n } else { 2.0 * k * n - k * k };
            }
            if let Some((h, sigma)) = self.opts.terrain {
                c += ((x.z - h(x.x, x.y)) / sigma).powi(2);
            }
        }
        Some(c)
    }

    /// Whether camera `c`'s parameter `p` is solved for.
    pub fn camera_free(opts: &AdjustOptions<'_>, camera: &Camera, p: CameraParam) -> bool {
        match p {
            CameraParam::FocalScale => opts.refine_focal,
            CameraParam::PrincipalPoint(_) => opts.refine_principal_point,
            CameraParam::Radial(_) => opts.refine_radial && radial_refinable(camera),
            CameraParam::Boresight(_) => opts.refine_boresight,
        }
    }

    /// A frame parameter's prior standard deviation (radians, metres).
    pub fn frame_sigma(&self, f: usize, p: FrameParam) -> f64 {
        match p {
            FrameParam::Rotation(_) => self.frames[f]
                .attitude_sigma_deg
                .unwrap_or(self.opts.attitude_sigma_deg)
                .to_radians(),
            FrameParam::Position(k) => self.frames[f]
                .position_sigma_m
                .map_or(self.opts.position_sigma_m.unwrap_or(1.0), |s| s[k]),
        }
    }

    /// A camera parameter's weak prior (focal length 5 %, principal point 100 px, radial 0.5,
    /// boresight 10 degrees): it only matters where the ties cannot tell.
    pub fn camera_sigma(p: CameraParam) -> f64 {
        match p {
            CameraParam::FocalScale => 0.05,
            CameraParam::PrincipalPoint(_) => 100.0,
            CameraParam::Radial(_) => 0.5,
            CameraParam::Boresight(_) => 10f64.to_radians(),
        }
    }

    /// Each free parameter's prior: (index, value, sigma).
    pub fn priors<'s>(&'s self, s: &'s State) -> impl Iterator<Item = (usize, f64, f64)> + 's {
        self.layout.free().map(move |(i, p)| {
            let sigma = match p {
                super::blocks::Param::Frame(f, q) => self.frame_sigma(f, q),
                super::blocks::Param::Camera(_, q) => Self::camera_sigma(q),
            };
            (i, p.value(s), sigma)
        })
    }

    fn prior_cost(&self, s: &State) -> f64 {
        self.priors(s).map(|(_, v, sig)| (v / sig).powi(2)).sum()
    }

    /// Root mean square of the observations' pixel residuals per frame (with the count and
    /// the outliers), and overall.
    pub fn rms(&self, s: &State) -> (Vec<(f64, usize, usize)>, f64) {
        let mut per = vec![(0.0, 0usize, 0usize); self.frames.len()];
        for (tie, x) in self.ties.iter().zip(&s.points) {
            for o in &tie.observations {
                if let Some(r) = self.residual(s, o, x) {
                    let e = (r * self.opts.pixel_sigma).norm_squared();
                    per[o.frame].0 += e;
                    per[o.frame].1 += 1;
                    per[o.frame].2 += usize::from(r.norm() > self.opts.huber);
                }
            }
        }
        let (sum, count) = per.iter().fold((0.0, 0), |a, f| (a.0 + f.0, a.1 + f.1));
        let per = per
            .into_iter()
            .map(|(s, n, out)| ((s / n.max(1) as f64).sqrt(), n, out))
            .collect();
        (per, (sum / count.max(1) as f64).sqrt())
    }
}
