//! The vector paths against the scalar code they replace, bit for bit, value by value: the
//! descriptor's patch collection, its scatter, and the batch exponential, magnitude and angle.
//! `tests/upstream.rs` compares whole descriptors, which are quantised to integers and so hide
//! a last-bit difference in a weight; these compare the unquantised values.

use super::descriptor::{compute_descriptor, DescriptorScratch, DESCR_LEN, DESCR_SCL_FCTR};
use super::hal::{atan2_deg, exp, exp_batch, mag_ang_batch, magnitude};
use super::scatter::{scatter, scatter_scalar};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn batch_exponential_is_the_scalar_exponential_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    // The descriptor's and orientation's arguments (-r^2 / 8, -r^2 / (2 sigma^2)), values whose
    // scaled form is a tie of the rounding (k + 1/2 over the prescale), and the clamps.
    let prescale = std::f32::consts::LOG2_E * 64.0;
    let mut v: Vec<f32> = (0..20_000)
        .map(|_| rng.random_range(-40.0f32..0.0))
        .collect();
    v.extend((-300..300).map(|k| (k as f32 + 0.5) / prescale));
    v.extend([
        0.0, -0.0, 1e-30, -1e-30, 3000.0, -3000.0, 1e6, -1e6, 88.0, -104.0,
    ]);
    v.push(-7.25); // a length not a multiple of 8
    let want: Vec<f32> = v.iter().map(|&x| exp(x)).collect();
    exp_batch(&mut v);
    assert_eq!(bits(&v), bits(&want));
}

#[test]
fn batch_magnitude_and_angle_are_the_scalar_ones_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let mut dx: Vec<f32> = (0..4000)
        .map(|_| rng.random_range(-255.0f32..255.0))
        .collect();
    let mut dy: Vec<f32> = (0..4000)
        .map(|_| rng.random_range(-255.0f32..255.0))
        .collect();
    // Every quadrant's edges: zeros of both signs, equal magnitudes, integer differences.
    for (x, y) in [
        (0.0, 0.0),
        (-0.0, 0.0),
        (0.0, -0.0),
        (-0.0, -0.0),
        (3.0, 3.0),
        (-3.0, 3.0),
        (3.0, -3.0),
        (-3.0, -3.0),
        (0.0, 5.0),
        (-5.0, 0.0),
        (1e-7, -1e-7),
        (255.0, -1.0),
        (-17.0, 0.0),
    ] {
        dx.push(x);
        dy.push(y);
    }
    let n = dx.len();
    let (mut mag, mut ang) = (vec![0f32; n], vec![0f32; n]);
    mag_ang_batch(&dx, &dy, &mut mag, &mut ang);
    let want_mag: Vec<f32> = dx.iter().zip(&dy).map(|(&x, &y)| magnitude(x, y)).collect();
    let want_ang: Vec<f32> = dx.iter().zip(&dy).map(|(&x, &y)| atan2_deg(y, x)).collect();
    assert_eq!(bits(&mag), bits(&want_mag));
    assert_eq!(bits(&ang), bits(&want_ang));
}

/// Samples crowded into few bins, so that consecutive ones add to the same cells, as along a
/// patch row.
fn samples(rng: &mut ChaCha8Rng, len: usize) -> DescriptorScratch {
    let mut sc = DescriptorScratch::new();
    for _ in 0..len {
        let r = rng.random_range(-0.999f32..3.999);
        let c = rng.random_range(-0.999f32..3.999);
        sc.rbin.push(r);
        sc.cbin.push(c);
        sc.ang.push(rng.random_range(0.0f32..360.0));
        sc.mag.push(rng.random_range(0.0f32..90.0));
        sc.wt.push(rng.random_range(0.0f32..1.0));
    }
    // Bin edges exactly: whole and half values, and zero of both signs.
    for (k, v) in [0.0f32, -0.0, 1.0, 2.0, -0.5, 2.5, 3.0]
        .into_iter()
        .enumerate()
    {
        sc.rbin[k] = v;
        sc.cbin[len - 1 - k] = v;
        sc.ang[k] = 45.0 * k as f32;
    }
    sc
}

#[test]
fn scatter_is_the_scalar_scatter_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    const HISTLEN: usize = 6 * 6 * 10;
    for len in [7, 8, 9, 1001, 1400] {
        let sc = samples(&mut rng, len);
        for ori in [0.0f32, 17.5, 359.9] {
            let (mut fast, mut slow) = ([0f32; HISTLEN], [0f32; HISTLEN]);
            scatter(&sc, len, ori, 8.0 / 360.0, &mut fast);
            scatter_scalar(&sc, 0, len, ori, 8.0 / 360.0, &mut slow);
            let (fast, slow) = (inner_cells(&fast), inner_cells(&slow));
            assert_eq!(bits(&fast), bits(&slow), "{len} samples, orientation {ori}");
        }
    }
}

/// The bins of the histogram's cells inside its border ring (rows and columns 1..=4, all 10
/// bins of each), in order: the only ones the descriptor's fold reads.
fn inner_cells(hist: &[f32]) -> Vec<f32> {
    let cell = |r: usize, c: usize| &hist[(r * 6 + c) * 10..(r * 6 + c + 1) * 10];
    (1..=4)
        .flat_map(|r| (1..=4).flat_map(move |c| cell(r, c).iter().copied()))
        .collect()
}

/// The reference's patch loop (`calcSIFTDescriptor`): every (i, j) of the square, kept where
/// both bin coordinates lie in (-1, d) and the pixel has four neighbours. Returns dx, dy,
/// row bin, column bin and the weight's exponent, per kept sample in order.
fn reference_patch(
    img: &[f32],
    (w, h): (usize, usize),
    (ptx, pty, scl, ori): (f32, f32, f32, f32),
) -> [Vec<f32>; 5] {
    const D: f32 = 4.0;
    let (px, py) = (ptx.round_ties_even() as i32, pty.round_ties_even() as i32);
    let hist_width = DESCR_SCL_FCTR * scl;
    let radius = ((hist_width * std::f32::consts::SQRT_2 * (D + 1.0) * 0.5).round_ties_even()
        as i32)
        .min(((w * w + h * h) as f32).sqrt() as i32);
    let cos_t = (ori * (std::f32::consts::PI / 180.0)).cos() / hist_width;
    let sin_t = (ori * (std::f32::consts::PI / 180.0)).sin() / hist_width;
    let exp_scale = -1.0 / (D * D * 0.5);
    let mut out: [Vec<f32>; 5] = Default::default();
    for i in -radius..=radius {
        for j in -radius..=radius {
            let c_rot = j as f32 * cos_t - i as f32 * sin_t;
            let r_rot = j as f32 * sin_t + i as f32 * cos_t;
            let rbin = r_rot + D / 2.0 - 0.5;
            let cbin = c_rot + D / 2.0 - 0.5;
            let (r, c) = (py + i, px + j);
            if rbin > -1.0
                && rbin < D
                && cbin > -1.0
                && cbin < D
                && r > 0
                && r < h as i32 - 1
                && c > 0
                && c < w as i32 - 1
            {
                let at = |r: i32, c: i32| img[r as usize * w + c as usize];
                out[0].push(at(r, c + 1) - at(r, c - 1));
                out[1].push(at(r - 1, c) - at(r + 1, c));
                out[2].push(rbin);
                out[3].push(cbin);
                out[4].push((c_rot * c_rot + r_rot * r_rot) * exp_scale);
            }
        }
    }
    out
}

#[test]
fn patch_collection_is_the_reference_loop_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(14);
    let (w, h) = (97, 83);
    let img: Vec<f32> = (0..w * h)
        .map(|_| rng.random_range(0.0f32..255.0))
        .collect();
    let mut out = [0f32; DESCR_LEN];
    // Inside, against each edge and corner, at several scales and angles.
    let points = [
        (48.3, 41.7),
        (2.0, 40.0),
        (95.0, 3.0),
        (50.0, 81.6),
        (0.4, 0.4),
    ];
    for &(x, y) in &points {
        for scl in [1.3f32, 2.7, 6.1] {
            for ori in [0.0f32, 33.0, 90.0, 211.7, 359.0] {
                let kp = (x, y, scl, ori);
                // Fresh scratch: its magnitude buffer is then exactly the samples kept.
                let mut sc = DescriptorScratch::new();
                compute_descriptor(&img, w, h, x, y, scl, ori, &mut out, &mut sc);
                let want = reference_patch(&img, (w, h), kp);
                let n = want[0].len();
                assert_eq!(sc.mag.len(), n, "samples kept at {kp:?}");
                let exps: Vec<f32> = want[4].iter().map(|&v| exp(v)).collect();
                let got = [&sc.dx, &sc.dy, &sc.rbin, &sc.cbin, &sc.wt];
                for (name, (g, wv)) in ["dx", "dy", "rbin", "cbin", "weight"].iter().zip(
                    got.iter()
                        .zip([&want[0], &want[1], &want[2], &want[3], &exps]),
                ) {
                    assert_eq!(bits(&g[..n]), bits(wv), "{name} at {kp:?}");
                }
            }
        }
    }
}
