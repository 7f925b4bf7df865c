//! Chessboard corner candidates: saddle points of the blurred image (the Hessian's determinant
//! strongly negative) that look like an X-junction on a circle around them (four alternating
//! dark and bright arcs whose boundaries are two straight lines through the point).

use super::image::Gray;
use std::f64::consts::PI;

/// One X-junction: its position, saddle strength and the angles (radians, in [0, pi)) of the two
/// edge lines crossing there.
#[derive(Debug, Clone, Copy)]
pub struct Candidate {
    pub p: [f64; 2],
    pub lines: [f64; 2],
    /// The brightness range on the test circle.
    pub contrast: f64,
}

/// The most candidates kept by saddle strength before the X-junction test.
const MAX_SADDLES: usize = 4000;
/// Samples on each test circle.
const RING: usize = 32;
/// The largest mean difference between opposite ring samples, as a fraction of the ring's range.
const MAX_ASYMMETRY: f64 = 0.25;

/// The X-junctions of `blurred` (already smoothed), strongest first.
pub fn candidates(blurred: Gray<'_>) -> Vec<Candidate> {
    let response = saddle_response(blurred);
    let peaks = local_maxima(&response, blurred.width, blurred.height);
    let (lo, hi) = blurred
        .data
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let min_contrast = 0.08 * f64::from(hi - lo);
    peaks
        .into_iter()
        .filter_map(|(x, y, _)| {
            let p = peak_position(&response, blurred.width, x, y);
            let (lines, contrast) = x_junction(blurred, p, min_contrast)?;
            Some(Candidate { p, lines, contrast })
        })
        .collect()
}

/// max(0, Ixy^2 - Ixx Iyy) by central differences: large at saddles (X-junctions), zero along
/// straight edges and on blobs.
fn saddle_response(g: Gray<'_>) -> Vec<f32> {
    let (w, h) = (g.width, g.height);
    let mut r = vec![0f32; w * h];
    for y in 1..h.saturating_sub(1) {
        for x in 1..w.saturating_sub(1) {
            let i = y * w + x;
            let d = g.data;
            let ixx = d[i + 1] - 2.0 * d[i] + d[i - 1];
            let iyy = d[i + w] - 2.0 * d[i] + d[i - w];
            let ixy = 0.25 * (d[i + w + 1] - d[i + w - 1] - d[i - w + 1] + d[i - w - 1]);
            r[i] = (ixy * ixy - ixx * iyy).max(0.0);
        }
    }
    r
}

/// Pixels that are the maximum of their 5 x 5 neighbourhood and above 1 % of the strongest,
/// strongest first, at most `MAX_SADDLES`.
fn local_maxima(r: &[f32], w: usize, h: usize) -> Vec<(usize, usize, f32)> {
    let top = r.iter().copied().fold(0f32, f32::max);
    let floor = 0.01 * top;
    let mut out = Vec::new();
    if top <= 0.0 {
        return out;
    }
    for y in 2..h.saturating_sub(2) {
        for x in 2..w.saturating_sub(2) {
            let v = r[y * w + x];
            if v <= floor {
                continue;
            }
            let is_max = (y - 2..=y + 2).all(|yy| {
                (x - 2..=x + 2).all(|xx| {
                    let u = r[yy * w + xx];
                    u < v || (u == v && (yy, xx) >= (y, x))
                })
            });
            if is_max {
                out.push((x, y, v));
            }
        }
    }
    out.sort_by(|a, b| b.2.total_cmp(&a.2));
    out.truncate(MAX_SADDLES);
    out
}

/// The vertex of a parabola through the response and its two neighbours, in each axis.
fn peak_position(r: &[f32], w: usize, x: usize, y: usize) -> [f64; 2] {
    let at = |dx: isize, dy: isize| {
        f64::from(r[(y as isize + dy) as usize * w + (x as isize + dx) as usize])
    };
    let vertex = |m: f64, c: f64, p: f64| {
        let den = m - 2.0 * c + p;
        if den < 0.0 {
            (0.5 * (m - p) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    let c = at(0, 0);
    [
        x as f64 + vertex(at(-1, 0), c, at(1, 0)),
        y as f64 + vertex(at(0, -1), c, at(0, 1)),
    ]
}

/// The two edge-line angles when a circle of radius 3.5 or 5.5 about `p` crosses four arcs of
/// alternating brightness whose boundaries lie pairwise opposite (within 20 degrees).
fn x_junction(g: Gray<'_>, p: [f64; 2], min_contrast: f64) -> Option<([f64; 2], f64)> {
    [5.5, 3.5]
        .iter()
        .find_map(|&radius| x_on_ring(g, p, radius, min_contrast))
}

fn x_on_ring(g: Gray<'_>, p: [f64; 2], radius: f64, min_contrast: f64) -> Option<([f64; 2], f64)> {
    let step = 2.0 * PI / RING as f64;
    let mut ring = [0f64; RING];
    for (v, (c, s)) in ring.iter_mut().zip(unit_ring()) {
        *v = g.bilinear(p[0] + radius * c, p[1] + radius * s);
    }
    let (lo, hi) = ring
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    if hi - lo < min_contrast {
        return None;
    }
    // Opposite sides of an X-junction have one colour (point symmetry); a T-junction's do not.
    let asymmetry = (0..RING / 2)
        .map(|k| (ring[k] - ring[k + RING / 2]).abs())
        .sum::<f64>()
        / (RING / 2) as f64;
    if asymmetry > MAX_ASYMMETRY * (hi - lo) {
        return None;
    }
    let mid = 0.5 * (lo + hi);
    let mut crossings = Vec::with_capacity(4);
    let mut at = Vec::with_capacity(4);
    for k in 0..RING {
        let (a, b) = (ring[k], ring[(k + 1) % RING]);
        if (a > mid) != (b > mid) {
            if crossings.len() == 4 {
                return None;
            }
            crossings.push((k as f64 + (mid - a) / (b - a)) * step);
            at.push(k);
        }
    }
    if crossings.len() != 4 {
        return None;
    }
    // Each arc spans at least two samples.
    let runs = [
        at[1] - at[0],
        at[2] - at[1],
        at[3] - at[2],
        RING + at[0] - at[3],
    ];
    if runs.iter().any(|&n| n < 2) {
        return None;
    }
    let opposite = |a: f64, b: f64| wrap(b - a - PI).abs() < 20f64.to_radians();
    if !(opposite(crossings[0], crossings[2]) && opposite(crossings[1], crossings[3])) {
        return None;
    }
    let line = |a: f64, b: f64| (a + 0.5 * wrap(b - PI - a)).rem_euclid(PI);
    let lines = [
        line(crossings[0], crossings[2]),
        line(crossings[1], crossings[3]),
    ];
    Some((lines, hi - lo))
}

/// (cos, sin) of the ring's sample angles, 2 pi k / RING.
fn unit_ring() -> &'static [(f64, f64); RING] {
    static RING_XY: std::sync::OnceLock<[(f64, f64); RING]> = std::sync::OnceLock::new();
    RING_XY.get_or_init(|| {
        std::array::from_fn(|k| {
            let a = 2.0 * PI * k as f64 / RING as f64;
            (a.cos(), a.sin())
        })
    })
}

/// An angle wrapped into (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let r = a.rem_euclid(2.0 * PI);
    if r > PI { r - 2.0 * PI } else { r }
}
