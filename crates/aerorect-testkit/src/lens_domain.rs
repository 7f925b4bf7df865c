//! Lenses that fold inside the field of view, and a slow oracle for the valid domain: a ray is
//! seen when the lens is monotonic along it all the way from the axis (marched densely,
//! independent of the bisection in `aerorect_core::distortion`'s domain search).

use aerorect_core::distortion::{Direction, Distortion, DistortionModel};
use aerorect_core::{Camera, ImageSize, Intrinsics};

/// One strongly folding lens of every model ([`Distortion::NAMES`] order): each stops being
/// monotonic inside the field of a 320 x 240 frame with a focal of 200 px (the corners at
/// normalised radius 1), most with terms that are not radially symmetric.
pub fn folding_lenses() -> Vec<Distortion> {
    let coefficients: [&[f64]; 7] = [
        // tsai: k1, k2 (ideal from observed: folds at observed r = 0.91)
        &[-0.4, 0.0],
        // brown: k1 k2 k3 p1 p2 a1 a2 a5 a6 a7 b1 b2 b5 b6 b7 dx0 dy0
        &[
            -0.4, 0.02, 0.0, 1e-3, -1e-3, 1e-3, -5e-4, 1e-3, 5e-4, -5e-4, 5e-4, -1e-3, 1e-3, 5e-4,
            -5e-4, 1e-3, -1e-3,
        ],
        // improved: k1 k2 p1 p2 dx0 dy0
        &[-0.4, 0.02, 1e-3, -1e-3, 1e-3, -1e-3],
        // opencv: k1 k2 p1 p2 k3 (folds at ideal r = 1.09, turns up again beyond 1.68)
        &[-0.4, 0.06, 1e-3, -5e-4, 0.0],
        // opencv-rational: + k4 k5 k6
        &[-0.3, 0.05, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0],
        // opencv-thin-prism: + s1..s4
        &[-0.4, 0.06, 0.0, 0.0, 0.0, 2e-3, -1e-3, -1.5e-3, 5e-4],
        // opencv-rational-thin-prism
        &[
            -0.35, 0.05, 1e-3, -5e-4, 0.0, 0.05, 0.0, 0.0, 2e-3, -1e-3, -1.5e-3, 5e-4,
        ],
    ];
    Distortion::NAMES
        .iter()
        .zip(coefficients)
        .map(|(kind, c)| {
            let mut d = Distortion::zero(kind).unwrap();
            d.model_mut().set_params(c);
            d
        })
        .collect()
}

/// The 320 x 240 frame of [`folding_lenses`] with `lens`.
pub fn folding_camera(lens: Distortion) -> Camera {
    let k = Intrinsics::new(200.0, 200.0, 159.5, 119.5).unwrap();
    Camera::new(k, Some(lens), ImageSize::new(320, 240))
}

/// Dense march from the axis to `a` (the closed form's argument): the model's value along the
/// ray increases strictly at each of `steps` steps and the Jacobian keeps a positive
/// determinant.
pub fn monotonic_to(m: &dyn DistortionModel, a: [f64; 2], steps: usize) -> bool {
    let r = a[0].hypot(a[1]);
    if r == 0.0 {
        return true;
    }
    let u = [a[0] / r, a[1] / r];
    let v0 = m.value([0.0, 0.0]);
    let mut last = 0.0;
    for i in 1..=steps {
        let t = i as f64 / steps as f64;
        let (v, j) = m.value_d_point([t * a[0], t * a[1]]);
        let along = (v[0] - v0[0]) * u[0] + (v[1] - v0[1]) * u[1];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        if !(along > last && det > 0.0 && along.is_finite()) {
            return false;
        }
        last = along;
    }
    true
}

/// Whether observed pixel `px` lies on the image (within half a pixel of the corner centres).
pub fn on_image(size: ImageSize, px: [f64; 2]) -> bool {
    px[0] >= -0.5
        && px[1] >= -0.5
        && px[0] <= size.width as f64 - 0.5
        && px[1] <= size.height as f64 - 0.5
}

/// The oracle: ideal normalised point `n` is seen at observed pixel `px` when the lens takes one
/// to the other, `px` lies on the image and the lens is monotonic from the axis to the point.
pub fn seen(camera: &Camera, n: [f64; 2], px: [f64; 2]) -> bool {
    let inside = on_image(camera.size, px);
    let Some(d) = &camera.distortion else {
        return inside;
    };
    let m = d.model();
    let o = camera.intrinsics.normalized_from_pixel(px[0], px[1]);
    let (arg, other) = match m.direction() {
        Direction::ObservedFromIdeal => (n, o),
        Direction::IdealFromObserved => (o, n),
    };
    let v = m.value(arg);
    let agrees = (v[0] - other[0]).hypot(v[1] - other[1]) < 1e-6;
    inside && agrees && monotonic_to(m, arg, 500)
}
