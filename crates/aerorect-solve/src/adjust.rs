//! Joint adjustment of a flight: small attitude corrections per frame (and optionally position
//! corrections), focal length and principal point per camera, from tie points seen in several
//! frames, with priors on the recorded attitude and position and a robust (Huber) loss.
//!
//! Tie points' ground positions are unknowns too; with a terrain they are held near it by a
//! height observation. They are eliminated block by block (Schur complement), and the reduced
//! system over frames and cameras, sparse because frames only meet their neighbours, is solved
//! with faer's sparse Cholesky: it scales to thousands of frames.
//!
//! Frame model: `world_from_camera = Rot(w) * R0 * Rot(b)` (w a rotation vector in world
//! axes, b the camera's boresight rotation in its own axes), `centre = C0 + dc`; camera: fx,
//! fy scaled by (1 + s), principal point moved by (du, dv), and radial terms dk1, dk2 added to
//! the lens's own (`q + n (dk1 r^2 + dk2 r^4)` for ideal normalised `n`, `r = |n|`: exactly
//! OpenCV's k1, k2 moved by dk1, dk2 when the lens has no rational terms).
//! Camera frame as in `aerorect_core::camera` (x right, y up, z back).

use crate::SolveError;
use aerorect_core::{Camera, Mat3, Vec3};
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector};
use serde::Serialize;
use std::collections::BTreeMap;

/// One frame's recorded exterior orientation and its camera.
#[derive(Debug, Clone)]
pub struct AdjustFrame {
    pub camera: usize,
    pub centre: [f64; 3],
    pub world_from_camera: Mat3,
    /// This frame's position prior (m, per world axis) when positions are adjusted, e.g. the
    /// receiver's own RTK standard deviations; `None` takes [`AdjustOptions::position_sigma_m`].
    pub position_sigma_m: Option<[f64; 3]>,
}

/// A tie point's observation in one frame (observed pixel, with the matcher's confidence as a
/// relative weight in (0, 1]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub frame: usize,
    pub pixel: [f64; 2],
    pub weight: f64,
}

/// A point seen in two or more frames, with a first guess of its ground position.
#[derive(Debug, Clone, PartialEq)]
pub struct TiePoint {
    pub ground: [f64; 3],
    pub observations: Vec<Observation>,
}

/// The terrain's height at (x, y) of the world frame.
pub type HeightFn<'a> = &'a (dyn Fn(f64, f64) -> f64 + Sync);

/// What is solved for, and how strongly the records hold.
#[derive(Clone)]
pub struct AdjustOptions<'a> {
    /// Standard deviation of the recorded attitude (each axis), degrees.
    pub attitude_sigma_deg: f64,
    /// Position corrections with this prior standard deviation (metres) where a frame gives
    /// none of its own; `None` keeps positions.
    pub position_sigma_m: Option<f64>,
    pub refine_focal: bool,
    pub refine_principal_point: bool,
    /// Radial distortion k1, k2 per camera (only for a camera with no lens model or OpenCV's
    /// without rational terms; others keep their lens as it is).
    pub refine_radial: bool,
    /// A boresight rotation per camera (the attitude priors hold each frame's own correction
    /// near zero, so what all frames of a camera share goes here).
    pub refine_boresight: bool,
    /// Standard deviation of a tie point's image position, pixels.
    pub pixel_sigma: f64,
    /// Huber threshold, in units of `pixel_sigma`.
    pub huber: f64,
    /// Terrain height at (x, y) and its standard deviation (m): tie points stay on the ground.
    pub terrain: Option<(HeightFn<'a>, f64)>,
    pub max_iterations: usize,
}

impl Default for AdjustOptions<'_> {
    fn default() -> Self {
        Self {
            attitude_sigma_deg: 1.0,
            position_sigma_m: None,
            refine_focal: true,
            refine_principal_point: true,
            refine_radial: false,
            refine_boresight: false,
            pixel_sigma: 0.5,
            huber: 3.0,
            terrain: None,
            max_iterations: 50,
        }
    }
}

/// The corrections and statistics of one frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameAdjustment {
    /// The rotation correction (world axes), degrees, and its standard deviation.
    pub rotation_deg: [f64; 3],
    pub rotation_sigma_deg: [f64; 3],
    pub position_m: [f64; 3],
    pub position_sigma_m: [f64; 3],
    pub observations: usize,
    pub rms_before_px: f64,
    pub rms_after_px: f64,
    /// Observations the robust loss down-weighted (residual above the Huber threshold).
    pub outliers: usize,
}

/// The corrections of one camera.
#[derive(Debug, Clone, Serialize)]
pub struct CameraAdjustment {
    pub focal_scale: f64,
    pub focal_scale_sigma: f64,
    pub principal_point_shift_px: [f64; 2],
    pub principal_point_sigma_px: [f64; 2],
    /// What was added to the lens's k1, k2.
    pub radial_k1_k2: [f64; 2],
    pub radial_sigma: [f64; 2],
    /// The boresight rotation (camera axes), degrees.
    pub boresight_deg: [f64; 3],
    pub boresight_sigma_deg: [f64; 3],
}

/// The result of an adjustment.
#[derive(Debug, Clone, Serialize)]
pub struct AdjustReport {
    pub frames: Vec<FrameAdjustment>,
    pub cameras: Vec<CameraAdjustment>,
    pub tie_points: usize,
    pub observations: usize,
    pub iterations: usize,
    pub converged: bool,
    pub rms_before_px: f64,
    pub rms_after_px: f64,
    pub seconds: f64,
}

/// The adjusted orientation of every frame and camera.
#[derive(Debug, Clone)]
pub struct Adjusted {
    pub frames: Vec<AdjustFrame>,
    pub cameras: Vec<Camera>,
    pub report: AdjustReport,
}

/// Number of parameters per frame and per camera for these options.
#[derive(Debug, Clone, Copy)]
struct Layout {
    frame: usize,
    camera: usize,
    frames: usize,
}

impl Layout {
    fn frame_at(&self, f: usize) -> usize {
        f * self.frame
    }
    fn camera_at(&self, c: usize) -> usize {
        self.frames * self.frame + c * self.camera
    }
}

/// The current state: parameters of frames and cameras, ground points.
#[derive(Debug, Clone)]
struct State {
    params: Vec<f64>,
    points: Vec<Vec3>,
}

/// Parameters per camera: focal scale, principal point shift (2), dk1, dk2, boresight (3).
const CAMERA_PARAMS: usize = 8;

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

/// The pixel of `x` in frame `f` for the parameter values `frame_p` (rotation vector, position
/// offset) and `cam_p` (focal scale, principal point shift, dk1, dk2, boresight).
fn project(
    frame: &AdjustFrame,
    camera: &Camera,
    frame_p: &[f64],
    cam_p: &[f64],
    x: &Vec3,
) -> Option<[f64; 2]> {
    let w = Vec3::new(frame_p[0], frame_p[1], frame_p[2]);
    let b = Vec3::new(cam_p[5], cam_p[6], cam_p[7]);
    let r =
        Rotation3::new(w).into_inner() * frame.world_from_camera * Rotation3::new(b).into_inner();
    let c = Vec3::from(frame.centre)
        + frame_p
            .get(3..6)
            .map_or(Vec3::zeros(), |d| Vec3::new(d[0], d[1], d[2]));
    let d = r.transpose() * (x - c);
    if d.z >= 0.0 {
        return None;
    }
    let n = [d.x / -d.z, d.y / d.z];
    let q = match &camera.distortion {
        None => n,
        Some(m) => m.model().observed_from_ideal(n)?,
    };
    let r2 = n[0] * n[0] + n[1] * n[1];
    let radial = cam_p[3] * r2 + cam_p[4] * r2 * r2;
    let q = [q[0] + n[0] * radial, q[1] + n[1] * radial];
    let k = &camera.intrinsics;
    let s = 1.0 + cam_p.first().copied().unwrap_or(0.0);
    let (du, dv) = (
        cam_p.get(1).copied().unwrap_or(0.0),
        cam_p.get(2).copied().unwrap_or(0.0),
    );
    Some([
        s * (k.fx * q[0] + k.skew * q[1]) + k.cx + du,
        s * k.fy * q[1] + k.cy + dv,
    ])
}

/// The problem: data that does not change while solving.
struct Problem<'a> {
    frames: &'a [AdjustFrame],
    cameras: &'a [Camera],
    ties: &'a [TiePoint],
    layout: Layout,
    opts: &'a AdjustOptions<'a>,
}

/// One observation's residual (pixels, already divided by sigma) and Jacobians with respect
/// to the frame block, the camera block and the point.
struct Linearised {
    r: SVector<f64, 2>,
    j_frame: SMatrix<f64, 2, 6>,
    j_cam: SMatrix<f64, 2, CAMERA_PARAMS>,
    j_point: SMatrix<f64, 2, 3>,
}

impl Problem<'_> {
    /// The frame's and its camera's parameter slices in `s`.
    fn blocks<'s>(&self, s: &'s State, frame: usize) -> (&'s [f64], &'s [f64]) {
        let l = &self.layout;
        let c = self.frames[frame].camera;
        (
            &s.params[l.frame_at(frame)..l.frame_at(frame) + l.frame],
            &s.params[l.camera_at(c)..l.camera_at(c) + l.camera],
        )
    }

    fn residual_with(
        &self,
        fp: &[f64],
        cp: &[f64],
        o: &Observation,
        x: &Vec3,
    ) -> Option<SVector<f64, 2>> {
        let fr = &self.frames[o.frame];
        let p = project(fr, &self.cameras[fr.camera], fp, cp, x)?;
        Some(SVector::<f64, 2>::new(p[0] - o.pixel[0], p[1] - o.pixel[1]) / self.opts.pixel_sigma)
    }

    fn residual(&self, s: &State, o: &Observation, x: &Vec3) -> Option<SVector<f64, 2>> {
        let (fp, cp) = self.blocks(s, o.frame);
        self.residual_with(fp, cp, o, x)
    }

    /// Central differences (the model is smooth and cheap; steps suit radians, metres, pixels).
    fn linearise(&self, s: &State, o: &Observation, x: &Vec3) -> Option<Linearised> {
        let (fp0, cp0) = self.blocks(s, o.frame);
        let (mut fp, mut cp) = (fp0.to_vec(), cp0.to_vec());
        let mut lin = Linearised {
            r: self.residual_with(&fp, &cp, o, x)?,
            j_frame: SMatrix::zeros(),
            j_cam: SMatrix::zeros(),
            j_point: SMatrix::zeros(),
        };
        for k in 0..fp.len() {
            let h = if k >= 3 { 1e-3 } else { 1e-6 };
            fp[k] = fp0[k] + h;
            let plus = self.residual_with(&fp, &cp, o, x)?;
            fp[k] = fp0[k] - h;
            let minus = self.residual_with(&fp, &cp, o, x)?;
            fp[k] = fp0[k];
            lin.j_frame.set_column(k, &((plus - minus) / (2.0 * h)));
        }
        let camera = self.frames[o.frame].camera;
        for k in (0..cp.len()).filter(|&k| self.camera_free(camera, k)) {
            let h = 1e-6;
            cp[k] = cp0[k] + h;
            let plus = self.residual_with(&fp, &cp, o, x)?;
            cp[k] = cp0[k] - h;
            let minus = self.residual_with(&fp, &cp, o, x)?;
            cp[k] = cp0[k];
            lin.j_cam.set_column(k, &((plus - minus) / (2.0 * h)));
        }
        for k in 0..3 {
            let (mut xp, mut xm) = (*x, *x);
            xp[k] += 1e-3;
            xm[k] -= 1e-3;
            let col = (self.residual_with(&fp, &cp, o, &xp)?
                - self.residual_with(&fp, &cp, o, &xm)?)
                / 2e-3;
            lin.j_point.set_column(k, &col);
        }
        Some(lin)
    }

    /// Huber weight of a residual (already in sigma units), times the matcher's weight.
    fn weight(&self, r: &SVector<f64, 2>, o: &Observation) -> f64 {
        let n = r.norm();
        let k = self.opts.huber;
        o.weight * if n <= k { 1.0 } else { k / n }
    }

    /// Robust cost of the whole problem (priors included); `None` if a point leaves a view.
    fn cost(&self, s: &State) -> Option<f64> {
        let mut c = self.prior_cost(s);
        for (tie, x) in self.ties.iter().zip(&s.points) {
            for o in &tie.observations {
                let r = self.residual(s, o, x)?;
                let (n, k) = (r.norm(), self.opts.huber);
                c += o.weight * if n <= k { n * n } else { 2.0 * k * n - k * k };
            }
            if let Some((h, sigma)) = self.opts.terrain {
                c += ((x.z - h(x.x, x.y)) / sigma).powi(2);
            }
        }
        Some(c)
    }

    /// Whether camera `c`'s parameter `k` is solved for (else it is pinned at zero).
    fn camera_free(&self, c: usize, k: usize) -> bool {
        match k {
            0 => self.opts.refine_focal,
            1 | 2 => self.opts.refine_principal_point,
            3 | 4 => self.opts.refine_radial && radial_refinable(&self.cameras[c]),
            _ => self.opts.refine_boresight,
        }
    }

    /// Frame `f`'s prior standard deviations, one per frame parameter.
    fn prior_sigmas(&self, f: usize) -> Vec<f64> {
        let mut s = Vec::with_capacity(self.layout.frame);
        s.extend([self.opts.attitude_sigma_deg.to_radians(); 3]);
        if let Some(p) = self.opts.position_sigma_m {
            s.extend(self.frames[f].position_sigma_m.unwrap_or([p; 3]));
        }
        s
    }

    fn prior_cost(&self, s: &State) -> f64 {
        (0..self.layout.frames)
            .flat_map(|f| {
                let at = self.layout.frame_at(f);
                self.prior_sigmas(f)
                    .into_iter()
                    .enumerate()
                    .map(move |(k, sig)| (s.params[at + k] / sig).powi(2))
            })
            .sum()
    }
}

/// Indices (in the reduced system) of an observation's frame and camera parameters.
fn indices(p: &Problem<'_>, o: &Observation) -> Vec<usize> {
    let l = &p.layout;
    let c = p.frames[o.frame].camera;
    (l.frame_at(o.frame)..l.frame_at(o.frame) + l.frame)
        .chain(l.camera_at(c)..l.camera_at(c) + l.camera)
        .collect()
}

/// The reduced normal equations (points eliminated) and what back-substitution needs.
struct Reduced {
    entries: BTreeMap<(usize, usize), f64>,
    rhs: Vec<f64>,
    /// Per tie point: H_pp^-1 (damped), b_p and the (index, H_pc row block) list.
    points: Vec<Option<PointBlock>>,
}

/// One observation's reduced-parameter indices, Jacobian, residual and weight.
struct LocalObservation {
    idx: Vec<usize>,
    jc: SMatrix<f64, 2, { 6 + CAMERA_PARAMS }>,
    r: SVector<f64, 2>,
    w: f64,
}

struct PointBlock {
    hpp_inv: Matrix3<f64>,
    bp: Vec3,
    hpc: Vec<(usize, Vec3)>,
}

fn jac_row(lin: &Linearised, l: &Layout) -> SMatrix<f64, 2, { 6 + CAMERA_PARAMS }> {
    let mut j = SMatrix::<f64, 2, { 6 + CAMERA_PARAMS }>::zeros();
    for k in 0..l.frame {
        j.set_column(k, &lin.j_frame.column(k));
    }
    for k in 0..l.camera {
        j.set_column(l.frame + k, &lin.j_cam.column(k));
    }
    j
}

fn reduce(p: &Problem<'_>, s: &State, lambda: f64) -> Option<Reduced> {
    let n = p.layout.frames * p.layout.frame + p.cameras.len() * p.layout.camera;
    let mut red = Reduced {
        entries: BTreeMap::new(),
        rhs: vec![0.0; n],
        points: Vec::with_capacity(p.ties.len()),
    };
    for (tie, x) in p.ties.iter().zip(&s.points) {
        let mut hpp = Matrix3::<f64>::zeros();
        let mut bp = Vec3::zeros();
        let mut hpc: BTreeMap<usize, Vec3> = BTreeMap::new();
        let mut local: Vec<LocalObservation> = Vec::new();
        for o in &tie.observations {
            let lin = p.linearise(s, o, x)?;
            let w = p.weight(&lin.r, o);
            let idx = indices(p, o);
            let jc = jac_row(&lin, &p.layout);
            hpp += w * lin.j_point.transpose() * lin.j_point;
            bp -= w * lin.j_point.transpose() * lin.r;
            let cross = w * jc.transpose() * lin.j_point; // 9 x 3
            for (a, &i) in idx.iter().enumerate() {
                *hpc.entry(i).or_insert_with(Vec3::zeros) += cross.row(a).transpose();
            }
            local.push(LocalObservation {
                idx,
                jc,
                r: lin.r,
                w,
            });
        }
        if let Some((h, sigma)) = p.opts.terrain {
            // d/dx of (z - h(x, y)) / sigma.
            let e = 1e-2;
            let gx = (h(x.x + e, x.y) - h(x.x - e, x.y)) / (2.0 * e);
            let gy = (h(x.x, x.y + e) - h(x.x, x.y - e)) / (2.0 * e);
            let j = Vec3::new(-gx, -gy, 1.0) / sigma;
            let r = (x.z - h(x.x, x.y)) / sigma;
            hpp += j * j.transpose();
            bp -= j * r;
        }
        for k in 0..3 {
            hpp[(k, k)] += lambda * hpp[(k, k)].max(1e-9);
        }
        // Camera-camera blocks and the right-hand side.
        for LocalObservation { idx, jc, r, w } in &local {
            let hcc = *w * jc.transpose() * jc;
            let bc = -*w * jc.transpose() * r;
            for (a, &i) in idx.iter().enumerate() {
                red.rhs[i] += bc[a];
                for (b, &j) in idx.iter().enumerate() {
                    *red.entries.entry((i, j)).or_insert(0.0) += hcc[(a, b)];
                }
            }
        }
        let Some(hpp_inv) = hpp.try_inverse() else {
            red.points.push(None);
            continue;
        };
        let hpc: Vec<(usize, Vec3)> = hpc.into_iter().collect();
        // S -= H_cp H_pp^-1 H_pc ; rhs -= H_cp H_pp^-1 b_p.
        let t: Vec<(usize, Vec3)> = hpc.iter().map(|(i, v)| (*i, hpp_inv * v)).collect();
        for (i, vi) in &hpc {
            red.rhs[*i] -= vi.dot(&(hpp_inv * bp));
            for (j, tj) in &t {
                *red.entries.entry((*i, *j)).or_insert(0.0) -= vi.dot(tj);
            }
        }
        red.points.push(Some(PointBlock { hpp_inv, bp, hpc }));
    }
    add_priors(p, s, lambda, &mut red);
    Some(red)
}

fn add_priors(p: &Problem<'_>, s: &State, lambda: f64, red: &mut Reduced) {
    let l = &p.layout;
    for f in 0..l.frames {
        for (k, sk) in p.prior_sigmas(f).iter().enumerate() {
            let i = l.frame_at(f) + k;
            *red.entries.entry((i, i)).or_insert(0.0) += 1.0 / (sk * sk);
            red.rhs[i] -= s.params[i] / (sk * sk);
        }
    }
    // Cameras: fixed parameters are pinned; refined ones get a weak prior (focal length 5 %,
    // principal point 100 px) that only matters where the ties cannot tell.
    for c in 0..p.cameras.len() {
        for k in 0..l.camera {
            let i = l.camera_at(c) + k;
            let sigma: f64 = match k {
                0 => 0.05,
                1 | 2 => 100.0,
                3 | 4 => 0.5,
                _ => 10f64.to_radians(),
            };
            let fixed = !p.camera_free(c, k);
            let w = if fixed { 1e12 } else { 1.0 / (sigma * sigma) };
            *red.entries.entry((i, i)).or_insert(0.0) += w;
            red.rhs[i] -= w * s.params[i];
        }
    }
    let n = red.rhs.len();
    for i in 0..n {
        let d = red.entries.get(&(i, i)).copied().unwrap_or(0.0);
        *red.entries.entry((i, i)).or_insert(0.0) += lambda * d.max(1e-9);
    }
}

/// Factorises the reduced system; solves for the step of the frames and cameras.
fn factor(
    n: usize,
    entries: &BTreeMap<(usize, usize), f64>,
) -> Option<faer::sparse::linalg::solvers::Llt<usize, f64>> {
    let triplets: Vec<Triplet<usize, usize, f64>> = entries
        .iter()
        .filter(|((i, j), _)| i >= j)
        .map(|(&(i, j), &v)| Triplet::new(i, j, v))
        .collect();
    let m = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets).ok()?;
    m.sp_cholesky(faer::Side::Lower).ok()
}

fn solve_with(llt: &faer::sparse::linalg::solvers::Llt<usize, f64>, rhs: &[f64]) -> Vec<f64> {
    let b = faer::Mat::<f64>::from_fn(rhs.len(), 1, |i, _| rhs[i]);
    let x = llt.solve(&b);
    (0..rhs.len()).map(|i| x[(i, 0)]).collect()
}

/// One damped Gauss-Newton step from `s`; `None` when the system cannot be solved.
fn step(p: &Problem<'_>, s: &State, lambda: f64) -> Option<State> {
    let red = reduce(p, s, lambda)?;
    let n = red.rhs.len();
    let llt = factor(n, &red.entries)?;
    let dc = solve_with(&llt, &red.rhs);
    let mut next = s.clone();
    for (v, d) in next.params.iter_mut().zip(&dc) {
        *v += d;
    }
    for (x, block) in next.points.iter_mut().zip(&red.points) {
        if let Some(b) = block {
            let hd = b.hpc.iter().fold(Vec3::zeros(), |a, (i, v)| a + v * dc[*i]);
            *x += b.hpp_inv * (b.bp - hd);
        }
    }
    Some(next)
}

/// Root mean square of the observations' pixel residuals per frame, and overall.
fn rms(p: &Problem<'_>, s: &State) -> (Vec<(f64, usize, usize)>, f64) {
    let mut per = vec![(0.0, 0usize, 0usize); p.frames.len()];
    for (tie, x) in p.ties.iter().zip(&s.points) {
        for o in &tie.observations {
            if let Some(r) = p.residual(s, o, x) {
                let e = (r * p.opts.pixel_sigma).norm_squared();
                per[o.frame].0 += e;
                per[o.frame].1 += 1;
                per[o.frame].2 += (r.norm() > p.opts.huber) as usize;
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

/// Adjusts the frames and cameras to the tie points.
pub fn adjust(
    frames: &[AdjustFrame],
    cameras: &[Camera],
    ties: &[TiePoint],
    opts: &AdjustOptions<'_>,
) -> Result<Adjusted, SolveError> {
    let t0 = std::time::Instant::now();
    check_input(frames, cameras, ties)?;
    let layout = Layout {
        frame: if opts.position_sigma_m.is_some() {
            6
        } else {
            3
        },
        camera: CAMERA_PARAMS,
        frames: frames.len(),
    };
    let p = Problem {
        frames,
        cameras,
        ties,
        layout,
        opts,
    };
    let n = layout.frames * layout.frame + cameras.len() * layout.camera;
    let mut s = State {
        params: vec![0.0; n],
        points: ties.iter().map(|t| Vec3::from(t.ground)).collect(),
    };
    let before = rms(&p, &s);
    let mut cost = p.cost(&s).ok_or(SolveError::Degenerate)?;
    let (mut lambda, mut iterations, mut converged) = (1e-3, 0, false);
    while iterations < opts.max_iterations {
        iterations += 1;
        let Some(next) = step(&p, &s, lambda) else {
            lambda *= 10.0;
            continue;
        };
        match p.cost(&next) {
            Some(c) if c < cost => {
                let gain = (cost - c) / cost.max(1e-300);
                // The largest change of a frame or camera parameter (radians, metres, scale, px).
                let moved = s
                    .params
                    .iter()
                    .zip(&next.params)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                s = next;
                cost = c;
                lambda = (lambda / 3.0).max(1e-9);
                // 1e-5 of the cost is 5e-6 of the RMS: nothing left to gain; 1e-6 (0.2
                // arc-seconds, a micrometre, 1e-6 of the focal length) is nothing left to move.
                if gain < 1e-5 || moved < 1e-6 {
                    converged = true;
                    break;
                }
            }
            _ => {
                lambda *= 10.0;
                if lambda > 1e8 {
                    converged = true;
                    break;
                }
            }
        }
    }
    let after = rms(&p, &s);
    let sigmas = standard_deviations(&p, &s);
    Ok(finish(
        &p, &s, before, after, sigmas, iterations, converged, t0,
    ))
}

fn check_input(
    frames: &[AdjustFrame],
    cameras: &[Camera],
    ties: &[TiePoint],
) -> Result<(), SolveError> {
    if frames.iter().any(|f| f.camera >= cameras.len()) {
        return Err(SolveError::Degenerate);
    }
    for (index, t) in ties.iter().enumerate() {
        let bad = t.observations.len() < 2
            || t.observations.iter().any(|o| {
                o.frame >= frames.len()
                    || o.weight.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                    || !o.pixel.iter().all(|v| v.is_finite())
            })
            || !t.ground.iter().all(|v| v.is_finite());
        if bad {
            return Err(SolveError::NotFinite { index });
        }
    }
    Ok(())
}

/// Standard deviations of the frame and camera parameters: the diagonal of the reduced
/// system's inverse (Gauss-Newton, undamped), scaled by the a-posteriori variance factor.
fn standard_deviations(p: &Problem<'_>, s: &State) -> Vec<f64> {
    let Some(red) = reduce(p, s, 0.0) else {
        return vec![f64::NAN; s.params.len()];
    };
    let n = red.rhs.len();
    let Some(llt) = factor(n, &red.entries) else {
        return vec![f64::NAN; n];
    };
    let (_, rms_all) = rms(p, s);
    let scale = (rms_all / p.opts.pixel_sigma).max(1.0);
    // Columns of the identity, solved many at a time (the factor's blocked solve).
    let mut out = Vec::with_capacity(n);
    for start in (0..n).step_by(256) {
        let cols = 256.min(n - start);
        let b = faer::Mat::<f64>::from_fn(n, cols, |i, j| f64::from(u8::from(i == start + j)));
        let x = llt.solve(&b);
        out.extend((0..cols).map(|j| x[(start + j, j)].max(0.0).sqrt() * scale));
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn finish(
    p: &Problem<'_>,
    s: &State,
    before: (Vec<(f64, usize, usize)>, f64),
    after: (Vec<(f64, usize, usize)>, f64),
    sig: Vec<f64>,
    iterations: usize,
    converged: bool,
    t0: std::time::Instant,
) -> Adjusted {
    let l = p.layout;
    let mut frames = Vec::with_capacity(l.frames);
    let mut reports = Vec::with_capacity(l.frames);
    for (f, fr) in p.frames.iter().enumerate() {
        let v = &s.params[l.frame_at(f)..l.frame_at(f) + l.frame];
        let sd = &sig[l.frame_at(f)..l.frame_at(f) + l.frame];
        let w = Vec3::new(v[0], v[1], v[2]);
        let dc = v.get(3..6).map_or([0.0; 3], |d| [d[0], d[1], d[2]]);
        let b = &s.params[l.camera_at(fr.camera) + 5..l.camera_at(fr.camera) + 8];
        let boresight = Rotation3::new(Vec3::new(b[0], b[1], b[2])).into_inner();
        frames.push(AdjustFrame {
            camera: fr.camera,
            centre: [
                fr.centre[0] + dc[0],
                fr.centre[1] + dc[1],
                fr.centre[2] + dc[2],
            ],
            world_from_camera: Rotation3::new(w).into_inner() * fr.world_from_camera * boresight,
            position_sigma_m: fr.position_sigma_m,
        });
        reports.push(FrameAdjustment {
            rotation_deg: [v[0].to_degrees(), v[1].to_degrees(), v[2].to_degrees()],
            rotation_sigma_deg: [sd[0].to_degrees(), sd[1].to_degrees(), sd[2].to_degrees()],
            position_m: dc,
            position_sigma_m: sd.get(3..6).map_or([0.0; 3], |d| [d[0], d[1], d[2]]),
            observations: after.0[f].1,
            rms_before_px: before.0[f].0,
            rms_after_px: after.0[f].0,
            outliers: after.0[f].2,
        });
    }
    let mut cameras = Vec::with_capacity(p.cameras.len());
    let mut cam_reports = Vec::with_capacity(p.cameras.len());
    for (c, cam) in p.cameras.iter().enumerate() {
        let v = &s.params[l.camera_at(c)..l.camera_at(c) + CAMERA_PARAMS];
        let sd = &sig[l.camera_at(c)..l.camera_at(c) + CAMERA_PARAMS];
        let mut out = cam.clone();
        if v[3] != 0.0 || v[4] != 0.0 {
            let mut lens = match &cam.distortion {
                Some(aerorect_core::distortion::Distortion::OpenCv(o)) => *o,
                _ => aerorect_core::distortion::OpenCv::default(),
            };
            (lens.k1, lens.k2) = (lens.k1 + v[3], lens.k2 + v[4]);
            out.distortion = Some(aerorect_core::distortion::Distortion::OpenCv(lens));
        }
        let k = &mut out.intrinsics;
        (k.fx, k.fy, k.skew) = (
            k.fx * (1.0 + v[0]),
            k.fy * (1.0 + v[0]),
            k.skew * (1.0 + v[0]),
        );
        (k.cx, k.cy) = (k.cx + v[1], k.cy + v[2]);
        cameras.push(out);
        cam_reports.push(CameraAdjustment {
            focal_scale: 1.0 + v[0],
            focal_scale_sigma: sd[0],
            principal_point_shift_px: [v[1], v[2]],
            principal_point_sigma_px: [sd[1], sd[2]],
            radial_k1_k2: [v[3], v[4]],
            radial_sigma: [sd[3], sd[4]],
            boresight_deg: [v[5].to_degrees(), v[6].to_degrees(), v[7].to_degrees()],
            boresight_sigma_deg: [sd[5].to_degrees(), sd[6].to_degrees(), sd[7].to_degrees()],
        });
    }
    let report = AdjustReport {
        frames: reports,
        cameras: cam_reports,
        tie_points: p.ties.len(),
        observations: p.ties.iter().map(|t| t.observations.len()).sum(),
        iterations,
        converged,
        rms_before_px: before.1,
        rms_after_px: after.1,
        seconds: t0.elapsed().as_secs_f64(),
    };
    Adjusted {
        frames,
        cameras,
        report,
    }
}
