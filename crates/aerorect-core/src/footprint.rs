//! The outline of what a frame camera sees when part of its image border lies beyond the lens's
//! valid domain: the image rectangle (through the corner pixels' centres) clipped to the
//! domain's rim, in observed pixels, and the rays of that outline.
//!
//! The rim is the domain's circle sampled in the closed form's argument space and taken to
//! observed pixels (by the closed form for OpenCV's model, directly for the paper's); the
//! rectangle clips it (Sutherland-Hodgman: the rectangle is convex, the rim need not be). Rim
//! vertices keep their known ideal points; the rectangle's pieces are resampled as densely as the
//! border and undistorted by the lens's inverse inside the domain.

use crate::Vec3;
use crate::distortion::{Direction, DistortionModel, ValidDomain};
use crate::intrinsics::{ImageSize, Intrinsics};

/// An outline vertex: its observed pixel and, on the rim, its ideal normalised point.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    px: [f64; 2],
    ideal: Option<[f64; 2]>,
}

/// The rays of the border of an image of `size` clipped to `domain`'s rim, `4 * per_side` rim
/// samples: rim vertices through `intrinsics` and `model`, the rectangle's pieces through the
/// camera's `ray_from_pixel`.
pub(crate) fn clipped_border_rays(
    intrinsics: &Intrinsics,
    size: ImageSize,
    model: &dyn DistortionModel,
    domain: &ValidDomain,
    per_side: usize,
    ray_from_pixel: impl Fn(f64, f64) -> Option<Vec3>,
) -> Vec<Vec3> {
    let n = 4 * per_side.max(1);
    let k = intrinsics;
    let rim: Vec<Vertex> = (0..n)
        .map(|i| {
            // Clockwise in the image (y down), like the border.
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let q = [domain.radius * a.cos(), domain.radius * a.sin()];
            let (observed, ideal) = match domain.direction {
                Direction::ObservedFromIdeal => (model.value(q), q),
                Direction::IdealFromObserved => (q, model.value(q)),
            };
            Vertex {
                px: k.pixel_from_normalized(observed[0], observed[1]),
                ideal: Some(ideal),
            }
        })
        .collect();
    let [w, h] = [size.width as f64 - 1.0, size.height as f64 - 1.0];
    let mut outline = rim;
    for edge in [
        Edge::Left(0.0),
        Edge::Right(w),
        Edge::Top(0.0),
        Edge::Bottom(h),
    ] {
        outline = clip(&outline, edge);
    }
    let spacing = (w.max(h) / per_side.max(1) as f64).max(1.0);
    densified(&outline, spacing)
        .iter()
        .filter_map(|v| match v.ideal {
            Some(q) => Some(Vec3::new(q[0], -q[1], -1.0)),
            None => ray_from_pixel(v.px[0], v.px[1]),
        })
        .collect()
}

/// A clipping half-plane of the rectangle.
#[derive(Debug, Clone, Copy)]
enum Edge {
    Left(f64),
    Right(f64),
    Top(f64),
    Bottom(f64),
}

impl Edge {
    fn inside(self, p: [f64; 2]) -> bool {
        match self {
            Edge::Left(x) => p[0] >= x,
            Edge::Right(x) => p[0] <= x,
            Edge::Top(y) => p[1] >= y,
            Edge::Bottom(y) => p[1] <= y,
        }
    }

    /// Where segment a-b crosses the edge's line.
    fn crossing(self, a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
        let t = match self {
            Edge::Left(x) | Edge::Right(x) => (x - a[0]) / (b[0] - a[0]),
            Edge::Top(y) | Edge::Bottom(y) => (y - a[1]) / (b[1] - a[1]),
        };
        let mut p = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
        match self {
            Edge::Left(x) | Edge::Right(x) => p[0] = x,
            Edge::Top(y) | Edge::Bottom(y) => p[1] = y,
        }
        p
    }
}

/// One Sutherland-Hodgman pass; new vertices (on the edge) have no known ideal point.
fn clip(poly: &[Vertex], edge: Edge) -> Vec<Vertex> {
    let mut out = Vec::with_capacity(poly.len() + 4);
    for (i, &cur) in poly.iter().enumerate() {
        let prev = poly[(i + poly.len() - 1) % poly.len()];
        let (a, b) = (edge.inside(prev.px), edge.inside(cur.px));
        if a != b {
            out.push(Vertex {
                px: edge.crossing(prev.px, cur.px),
                ideal: None,
            });
        }
        if b {
            out.push(cur);
        }
    }
    out
}

/// The outline with every edge that is not a rim chord resampled at `spacing` pixels.
fn densified(poly: &[Vertex], spacing: f64) -> Vec<Vertex> {
    let mut out = Vec::with_capacity(poly.len() * 2);
    for (i, &a) in poly.iter().enumerate() {
        out.push(a);
        let b = poly[(i + 1) % poly.len()];
        if a.ideal.is_some() && b.ideal.is_some() {
            continue;
        }
        let len = (b.px[0] - a.px[0]).hypot(b.px[1] - a.px[1]);
        let steps = (len / spacing).ceil() as usize;
        for s in 1..steps {
            let t = s as f64 / steps as f64;
            out.push(Vertex {
                px: [
                    a.px[0] + t * (b.px[0] - a.px[0]),
                    a.px[1] + t * (b.px[1] - a.px[1]),
                ],
                ideal: None,
            });
        }
    }
    out
}
