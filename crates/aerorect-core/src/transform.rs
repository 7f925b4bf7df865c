//! Plane transforms fitted to point pairs (ground control points, tie points): polynomials of
//! one of three orders and a piecewise-affine map over a triangulation. Both are `b_from_a`:
//! the fitting code in aerorect-solve decides which frame is `a`.
use crate::Homography;

mod piecewise;
mod polynomial;

pub use piecewise::PiecewiseAffine;
pub use polynomial::{PolyKind, Polynomial};

/// Any of the fitted plane transforms, `b_from_a`.
#[derive(Debug, Clone)]
pub enum PlaneTransform {
    Polynomial(Polynomial),
    Projective(Homography),
    Piecewise(PiecewiseAffine),
}

impl PlaneTransform {
    /// The image of (u, v); `None` beyond a homography's horizon.
    pub fn map(&self, u: f64, v: f64) -> Option<[f64; 2]> {
        match self {
            PlaneTransform::Polynomial(p) => Some(p.map(u, v)),
            PlaneTransform::Projective(h) => h.map(u, v),
            PlaneTransform::Piecewise(p) => p.map(u, v),
        }
    }

    /// The transform of (u + du, v + dv): the same map read from a grid whose origin is at
    /// (du, dv).
    pub fn after_translation(&self, du: f64, dv: f64) -> PlaneTransform {
        match self {
            PlaneTransform::Polynomial(p) => {
                let mut q = p.clone();
                q.centre = [p.centre[0] - du, p.centre[1] - dv];
                PlaneTransform::Polynomial(q)
            }
            PlaneTransform::Projective(h) => {
                PlaneTransform::Projective(h.after(&Homography::translation(du, dv)))
            }
            PlaneTransform::Piecewise(p) => PlaneTransform::Piecewise(p.after_translation(du, dv)),
        }
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::Mat3;

    fn sample_poly(kind: PolyKind) -> Polynomial {
        let n = kind.terms().len();
        let cx: Vec<f64> = (0..n).map(|k| 3.0 - 0.7 * k as f64).collect();
        let cy: Vec<f64> = (0..n).map(|k| -1.0 + 0.45 * (k * k) as f64).collect();
        Polynomial::from_normalised(kind, [512.0, 300.0], 1.0 / 400.0, [cx, cy]).expect("valid")
    }

    /// The raw (unnormalised) coefficients evaluate to the same values as the normalised form.
    #[test]
    fn raw_coefficients_equal_the_normalised_polynomial() {
        for kind in [PolyKind::Bilinear, PolyKind::Quadratic, PolyKind::Cubic] {
            let p = sample_poly(kind);
            let raw = p.raw_coefficients();
            for (u, v) in [(0.0, 0.0), (100.0, 700.0), (1023.0, 5.5), (-40.0, 250.0)] {
                let want = p.map(u, v);
                for (d, c) in raw.iter().enumerate() {
                    let got: f64 = kind
                        .terms()
                        .iter()
                        .zip(c)
                        .map(|(&(i, j), a)| a * u.powi(i) * v.powi(j))
                        .sum();
                    assert!(
                        (got - want[d]).abs() < 1e-9 * want[d].abs().max(1.0),
                        "{kind:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn along_row_matches_map() {
        let p = sample_poly(PolyKind::Cubic);
        let v = 77.25;
        let rows = p.along_row(v);
        for u in [0.0, 10.0, 999.0] {
            let [x, _] = p.normalise(u, v);
            let want = p.map(u, v);
            for d in 0..2 {
                let c = rows[d];
                let got = ((c[3] * x + c[2]) * x + c[1]) * x + c[0];
                assert!((got - want[d]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn term_names_follow_the_exponents() {
        assert_eq!(PolyKind::Bilinear.term_names(), ["1", "u", "v", "uv"]);
        assert_eq!(
            PolyKind::Cubic.term_names()[5..],
            ["v^2", "u^3", "u^2v", "uv^2", "v^3"]
        );
    }

    /// Affine pieces reproduce the vertices and are continuous across a shared edge.
    #[test]
    fn piecewise_is_exact_at_vertices_and_continuous() {
        let from = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let to = [[1.0, 2.0], [12.0, 1.0], [13.0, 14.0], [0.0, 11.0]];
        let pw = PiecewiseAffine::new(
            &from,
            &to,
            vec![[0, 1, 2], [0, 2, 3]],
            Homography::identity(),
        )
        .expect("valid");
        for (f, t) in from.iter().zip(&to) {
            let m = pw.map(f[0], f[1]).expect("inside");
            assert!((m[0] - t[0]).abs() < 1e-9 && (m[1] - t[1]).abs() < 1e-9);
        }
        // On the diagonal both pieces give the linear interpolation of its end points.
        let m = pw.map(4.0, 4.0).expect("inside");
        assert!(
            (m[0] - (1.0 + 0.4 * 12.0)).abs() < 1e-9 && (m[1] - (2.0 + 0.4 * 12.0)).abs() < 1e-9
        );
        // Outside: the homography (identity here).
        assert_eq!(pw.map(20.0, 5.0), Some([20.0, 5.0]));
    }

    #[test]
    fn after_translation_reads_the_same_map_from_a_shifted_grid() {
        let from = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let to = [[1.0, 2.0], [12.0, 1.0], [13.0, 14.0], [0.0, 11.0]];
        let h =
            Homography::new(Mat3::new(1.0, 0.1, 2.0, 0.0, 0.9, 1.0, 1e-3, 0.0, 1.0)).expect("h");
        let pw = PiecewiseAffine::new(&from, &to, vec![[0, 1, 2], [0, 2, 3]], h).expect("ok");
        let all = [
            PlaneTransform::Polynomial(sample_poly(PolyKind::Cubic)),
            PlaneTransform::Projective(h),
            PlaneTransform::Piecewise(pw),
        ];
        for t in &all {
            let s = t.after_translation(-3.0, 7.0);
            for (u, v) in [(5.0, 1.0), (9.0, -2.0), (30.0, 4.0), (2.5, 2.5)] {
                let (a, b) = (s.map(u, v).expect("a"), t.map(u - 3.0, v + 7.0).expect("b"));
                assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn degenerate_triangle_is_refused() {
        let from = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]];
        let r = PiecewiseAffine::new(&from, &from, vec![[0, 1, 2]], Homography::identity());
        assert!(r.is_err());
    }
}
