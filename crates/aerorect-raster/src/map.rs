//! Destination pixel -> source pixel maps for the warp engine.

use aerorect_core::{Homography, Mat3, PiecewiseAffine, PlaneTransform, Polynomial};

/// Where each destination pixel comes from in the source image (pixel-centre coordinates).
pub trait PixelMap: Sync {
    /// The source position of destination pixel (col, row); `None` where it has none.
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]>;

    /// Fills the source positions of destination row `row`, columns `col0..col0 + xs.len()`.
    /// A pixel without a source gets NaN. Implementations override this for speed.
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let p = self
                .source_of((col0 + i) as f64, row as f64)
                .unwrap_or([f64::NAN; 2]);
            (*x, *y) = (p[0], p[1]);
        }
    }

    /// The map's matrix when it is a homography (source = M (col, row, 1), divided by w, and no
    /// source where w <= 0), which lets the warp evaluate it in fast relative coordinates.
    fn projective(&self) -> Option<Mat3> {
        None
    }
}

/// A homography used as `source_from_destination`; w <= 0 has no source (beyond the horizon).
impl PixelMap for Homography {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        self.map(col, row)
    }

    fn projective(&self) -> Option<Mat3> {
        Some(*self.matrix())
    }

    #[inline]
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        let m = self.matrix();
        let r = row as f64;
        let (bx, by, bw) = (
            m[(0, 1)] * r + m[(0, 2)],
            m[(1, 1)] * r + m[(1, 2)],
            m[(2, 1)] * r + m[(2, 2)],
        );
        let (ax, ay, aw) = (m[(0, 0)], m[(1, 0)], m[(2, 0)]);
        // Columns fit i32 (output widths are far below 2^31); i32 -> f64 vectorises, usize does not.
        let c0 = col0 as i32;
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let c = (c0 + i as i32) as f64;
            let w = aw * c + bw;
            let inv = if w > 0.0 { 1.0 / w } else { f64::NAN };
            *x = (ax * c + bx) * inv;
            *y = (ay * c + by) * inv;
        }
    }
}

/// A polynomial `source_from_destination`: each row is a cubic in the normalised column.
impl PixelMap for Polynomial {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        Some(self.map(col, row))
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        let [cu, cv] = self.along_row(row as f64);
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let [p, _] = self.normalise((col0 + i) as f64, row as f64);
            *x = ((cu[3] * p + cu[2]) * p + cu[1]) * p + cu[0];
            *y = ((cv[3] * p + cv[2]) * p + cv[1]) * p + cv[0];
        }
    }
}

impl PixelMap for PiecewiseAffine {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        self.map(col, row)
    }
}

impl PixelMap for PlaneTransform {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        self.map(col, row)
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        match self {
            PlaneTransform::Polynomial(p) => p.source_row(row, col0, xs, ys),
            PlaneTransform::Projective(h) => h.source_row(row, col0, xs, ys),
            PlaneTransform::Piecewise(p) => p.source_row(row, col0, xs, ys),
        }
    }

    fn projective(&self) -> Option<Mat3> {
        match self {
            PlaneTransform::Projective(h) => h.projective(),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aerorect_core::Mat3;

    #[test]
    fn fast_row_equals_point_map() {
        let h = Homography::new(Mat3::new(0.9, 0.1, 5.0, -0.05, 1.1, -3.0, 1e-4, 2e-4, 1.0))
            .expect("ok");
        let mut xs = vec![0.0; 40];
        let mut ys = vec![0.0; 40];
        h.source_row(7, 3, &mut xs, &mut ys);
        for i in 0..40 {
            let p = h.map((3 + i) as f64, 7.0).expect("ground");
            assert!((xs[i] - p[0]).abs() < 1e-12 * p[0].abs().max(1.0));
            assert!((ys[i] - p[1]).abs() < 1e-12 * p[1].abs().max(1.0));
        }
    }

    #[test]
    fn polynomial_rows_equal_point_map() {
        let kind = aerorect_core::PolyKind::Cubic;
        let c: Vec<f64> = (0..10).map(|k| 1.0 + 0.3 * k as f64).collect();
        let d: Vec<f64> = (0..10).map(|k| -2.0 + 0.1 * (k * k) as f64).collect();
        let p = Polynomial::from_normalised(kind, [200.0, 100.0], 0.01, [c, d]).expect("ok");
        let t = PlaneTransform::Polynomial(p.clone());
        let (mut xs, mut ys) = (vec![0.0; 30], vec![0.0; 30]);
        t.source_row(9, 5, &mut xs, &mut ys);
        for i in 0..30 {
            let q = p.map((5 + i) as f64, 9.0);
            assert!((xs[i] - q[0]).abs() < 1e-9 && (ys[i] - q[1]).abs() < 1e-9);
        }
    }

    #[test]
    fn beyond_the_horizon_is_nan() {
        let h =
            Homography::new(Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, -5.0)).expect("ok");
        let (mut xs, mut ys) = (vec![0.0; 2], vec![0.0; 2]);
        h.source_row(4, 0, &mut xs, &mut ys);
        assert!(xs[0].is_nan() && ys[1].is_nan());
        h.source_row(6, 0, &mut xs, &mut ys);
        assert!(xs[0].is_finite());
    }
}

/// Which way a [`LensMap`] goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LensDirection {
    /// Destination pixels are ideal (undistorted), sources are observed.
    ObservedFromIdeal,
    /// Destination pixels are observed, sources are ideal.
    IdealFromObserved,
}

/// Pixel -> pixel through a lens model: the destination pixel is normalised with `from`, moved
/// through `model` in `direction`, and put back into pixels with `to`. No source outside the
/// model's valid domain (computed once, in [`LensMap::new`]) or where its inverse does not
/// converge.
#[derive(Debug, Clone)]
pub struct LensMap {
    pub from: aerorect_core::Intrinsics,
    pub to: aerorect_core::Intrinsics,
    pub model: aerorect_core::distortion::Distortion,
    pub direction: LensDirection,
    domain: aerorect_core::distortion::ValidDomain,
}

impl LensMap {
    /// The map, with the model's valid domain.
    pub fn new(
        from: aerorect_core::Intrinsics,
        to: aerorect_core::Intrinsics,
        model: aerorect_core::distortion::Distortion,
        direction: LensDirection,
    ) -> Self {
        let domain = model.valid_domain();
        Self {
            from,
            to,
            model,
            direction,
            domain,
        }
    }

    /// A map within one camera (the same intrinsics on both sides).
    pub fn within(
        k: aerorect_core::Intrinsics,
        model: aerorect_core::distortion::Distortion,
        direction: LensDirection,
    ) -> Self {
        Self::new(k, k, model, direction)
    }

    /// The lens of `camera`, within it; `None` for an ideal pinhole.
    pub fn of_camera(camera: &aerorect_core::Camera, direction: LensDirection) -> Option<Self> {
        // The camera's cached domain, not a second search.
        Some(Self {
            from: camera.intrinsics,
            to: camera.intrinsics,
            model: camera.distortion.clone()?,
            direction,
            domain: camera.lens_domain()?,
        })
    }

    /// One point through a concrete model (statically dispatched in row loops).
    #[inline(always)]
    fn through<M: aerorect_core::distortion::DistortionModel>(
        &self,
        m: &M,
        col: f64,
        row: f64,
    ) -> Option<[f64; 2]> {
        let n = self.from.normalized_from_pixel(col, row);
        let d = &self.domain;
        let q = match self.direction {
            LensDirection::ObservedFromIdeal => m.observed_from_ideal_within(d, n)?,
            LensDirection::IdealFromObserved => m.ideal_from_observed_within(d, n)?,
        };
        Some(self.to.pixel_from_normalized(q[0], q[1]))
    }

    fn row_with<M: aerorect_core::distortion::DistortionModel>(
        &self,
        m: &M,
        row: usize,
        col0: usize,
        xs: &mut [f64],
        ys: &mut [f64],
    ) {
        // Along a row the normalised y is constant and x linear in the column: no division.
        let [x0, ny] = self.from.normalized_from_pixel(col0 as f64, row as f64);
        let step = 1.0 / self.from.fx;
        for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
            let n = [x0 + i as f64 * step, ny];
            let d = &self.domain;
            let q = match self.direction {
                LensDirection::ObservedFromIdeal => m.observed_from_ideal_within(d, n),
                LensDirection::IdealFromObserved => m.ideal_from_observed_within(d, n),
            };
            let p = q.map_or([f64::NAN; 2], |q| self.to.pixel_from_normalized(q[0], q[1]));
            (*x, *y) = (p[0], p[1]);
        }
    }
}

impl PixelMap for LensMap {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        use aerorect_core::distortion::Distortion as D;
        match &self.model {
            D::Tsai(m) => self.through(m, col, row),
            D::Brown(m) => self.through(m, col, row),
            D::Improved(m) => self.through(m, col, row),
            D::OpenCv(m) => self.through(m, col, row),
        }
    }

    /// The model is matched once per row; the loop is monomorphised.
    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        use aerorect_core::distortion::Distortion as D;
        match &self.model {
            D::Tsai(m) => self.row_with(m, row, col0, xs, ys),
            D::Brown(m) => self.row_with(m, row, col0, xs, ys),
            D::Improved(m) => self.row_with(m, row, col0, xs, ys),
            D::OpenCv(m) => self.row_with(m, row, col0, xs, ys),
        }
    }
}

/// `first`, then `second`: destination -> first's source -> second's source.
#[derive(Debug, Clone)]
pub struct Then<A, B>(pub A, pub B);

impl<A: PixelMap, B: PixelMap> PixelMap for Then<A, B> {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        let p = self.0.source_of(col, row)?;
        self.1.source_of(p[0], p[1])
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        self.0.source_row(row, col0, xs, ys);
        for (x, y) in xs.iter_mut().zip(ys.iter_mut()) {
            let p = if x.is_finite() && y.is_finite() {
                self.1.source_of(*x, *y)
            } else {
                None
            };
            (*x, *y) = p.map_or((f64::NAN, f64::NAN), |p| (p[0], p[1]));
        }
    }
}

#[cfg(test)]
mod lens_tests {
    use super::*;
    use aerorect_core::Intrinsics;
    use aerorect_core::distortion::Distortion;

    #[test]
    fn lens_map_round_trips_and_then_composes() {
        let k = Intrinsics::new(500.0, 500.0, 200.0, 150.0).expect("valid");
        let mut d = Distortion::zero("improved").expect("known");
        d.model_mut()
            .set_params(&[-0.2, 0.05, 1e-3, -1e-3, 0.0, 0.0]);
        let fwd = LensMap::within(k, d.clone(), LensDirection::ObservedFromIdeal);
        let back = LensMap::within(k, d, LensDirection::IdealFromObserved);
        let p = fwd.source_of(30.0, 250.0).expect("converges");
        let q = back.source_of(p[0], p[1]).expect("closed form");
        assert!((q[0] - 30.0).abs() < 1e-8 && (q[1] - 250.0).abs() < 1e-8);
        let both = Then(fwd, back);
        let (mut xs, mut ys) = (vec![0.0; 4], vec![0.0; 4]);
        both.source_row(40, 10, &mut xs, &mut ys);
        for i in 0..4 {
            assert!((xs[i] - (10 + i) as f64).abs() < 1e-8 && (ys[i] - 40.0).abs() < 1e-8);
        }
    }
}
