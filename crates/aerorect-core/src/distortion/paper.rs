//! The paper's models, ideal = observed + sum_j theta_j B_j(observed) (eq. 6, 7, 10 as fixed by
//! the spec: the radial correction is x_d (k1 r^2 + ...), without the printed "1 +").

use super::{ClosedForm, Direction, DistortionModel};
use serde::{Deserialize, Serialize};

/// A basis function at (x, y): its value (bx, by) and derivatives [[dbx/dx, dbx/dy], [dby/dx, dby/dy]].
type Basis = fn(f64, f64) -> ([f64; 2], [[f64; 2]; 2]);

fn radial(x: f64, y: f64, n: i32) -> ([f64; 2], [[f64; 2]; 2]) {
    // x r^(2n): d/dx = r^(2n) + 2n x^2 r^(2n-2), d/dy = 2n x y r^(2n-2)
    let r2 = x * x + y * y;
    let (rn, rn1) = (r2.powi(n), r2.powi(n - 1));
    let k = 2.0 * n as f64 * rn1;
    (
        [x * rn, y * rn],
        [[rn + k * x * x, k * x * y], [k * x * y, rn + k * y * y]],
    )
}

fn k1(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    radial(x, y, 1)
}
fn k2(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    radial(x, y, 2)
}
fn k3(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    radial(x, y, 3)
}
/// p1: (r^2 + 2x^2, 2xy)
fn p1(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    (
        [3.0 * x * x + y * y, 2.0 * x * y],
        [[6.0 * x, 2.0 * y], [2.0 * y, 2.0 * x]],
    )
}
/// p2: (2xy, r^2 + 2y^2)
fn p2(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    (
        [2.0 * x * y, x * x + 3.0 * y * y],
        [[2.0 * y, 2.0 * x], [2.0 * x, 6.0 * y]],
    )
}
fn dx0(_: f64, _: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([1.0, 0.0], [[0.0; 2]; 2])
}
fn dy0(_: f64, _: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, 1.0], [[0.0; 2]; 2])
}
fn a1(x: f64, _: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([x, 0.0], [[1.0, 0.0], [0.0; 2]])
}
fn a2(_: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([y, 0.0], [[0.0, 1.0], [0.0; 2]])
}
fn a5(_: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([y * y, 0.0], [[0.0, 2.0 * y], [0.0; 2]])
}
fn a6(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([x * x * y, 0.0], [[2.0 * x * y, x * x], [0.0; 2]])
}
fn a7(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([x * y * y, 0.0], [[y * y, 2.0 * x * y], [0.0; 2]])
}
fn b1(x: f64, _: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, x], [[0.0; 2], [1.0, 0.0]])
}
fn b2(_: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, y], [[0.0; 2], [0.0, 1.0]])
}
fn b5(_: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, y * y], [[0.0; 2], [0.0, 2.0 * y]])
}
fn b6(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, x * x * y], [[0.0; 2], [2.0 * x * y, x * x]])
}
fn b7(x: f64, y: f64) -> ([f64; 2], [[f64; 2]; 2]) {
    ([0.0, x * y * y], [[0.0; 2], [y * y, 2.0 * x * y]])
}

/// ideal = q + sum theta_j B_j(q) and its point Jacobian, without allocating.
fn linear_value(basis: &[Basis], theta: &[f64], q: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
    let mut value = q;
    let mut d_point = [[1.0, 0.0], [0.0, 1.0]];
    for (b, &t) in basis.iter().zip(theta) {
        if t == 0.0 {
            continue;
        }
        let (v, d) = b(q[0], q[1]);
        for i in 0..2 {
            value[i] += t * v[i];
            for j in 0..2 {
                d_point[i][j] += t * d[i][j];
            }
        }
    }
    (value, d_point)
}

/// ideal = q + sum theta_j B_j(q) and its point Jacobian, the parameter Jacobian (the basis
/// values) into `d_params`.
fn linear_closed_into(
    basis: &[Basis],
    theta: &[f64],
    q: [f64; 2],
    d_params: &mut [[f64; 2]],
) -> ([f64; 2], [[f64; 2]; 2]) {
    let mut value = q;
    let mut d_point = [[1.0, 0.0], [0.0, 1.0]];
    for ((b, &t), out) in basis.iter().zip(theta).zip(d_params.iter_mut()) {
        let (v, d) = b(q[0], q[1]);
        for i in 0..2 {
            value[i] += t * v[i];
            for j in 0..2 {
                d_point[i][j] += t * d[i][j];
            }
        }
        *out = v;
    }
    (value, d_point)
}

/// ideal = q + sum theta_j B_j(q) with its Jacobians.
fn linear_closed(basis: &[Basis], theta: &[f64], q: [f64; 2]) -> ClosedForm {
    let mut d_params = vec![[0.0; 2]; basis.len()];
    let (value, d_point) = linear_closed_into(basis, theta, q, &mut d_params);
    ClosedForm {
        value,
        d_point,
        d_params,
    }
}

macro_rules! paper_model {
    ($(#[$doc:meta])* $name:ident { $($field:ident),* }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct $name {
            $(#[serde(default)] pub $field: f64,)*
        }

        impl $name {
            const NAMES: &'static [&'static str] = &[$(stringify!($field)),*];
            const BASIS: &'static [Basis] = &[$($field),*];
        }

        impl DistortionModel for $name {
            fn names(&self) -> &'static [&'static str] { Self::NAMES }
            fn params(&self) -> Vec<f64> { vec![$(self.$field),*] }
            fn set_params(&mut self, values: &[f64]) {
                let mut it = values.iter().copied();
                $(self.$field = it.next().unwrap_or(0.0);)*
            }
            fn direction(&self) -> Direction { Direction::IdealFromObserved }
            fn is_radial(&self) -> bool {
                Self::NAMES.iter().zip(self.params()).all(|(n, v)| v == 0.0 || n.starts_with('k'))
            }
            fn closed(&self, q: [f64; 2]) -> ClosedForm { linear_closed(Self::BASIS, &self.params(), q) }
            fn closed_into(&self, q: [f64; 2], d_params: &mut [[f64; 2]]) -> ([f64; 2], [[f64; 2]; 2]) {
                linear_closed_into(Self::BASIS, &[$(self.$field),*], q, d_params)
            }
            fn value(&self, q: [f64; 2]) -> [f64; 2] { self.value_d_point(q).0 }
            fn value_d_point(&self, q: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
                linear_value(Self::BASIS, &[$(self.$field),*], q)
            }
        }
    };
}

paper_model!(
    /// Tsai (eq. 6): radial k1, k2. Ideal from observed.
    Tsai { k1, k2 }
);
paper_model!(
    /// Brown, full (eq. 7): radial k1-k3, decentring p1, p2, film deformation a1, a2, a5-a7,
    /// b1, b2, b5-b7, principal point offsets dx0, dy0. Ideal from observed.
    Brown { k1, k2, k3, p1, p2, a1, a2, a5, a6, a7, b1, b2, b5, b6, b7, dx0, dy0 }
);
paper_model!(
    /// The paper's improved model (eq. 10): k1, k2, p1, p2, dx0, dy0. Ideal from observed.
    Improved { k1, k2, p1, p2, dx0, dy0 }
);
