//! Orientation assignment: a 36-bin gradient histogram per keypoint.
//!
//! The accumulation order is fixed by the reference and cannot be reordered:
//! float addition is not associative, and this histogram is summed sequentially
//! in a known sample order. The loop below walks rows-outer, columns-inner for
//! that reason.

use super::detect::RawKeypoint;
use super::hal::{exp_batch, grow_to, mag_ang_batch};
use super::params::SiftConfig;

/// Histogram bins (`SIFT_ORI_HIST_BINS`).
pub const ORI_HIST_BINS: usize = 36;
/// Patch radius factor (`SIFT_ORI_RADIUS`).
pub const ORI_RADIUS: f32 = 4.5;
/// Gaussian weight sigma factor (`SIFT_ORI_SIG_FCTR`).
pub const ORI_SIG_FCTR: f32 = 1.5;
/// Secondary-peak acceptance ratio (`SIFT_ORI_PEAK_RATIO`).
pub const ORI_PEAK_RATIO: f32 = 0.8;

/// A keypoint with an assigned orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedKeypoint {
    /// Column in base-image pixels.
    pub x: f32,
    /// Row in base-image pixels.
    pub y: f32,
    /// Diameter of the meaningful neighbourhood.
    pub size: f32,
    /// Contrast at the refined extremum.
    pub response: f32,
    /// Packed octave/layer/sub-layer field.
    pub octave: i32,
    /// Orientation in degrees.
    pub angle: f32,
}

/// Per-worker scratch for [`assign_orientations`].
///
/// Same reason the descriptor has one: the reference runs each primitive as a
/// single pass over the whole patch, and doing it a few samples at a time makes
/// the transcendental emulations share registers with the binning loop.
#[derive(Default)]
pub struct OrientScratch {
    dx: Vec<f32>,
    dy: Vec<f32>,
    wt: Vec<f32>,
    mag: Vec<f32>,
    ang: Vec<f32>,
}

impl OrientScratch {
    /// Empty scratch; sized on first use.
    pub fn new() -> Self {
        Self::default()
    }
}

/// Append one oriented keypoint per dominant gradient direction.
///
/// A keypoint with several peaks within `ORI_PEAK_RATIO` of the maximum yields
/// several entries, as the reference does.
pub fn assign_orientations(
    img: &[f32],
    w: usize,
    h: usize,
    kp: &RawKeypoint,
    cfg: &SiftConfig,
    out: &mut Vec<OrientedKeypoint>,
    sc: &mut OrientScratch,
) {
    let octv = kp.octave & 255;
    // `size` is still in the octave's own scale here; the first-octave halving
    // happens later.
    let scl_octv = kp.size * 0.5 / (1 << octv) as f32;
    let radius = (ORI_RADIUS * scl_octv).round_ties_even() as i32;
    let sigma = ORI_SIG_FCTR * scl_octv;
    let expf_scale = -1.0 / (2.0 * sigma * sigma);

    let mut temphist = [0.0f32; ORI_HIST_BINS];
    let (cc, rr) = (kp.cc, kp.rr);

    // The reference's binning loop has a SIMD block and a scalar tail, and they
    // round DIFFERENTLY:
    //
    //   SIMD:   w = w * mag;  then  temphist[bin] += w;   // two roundings
    //   tail:   temphist[bin] += W[k] * Mag[k];           // contracts to one fma
    //
    // So which samples get which depends only on the total count, and the count
    // is `nx * ny` in closed form because the loop is a rectangle clipped to the
    // image interior and the column bound does not depend on the row.
    let y0 = (rr - radius).max(1);
    let y1 = (rr + radius).min(h as i32 - 2);
    let x0 = (cc - radius).max(1);
    let x1 = (cc + radius).min(w as i32 - 2);
    let nx = (x1 - x0 + 1).max(0);
    let ny = (y1 - y0 + 1).max(0);
    let vec_end = (nx * ny) & !3;

    // Collect the whole patch, then run one pass per primitive, as
    // `calcOrientationHist` does. Batching four at a time was measured here and
    // lost: at that width the helpers' loop preambles do not fold away, and the
    // emulations share registers with the binning loop.
    //
    // The primitives are elementwise, so the values do not depend on where a
    // batch boundary falls; the binning below still runs in strict sample order
    // and its `vec_end` split is indexed by the sample counter, so neither is
    // affected.
    sc.dx.clear();
    sc.dy.clear();
    sc.wt.clear();

    // Row by row over the columns inside the image (x0..=x1), as whole slices: the same
    // per-sample arithmetic as a loop over (i, j) that skips the border, and it vectorises.
    if nx > 0 {
        let (xa, xb) = (x0 as usize, x1 as usize);
        for y in y0..=y1 {
            let (i, y) = (y - rr, y as usize);
            let (row, up, dn) = (&img[y * w..], &img[(y - 1) * w..], &img[(y + 1) * w..]);
            let (right, left) = (&row[xa + 1..=xb + 1], &row[xa - 1..=xb - 1]);
            sc.dx.extend(right.iter().zip(left).map(|(a, b)| a - b));
            let (above, below) = (&up[xa..=xb], &dn[xa..=xb]);
            sc.dy.extend(above.iter().zip(below).map(|(a, b)| a - b));
            sc.wt.extend((x0..=x1).map(|x| {
                let j = x - cc;
                (i * i + j * j) as f32 * expf_scale
            }));
        }
    }

    let len = sc.dx.len();
    grow_to(&mut sc.mag, len);
    grow_to(&mut sc.ang, len);
    exp_batch(&mut sc.wt);
    mag_ang_batch(&sc.dx, &sc.dy, &mut sc.mag[..len], &mut sc.ang[..len]);

    for k in 0..len {
        let mut bin = ((ORI_HIST_BINS as f32 / 360.0) * sc.ang[k]).round_ties_even() as i32;
        if bin >= ORI_HIST_BINS as i32 {
            bin -= ORI_HIST_BINS as i32;
        }
        if bin < 0 {
            bin += ORI_HIST_BINS as i32;
        }
        // NOTE: `magnitude32f`'s vector body composes `recip(rsqrt(s))` from
        // ARM's estimate instructions while its scalar tail issues a real
        // square root. Reproducing that split for the last `len % 4` samples
        // was implemented and measured here and on the GPU: it changes no angle
        // either time. Do not re-try.
        if (k as i32) < vec_end {
            temphist[bin as usize] += sc.wt[k] * sc.mag[k];
        } else {
            temphist[bin as usize] = sc.wt[k].mul_add(sc.mag[k], temphist[bin as usize]);
        }
    }

    // Smooth with [1,4,6,4,1]/16, wrapping. The reference's scalar form is
    // `(tn2+t2)*1/16 + (tn1+t1)*4/16 + t0*6/16` evaluated left to right, which
    // its build contracts as below — NOT the vector branch's shape.
    let n = ORI_HIST_BINS;
    let mut hist = [0.0f32; ORI_HIST_BINS];
    for i in 0..n {
        let tn2 = temphist[(i + n - 2) % n];
        let tn1 = temphist[(i + n - 1) % n];
        let t0 = temphist[i];
        let t1 = temphist[(i + 1) % n];
        let t2 = temphist[(i + 2) % n];
        // Vector branch's association, matching the binning loop above: the
        // whole translation unit takes one dispatch or the other, so if the
        // accumulation is the SIMD form the smoothing is too.
        hist[i] = (tn2 + t2).mul_add(
            1.0 / 16.0,
            (tn1 + t1).mul_add(4.0 / 16.0, t0 * (6.0 / 16.0)),
        );
    }

    let mut omax = hist[0];
    for &v in hist.iter().skip(1) {
        if v > omax {
            omax = v;
        }
    }
    let mag_thr = omax * ORI_PEAK_RATIO;

    let scale = 1.0f32; // caller applies the first-octave rescale
    for j in 0..n {
        let l = if j > 0 { j - 1 } else { n - 1 };
        let r2 = if j < n - 1 { j + 1 } else { 0 };
        if hist[j] > hist[l] && hist[j] > hist[r2] && hist[j] >= mag_thr {
            let den = hist[l] - 2.0 * hist[j] + hist[r2];
            let mut bin = j as f32 + 0.5 * (hist[l] - hist[r2]) / den;
            bin = if bin < 0.0 {
                n as f32 + bin
            } else if bin >= n as f32 {
                bin - n as f32
            } else {
                bin
            };
            // `360 - (360/n)*bin` is a mul-then-subtract, which the reference's
            // build contracts. Rounding the product separately shifts the angle
            // by an ULP.
            let mut angle = (-(360.0 / n as f32)).mul_add(bin, 360.0);
            if (angle - 360.0).abs() < f32::EPSILON {
                angle = 0.0;
            }
            out.push(OrientedKeypoint {
                x: kp.x * scale,
                y: kp.y * scale,
                size: kp.size * scale,
                response: kp.response,
                octave: kp.octave,
                angle,
            });
        }
    }
    let _ = cfg;
}
