//! Ground points through an adjusted orientation: where a surveyed point falls in a frame, and
//! where a point marked in frames lies (intersection of the rays, by Gauss-Newton on the
//! reprojection error), for check points and ground control reports.

use super::blocks::{CameraBlock, FrameBlock};
use super::jacobian::Posed;
use super::{AdjustFrame, Adjusted, Observation};
use aerorect_core::{Camera, Vec3};
use nalgebra::{Matrix3, Vector2};

/// Frames and their cameras, oriented (recorded or adjusted).
#[derive(Debug, Clone, Copy)]
pub struct OrientedFrames<'a> {
    pub frames: &'a [AdjustFrame],
    pub cameras: &'a [Camera],
}

impl Adjusted {
    /// The adjusted frames.
    pub fn oriented(&self) -> OrientedFrames<'_> {
        OrientedFrames {
            frames: &self.frames,
            cameras: &self.cameras,
        }
    }
}

impl<'a> OrientedFrames<'a> {
    /// The pixel of ground point `x` in frame `f` (`None` behind the camera or beyond the
    /// lens's domain).
    pub fn pixel_of(&self, f: usize, x: [f64; 3]) -> Option<[f64; 2]> {
        self.posed_frame(f)?.project(&Vec3::from(x))
    }

    /// The point the observations' rays meet best (least squares in pixels, weighted),
    /// starting from `start`; `None` with fewer than two observations, rays that do not meet
    /// (parallel: the normal matrix is singular), or a point that leaves a view.
    pub fn intersect(&self, observations: &[Observation], start: [f64; 3]) -> Option<[f64; 3]> {
        let posed: Vec<Posed<'_>> = (observations.iter())
            .map(|o| self.posed_frame(o.frame))
            .collect::<Option<_>>()?;
        intersect_posed(observations, |k| posed.get(k), start)
    }

    /// Every frame posed once, for many points ([`PosedFrames`]).
    pub fn posed(&self) -> PosedFrames<'a> {
        PosedFrames {
            frames: (0..self.frames.len())
                .map(|f| self.posed_frame(f))
                .collect(),
        }
    }

    /// Frame `f` as it is oriented (no corrections); `None` for a frame or camera that is not
    /// there.
    fn posed_frame(&self, f: usize) -> Option<Posed<'a>> {
        let fr = self.frames.get(f)?;
        let cam = self.cameras.get(fr.camera)?;
        Some(Posed::new(
            fr,
            cam,
            &FrameBlock::default(),
            &CameraBlock::default(),
        ))
    }

    /// The midpoint of the common perpendicular of two observations' rays: where they meet,
    /// or pass closest; a start for [`Self::intersect`] one or two steps from its end (from
    /// a guess metres off, the 1,000-frame fixed wing's tie surface spent 3.7 s intersecting
    /// its 1.6 M tie points). `None` for rays within about a millionth of a radian of
    /// parallel, or a frame that is not there.
    pub fn rays_meet(&self, a: &Observation, b: &Observation) -> Option<[f64; 3]> {
        let ray = |o: &Observation| {
            let (c, d) = self.world_ray(o.frame, o.pixel)?;
            Some((c, d.normalize()))
        };
        let ((ca, da), (cb, db)) = (ray(a)?, ray(b)?);
        // Closest points ca + s da and cb + u db: (ca - cb + s da - u db) is normal to both.
        let w = ca - cb;
        let (k, d, e) = (da.dot(&db), da.dot(&w), db.dot(&w));
        let denom = 1.0 - k * k;
        if denom <= 1e-12 {
            return None;
        }
        let (s, u) = ((k * e - d) / denom, (e - k * d) / denom);
        let x = (ca + da * s + cb + db * u) / 2.0;
        x.iter().all(|v| v.is_finite()).then(|| x.into())
    }

    /// Where the ray of `pixel` in frame `f` meets the level `z` (`None` when it does not
    /// descend to it).
    pub fn ray_at_height(&self, f: usize, pixel: [f64; 2], z: f64) -> Option<[f64; 3]> {
        let (centre, ray) = self.world_ray(f, pixel)?;
        let t = (z - centre.z) / ray.z;
        (t.is_finite() && t > 0.0).then(|| (centre + ray * t).into())
    }

    /// Frame `f`'s centre and the world direction (not normalised) of its ray through
    /// `pixel`; `None` for a frame that is not there or a pixel beyond the lens's domain.
    fn world_ray(&self, f: usize, pixel: [f64; 2]) -> Option<(Vec3, Vec3)> {
        let fr = self.frames.get(f)?;
        let cam = self.cameras.get(fr.camera)?;
        let d = fr.world_from_camera * cam.ray_from_pixel(pixel[0], pixel[1])?;
        Some((Vec3::from(fr.centre), d))
    }
}

/// [`OrientedFrames`] with every frame's rotations and their Jacobians composed once: the
/// points of a whole flight's ties (the 1,000-frame fixed wing's 1.6 M, each projected six
/// times in its intersection and its check) take them from here rather than composing them
/// again for each projection. The same numbers as [`OrientedFrames`]' own methods, bit for bit.
pub struct PosedFrames<'a> {
    frames: Vec<Option<Posed<'a>>>,
}

impl PosedFrames<'_> {
    /// [`OrientedFrames::pixel_of`].
    pub fn pixel_of(&self, f: usize, x: [f64; 3]) -> Option<[f64; 2]> {
        self.frames.get(f)?.as_ref()?.project(&Vec3::from(x))
    }

    /// [`OrientedFrames::intersect`].
    pub fn intersect(&self, observations: &[Observation], start: [f64; 3]) -> Option<[f64; 3]> {
        let posed = |k: usize| self.frames.get(observations.get(k)?.frame)?.as_ref();
        intersect_posed(observations, posed, start)
    }
}

/// Gauss-Newton on the reprojection error from `start`, observation `k` seen through the frame
/// `posed(k)` (`None`: a frame that is not there).
fn intersect_posed<'p>(
    observations: &[Observation],
    posed: impl Fn(usize) -> Option<&'p Posed<'p>>,
    start: [f64; 3],
) -> Option<[f64; 3]> {
    if observations.len() < 2 {
        return None;
    }
    let mut x = Vec3::from(start);
    for _ in 0..20 {
        let (mut h, mut b) = (Matrix3::<f64>::zeros(), Vec3::zeros());
        for (k, o) in observations.iter().enumerate() {
            let pj = posed(k)?.pixel_jacobian(&x)?;
            let r = Vector2::new(pj.pixel[0] - o.pixel[0], pj.pixel[1] - o.pixel[1]);
            h += o.weight * pj.point.transpose() * pj.point;
            b -= o.weight * pj.point.transpose() * r;
        }
        // Rays meeting at under about a degree leave the depth undetermined.
        if undetermined(&h) {
            return None;
        }
        let dx = h.try_inverse()? * b;
        x += dx;
        if dx.norm() < 1e-6 {
            break;
        }
    }
    x.iter().all(|v| v.is_finite()).then(|| x.into())
}

/// Whether the smallest eigenvalue of the normal matrix `h` of a point's rays (symmetric,
/// positive semi-definite) is at most a millionth of its largest: the rays meet at too narrow
/// an angle to fix the depth. With eigenvalues l1 >= l2 >= l3 >= 0, det = l1 l2 l3 and the
/// trace is at least l1 and l2, so l3 / l1 = det / (l1^2 l2) >= det / trace^3: a bound above
/// twice the threshold settles it without the eigenvalues (an iterative decomposition that
/// cost the 1,000-frame fixed wing's tie surface several seconds over its 1.6 M points), and
/// only the rest, rays within some degrees of parallel, are decomposed. The margin of two
/// covers the rounding of both computations, so the answer is the decomposition's.
fn undetermined(h: &Matrix3<f64>) -> bool {
    let trace = h.trace();
    if h.determinant() > 2e-6 * trace * trace * trace {
        return false;
    }
    let eig = h.symmetric_eigenvalues();
    eig.min() <= 1e-6 * eig.max()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The decomposition's own verdict, as `intersect` took it before the bound.
    fn by_eigenvalues(h: &Matrix3<f64>) -> bool {
        let eig = h.symmetric_eigenvalues();
        eig.min() <= 1e-6 * eig.max()
    }

    /// Normal matrices of two to four unit rays' pixel Jacobians (rows normal to each ray),
    /// from rays crossing at tens of degrees down to identical ones, and matrices built from
    /// eigenvalues placed around the threshold: the bound's verdict is the decomposition's.
    #[test]
    fn the_determinant_bound_decides_as_the_eigenvalues_do() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let mut decided = [0usize; 2];
        for k in 0..20_000 {
            let h = if k % 2 == 0 {
                let spread = 10f64.powf(rng.random_range(-7.0..0.0));
                let base = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    -2.0,
                );
                let mut h = Matrix3::zeros();
                for _ in 0..rng.random_range(2..=4) {
                    let tilt = Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        0.0,
                    );
                    let d = (base + tilt * spread).normalize();
                    let u = d.cross(&Vec3::z()).normalize();
                    let v = d.cross(&u);
                    let w = rng.random_range(0.1..10.0) * 1e4;
                    h += w * (u * u.transpose() + v * v.transpose());
                }
                h
            } else {
                let q = nalgebra::Rotation3::from_scaled_axis(Vec3::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-3.0..3.0),
                    rng.random_range(-3.0..3.0),
                ));
                let top = 10f64.powf(rng.random_range(-3.0..6.0));
                let ratio = 1e-6 * (1.0 + rng.random_range(-1e-3..1e-3)) * [1.0, 3.0, 30.0][k % 3];
                let l =
                    nalgebra::Vector3::new(top, top * rng.random_range(ratio..1.0), top * ratio);
                q.matrix() * Matrix3::from_diagonal(&l) * q.matrix().transpose()
            };
            let expect = by_eigenvalues(&h);
            assert_eq!(undetermined(&h), expect, "{h}");
            decided[usize::from(expect)] += 1;
        }
        // Both verdicts are well represented.
        assert!(decided.iter().all(|&n| n > 2000), "{decided:?}");
    }
}
