//! The adjustment's model: a tie point's pixel in a frame for the blocks' values, the robust
//! (Huber) cost with the priors and the terrain, and the residual statistics.

use super::blocks::{
    CameraBlock, CameraParam, DatumBlock, DatumParam, FrameBlock, FrameParam, Layout, Param, State,
};
use super::jacobian::Posed;
use super::{AdjustFrame, AdjustOptions, Observation, TiePoint};
use aerorect_core::{Camera, Mat3, Vec3};
use nalgebra::{Rotation3, SVector};
use rayon::prelude::*;

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

/// The pixel of `x` in `frame` for these blocks (`None` behind the camera or beyond the lens):
/// the numeric oracle's entry (the library poses each frame once, [`Posed`]).
#[cfg(test)]
pub(super) fn project(
    frame: &AdjustFrame,
    camera: &Camera,
    fb: &FrameBlock,
    cb: &CameraBlock,
    x: &Vec3,
) -> Option<[f64; 2]> {
    Posed::new(frame, camera, fb, cb).project(x)
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
    /// The recorded centres' centroid: the datum rotates and scales about it.
    pub centroid: Vec3,
}

/// One prior as a linear row: its residual `value` with standard deviation `sigma`, its
/// derivative by each free parameter it involves (reduced-system index, derivative), its
/// robust weight and its share of the cost ((value / sigma)^2, or Huber's for a position
/// prior taken robustly).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PriorRow {
    pub value: f64,
    pub sigma: f64,
    pub terms: Vec<(usize, f64)>,
    pub weight: f64,
    pub cost: f64,
}

/// The datum's weak priors: a shift of [`AdjustOptions::datum_shift_sigma_m`], a degree, one
/// percent of scale, [`GPS_DRIFT_SIGMA_M`] of drift. Ground control (or for the drift, the
/// images) decides it; the priors keep a datum control cannot see from drifting (and without
/// control, the shift's prior holds the block where its GPS is).
pub(super) fn datum_sigma(opts: &AdjustOptions<'_>, p: DatumParam) -> f64 {
    match p {
        DatumParam::Shift(k) => opts.datum_shift_sigma_m[k],
        DatumParam::Rotation(_) => 1f64.to_radians(),
        DatumParam::Scale => 0.01,
        DatumParam::Drift(_) => GPS_DRIFT_SIGMA_M,
    }
}

/// The GPS drift's prior (m over the flight, each axis): weak, so that the images decide it
/// (a flight solves a drift only where its frames' times are not a line through their
/// positions, which would trade the drift for the block's scale and tilt).
pub(super) const GPS_DRIFT_SIGMA_M: f64 = 1000.0;

/// The position offset the datum gives a frame recorded `d` from the centroid at time `t`
/// ([`AdjustOptions::gps_drift_times`]): `shift + rotation x d + scale d + drift t`.
pub(super) fn datum_offset(datum: &DatumBlock, d: &Vec3, t: f64) -> Vec3 {
    datum.shift + datum.rotation.cross(d) + d * datum.scale + datum.drift * t
}

impl Problem<'_> {
    /// Every frame's pose at `s` (index by frame).
    pub fn posed(&self, s: &State) -> Vec<Posed<'_>> {
        self.frames
            .iter()
            .zip(&s.frames)
            .map(|(fr, fb)| {
                let c = fr.camera;
                Posed::new(fr, &self.cameras[c], fb, &s.cameras[c])
            })
            .collect()
    }

    /// An observation's residual (pixels over sigma), the frames posed by [`Self::posed`].
    pub fn residual(
        &self,
        posed: &[Posed<'_>],
        o: &Observation,
        x: &Vec3,
    ) -> Option<SVector<f64, 2>> {
        let p = posed[o.frame].project(x)?;
        Some(SVector::<f64, 2>::new(p[0] - o.pixel[0], p[1] - o.pixel[1]) / self.opts.pixel_sigma)
    }

    /// Huber weight of a residual (already in sigma units), times the matcher's weight.
    pub fn weight(&self, r: &SVector<f64, 2>, o: &Observation) -> f64 {
        let n = r.norm();
        let k = self.huber;
        o.weight * if n <= k { 1.0 } else { k / n }
    }

    /// Robust cost of the whole problem (priors included); `None` if a point leaves a view.
    /// Each tie point's terms are summed in its own order, in parallel, and the points' sums
    /// are added in tie order: the same sum whatever the number of threads.
    pub fn cost(&self, s: &State) -> Option<f64> {
        let posed = self.posed(s);
        let mut c: f64 = self.prior_rows(s).iter().map(|row| row.cost).sum();
        let chunk = 4096;
        for (ties, xs) in self.ties.chunks(chunk).zip(s.points.chunks(chunk)) {
            let terms: Vec<Option<f64>> = ties
                .par_iter()
                .zip(xs)
                .map(|(tie, x)| self.tie_cost(&posed, tie, x))
                .collect();
            for t in terms {
                c += t?;
            }
        }
        Some(c)
    }

    /// A tie point's share of the cost: each observation's term, then its prior's, summed
    /// in that order.
    pub(super) fn tie_cost(&self, posed: &[Posed<'_>], tie: &TiePoint, x: &Vec3) -> Option<f64> {
        let mut sum = 0.0;
        for o in &tie.observations {
            let r = self.residual(posed, o, x)?;
            let (n, k) = (r.norm(), self.huber);
            sum += o.weight * if n <= k { n * n } else { 2.0 * k * n - k * k };
        }
        Some(sum + self.point_prior(tie, x).norm_squared())
    }

    /// A tie point's whitened ground residual: against its surveyed position for ground
    /// control, else its height against the terrain (zero where there is none).
    pub fn point_prior(&self, tie: &TiePoint, x: &Vec3) -> Vec3 {
        if let Some(c) = &tie.control {
            return Vec3::from_fn(|k, _| (x[k] - c.ground[k]) / c.sigma_m[k]);
        }
        match self.opts.terrain {
            Some((h, _)) => Vec3::new(0.0, 0.0, (x.z - h(x.x, x.y)) / self.terrain_sigma(tie)),
            None => Vec3::zeros(),
        }
    }

    /// The standard deviation (m) tie point `tie` is held to the terrain with: its first
    /// observation's frame's ([`AdjustOptions::terrain_sigma_by_frame`]), else the terrain's.
    pub fn terrain_sigma(&self, tie: &TiePoint) -> f64 {
        let own = self.opts.terrain_sigma_by_frame.and_then(|by_frame| {
            let f = tie.observations.first()?.frame;
            by_frame.get(f).copied()
        });
        own.or(self.opts.terrain.map(|(_, sigma)| sigma))
            .unwrap_or(f64::INFINITY)
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
            FrameParam::Position(k) => {
                self.frames[f].position_sigma_or(self.opts.position_sigma_m.unwrap_or(1.0))[k]
            }
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

    /// Whether the datum is solved (then the position priors are relative to it).
    fn datum_free(&self) -> bool {
        self.layout.datum(DatumParam::Shift(0)).is_some()
    }

    /// Every free parameter's prior as a whitened row: each parameter held near zero, except
    /// a frame's position correction, which with a datum is held near the datum's offset for
    /// that frame.
    pub fn prior_rows(&self, s: &State) -> Vec<PriorRow> {
        let datum = self.datum_free() || self.opts.position_huber.is_some();
        self.layout
            .free()
            .map(|(i, p)| match p {
                Param::Frame(f, FrameParam::Position(k)) if datum => self.position_row(s, f, k, i),
                Param::Frame(f, q) => Self::row(i, p.value(s), self.frame_sigma(f, q)),
                Param::Camera(_, q) => Self::row(i, p.value(s), Self::camera_sigma(q)),
                Param::Datum(q) => Self::row(i, p.value(s), datum_sigma(self.opts, q)),
            })
            .collect()
    }

    fn row(i: usize, v: f64, sigma: f64) -> PriorRow {
        PriorRow {
            value: v,
            sigma,
            terms: vec![(i, 1.0)],
            weight: 1.0,
            cost: (v / sigma).powi(2),
        }
    }

    /// Frame `f`'s time for the GPS drift (0 without one).
    fn drift_time(&self, f: usize) -> f64 {
        self.opts.gps_drift_times.map_or(0.0, |t| t[f])
    }

    /// Where the datum at `s` moves frame `f`'s recorded position.
    pub fn datum_offset(&self, s: &State, f: usize) -> Vec3 {
        let d = Vec3::from(self.frames[f].centre) - self.centroid;
        datum_offset(&s.datum, &d, self.drift_time(f))
    }

    /// Frame `f`'s whitened position residual against the datum's offset (all three axes).
    pub fn position_residual(&self, s: &State, f: usize) -> Vec3 {
        let offset = self.datum_offset(s, f);
        Vec3::from_fn(|k, _| {
            (s.frames[f].position[k] - offset[k]) / self.frame_sigma(f, FrameParam::Position(k))
        })
    }

    /// The robust weight of frame `f`'s position prior (1 unless
    /// [`AdjustOptions::position_huber`] down-weights a fix the images contradict) and the
    /// prior's whole cost.
    pub fn position_weight(&self, s: &State, f: usize) -> (f64, f64) {
        let n = self.position_residual(s, f).norm();
        match self.opts.position_huber {
            Some(k) if n > k => (k / n, 2.0 * k * n - k * k),
            _ => (1.0, n * n),
        }
    }

    /// Frame `f`'s position prior on axis `k` (index `i`) against the datum's offset.
    fn position_row(&self, s: &State, f: usize, k: usize, i: usize) -> PriorRow {
        let sigma = self.frame_sigma(f, FrameParam::Position(k));
        let d = Vec3::from(self.frames[f].centre) - self.centroid;
        let t = self.drift_time(f);
        let offset = datum_offset(&s.datum, &d, t);
        let mut terms = vec![(i, 1.0)];
        // d offset_k / d shift_k = 1; d (w x d)_k / d w_j = -[d]x_kj; d offset_k / d scale = d_k;
        // d offset_k / d drift_k = t.
        let cross = d.cross_matrix();
        let mut add = |q: DatumParam, v: f64| {
            if let Some(j) = self.layout.datum(q) {
                terms.push((j, -v));
            }
        };
        add(DatumParam::Shift(k), 1.0);
        for j in 0..3 {
            add(DatumParam::Rotation(j), -cross[(k, j)]);
        }
        add(DatumParam::Scale, d[k]);
        add(DatumParam::Drift(k), t);
        let value = s.frames[f].position[k] - offset[k];
        let r = value / sigma;
        // The frame's Huber cost shared among its axes by their squares.
        let (weight, whole) = self.position_weight(s, f);
        let n2 = self.position_residual(s, f).norm_squared();
        PriorRow {
            value,
            sigma,
            terms,
            weight,
            cost: if n2 > 0.0 { whole * r * r / n2 } else { 0.0 },
        }
    }

    /// Root mean square of the observations' pixel residuals per frame (with the count and
    /// the outliers), and overall.
    pub fn rms(&self, s: &State) -> (Vec<(f64, usize, usize)>, f64) {
        let posed = self.posed(s);
        let mut per = vec![(0.0, 0usize, 0usize); self.frames.len()];
        // The residuals in parallel, a run of ties at a time; their sums in the observations'
        // order.
        let (chunk, run) = (65536, 1024);
        for (ties, xs) in self.ties.chunks(chunk).zip(s.points.chunks(chunk)) {
            let terms: Vec<Vec<(usize, f64, bool)>> = ties
                .par_chunks(run)
                .zip(xs.par_chunks(run))
                .map(|(ties, xs)| {
                    let mut terms = Vec::with_capacity(2 * ties.len());
                    for (tie, x) in ties.iter().zip(xs) {
                        for o in &tie.observations {
                            if let Some(r) = self.residual(&posed, o, x) {
                                let e = (r * self.opts.pixel_sigma).norm_squared();
                                terms.push((o.frame, e, r.norm() > self.opts.huber));
                            }
                        }
                    }
                    terms
                })
                .collect();
            for (frame, e, out) in terms.into_iter().flatten() {
                per[frame].0 += e;
                per[frame].1 += 1;
                per[frame].2 += usize::from(out);
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
