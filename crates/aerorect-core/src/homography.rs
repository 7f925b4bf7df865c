//! Plane projective transforms with a meaningful sign of w.
//!
//! Convention: a homography built by this crate keeps the third homogeneous component w > 0 for
//! points in front of the camera (on the ground). `map` returns `None` where w <= 0: such a point
//! is at or beyond the horizon (or behind the camera) and has no image.

use crate::error::GeometryError;
use crate::{Mat3, Vec3};

/// A homography `b_from_a` with its inverse, both kept so that neither direction is recomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Homography {
    matrix: Mat3,
    inverse: Mat3,
}

impl Homography {
    /// Wraps a matrix; refuses a singular or non-finite one.
    pub fn new(matrix: Mat3) -> Result<Self, GeometryError> {
        if matrix.iter().any(|x| !x.is_finite()) {
            return Err(GeometryError::Singular);
        }
        let inverse = matrix.try_inverse().ok_or(GeometryError::Singular)?;
        if inverse.iter().any(|x| !x.is_finite()) {
            return Err(GeometryError::Singular);
        }
        Ok(Self { matrix, inverse })
    }

    /// A matrix and its inverse computed in closed form by the caller.
    pub(crate) fn from_pair(matrix: Mat3, inverse: Mat3) -> Self {
        Self { matrix, inverse }
    }

    pub fn identity() -> Self {
        Self {
            matrix: Mat3::identity(),
            inverse: Mat3::identity(),
        }
    }

    /// A translation by (tx, ty).
    pub fn translation(tx: f64, ty: f64) -> Self {
        let m = Mat3::new(1.0, 0.0, tx, 0.0, 1.0, ty, 0.0, 0.0, 1.0);
        let i = Mat3::new(1.0, 0.0, -tx, 0.0, 1.0, -ty, 0.0, 0.0, 1.0);
        Self {
            matrix: m,
            inverse: i,
        }
    }

    pub fn matrix(&self) -> &Mat3 {
        &self.matrix
    }

    /// The inverse transform `a_from_b`.
    pub fn inverse(&self) -> Self {
        Self {
            matrix: self.inverse,
            inverse: self.matrix,
        }
    }

    /// `self` after `first`: (c_from_b) * (b_from_a) = c_from_a. Composition reads right to left.
    pub fn after(&self, first: &Homography) -> Self {
        Self {
            matrix: self.matrix * first.matrix,
            inverse: first.inverse * self.inverse,
        }
    }

    /// The homogeneous image of (x, y, 1), not divided.
    pub fn map_homogeneous(&self, x: f64, y: f64) -> Vec3 {
        self.matrix * Vec3::new(x, y, 1.0)
    }

    /// Maps a point; `None` where w <= 0 (at or beyond the horizon) or the result is not finite.
    pub fn map(&self, x: f64, y: f64) -> Option<[f64; 2]> {
        let p = self.map_homogeneous(x, y);
        if p.z > 0.0 {
            let r = [p.x / p.z, p.y / p.z];
            (r[0].is_finite() && r[1].is_finite()).then_some(r)
        } else {
            None
        }
    }

    /// The matrix in row-major order, for reports.
    pub fn row_major(&self) -> [[f64; 3]; 3] {
        let m = &self.matrix;
        [
            [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
            [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
            [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn composition_reads_right_to_left() {
        let t = Homography::translation(3.0, -2.0);
        let s =
            Homography::new(Mat3::new(2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 1.0)).expect("ok");
        // scale after translate: (1,1) -> (4,-1) -> (8,-2)
        let p = s.after(&t).map(1.0, 1.0).expect("finite");
        assert_relative_eq!(p[0], 8.0);
        assert_relative_eq!(p[1], -2.0);
        let q = s.after(&t).inverse().map(8.0, -2.0).expect("finite");
        assert_relative_eq!(q[0], 1.0);
        assert_relative_eq!(q[1], 1.0);
    }

    #[test]
    fn non_positive_w_has_no_image() {
        let h =
            Homography::new(Mat3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, -5.0)).expect("ok");
        assert!(h.map(0.0, 5.0).is_none());
        assert!(h.map(0.0, 4.0).is_none());
        assert!(h.map(0.0, 6.0).is_some());
    }

    #[test]
    fn singular_is_refused() {
        assert_eq!(Homography::new(Mat3::zeros()), Err(GeometryError::Singular));
    }
}
