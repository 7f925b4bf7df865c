//! Test oracles of the JTC forms: noisy textured pairs, and the paper's joint image computed in
//! f64 by its definition.

use super::check_frame;
use super::jtc_common::{JtcOptions, Plane};
use super::sim::{add_noise, shifted_linear};
use aerorect_core::ImageSize;
use rand::SeedableRng;

/// Noisy pairs cut from a textured scene: (reference, current, true shift).
pub(super) fn pairs(w: usize, h: usize) -> Vec<(Vec<f32>, Vec<f32>)> {
    let size = ImageSize::new(400, 400);
    let texture = aerorect_testkit::textured_scene::<f32>(size, 1, 1.0, 5);
    let scene = crate::Raster::from_planes(size, vec![texture.plane(0).to_vec()]).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let size = ImageSize::new(w, h);
    [
        (1.37, -2.61, 10.0),
        (-0.4, 0.25, 20.0),
        (3.0, 2.0, 4.0),
        (0.0, 0.0, 30.0),
    ]
    .iter()
    .map(|&(dx, dy, snr)| {
        let mut r = shifted_linear(&scene, 60.0, 70.0, size, 0.0, 0.0);
        let mut t = shifted_linear(&scene, 60.0, 70.0, size, dx, dy);
        add_noise(&mut r, snr, &mut rng);
        add_noise(&mut t, snr, &mut rng);
        (r, t)
    })
    .collect()
}

/// The paper's joint image in f64, by its definition: the 6w x 2h joint image (reference
/// at column 0, current at 2w), its full 2-D spectrum (complex FFTs of rows and columns),
/// |J|^2, the [-1 2 -1] filter along u on the whole circle, the binarisation (+1 above the
/// median of every 8th value of the half spectrum taken u-major, -1 elsewhere), the inverse, both cross peaks
/// averaged, both frame orders antisymmetrised: the independent oracle of the f32 forms.
pub(super) fn joint_image_f64(
    r: &[f32],
    t: &[f32],
    w: usize,
    h: usize,
    opts: JtcOptions,
) -> (f64, f64) {
    let way = |a: &[f32], b: &[f32]| -> (f64, f64) {
        let (ww, hh) = (6 * w, 2 * h);
        let mut planner = rustfft::FftPlanner::<f64>::new();
        let (row_f, col_f) = (planner.plan_fft_forward(ww), planner.plan_fft_forward(hh));
        let (row_i, col_i) = (planner.plan_fft_inverse(ww), planner.plan_fft_inverse(hh));
        let prep = |f: &[f32]| {
            let mean = check_frame("f", f, w, h).unwrap();
            let mut out = vec![0.0f32; w * h];
            super::jtc_common::prepare(f, mean, w, h, opts.laplacian, &mut out);
            out
        };
        let (pa, pb) = (prep(a), prep(b));
        let mut j = vec![rustfft::num_complex::Complex64::default(); ww * hh];
        for y in 0..h {
            for x in 0..w {
                j[y * ww + x].re = pa[y * w + x] as f64;
                j[y * ww + 2 * w + x].re = pb[y * w + x] as f64;
            }
        }
        let fft2 = |j: &mut Vec<rustfft::num_complex::Complex64>, inverse: bool| {
            let (rf, cf) = if inverse {
                (&row_i, &col_i)
            } else {
                (&row_f, &col_f)
            };
            rf.process(j);
            let mut col = vec![rustfft::num_complex::Complex64::default(); hh];
            for x in 0..ww {
                for y in 0..hh {
                    col[y] = j[y * ww + x];
                }
                cf.process(&mut col);
                for y in 0..hh {
                    j[y * ww + x] = col[y];
                }
            }
        };
        fft2(&mut j, false);
        let p: Vec<f64> = j.iter().map(|c| c.norm_sqr()).collect();
        for y in 0..hh {
            for u in 0..ww {
                let at = |k: usize| p[y * ww + k % ww];
                let e = if opts.spectral_filter {
                    2.0 * at(u) - at(u + ww - 1) - at(u + 1)
                } else {
                    at(u)
                };
                j[y * ww + u] = rustfft::num_complex::Complex64::new(e, 0.0);
            }
        }
        if opts.binarize {
            // The threshold: the median of every 8th value of the half spectrum (u in 0..=3w)
            // taken u-major, (u, v) at index u * 2h + v.
            let mut sample: Vec<f64> = (0..=3 * w)
                .flat_map(|u| (0..hh).map(move |v| (u, v)))
                .filter(|&(u, v)| (u * hh + v) % 8 == 0)
                .map(|(u, v)| j[v * ww + u].re)
                .collect();
            let n = sample.len();
            let median = *sample.select_nth_unstable_by(n / 2, f64::total_cmp).1;
            for c in j.iter_mut() {
                c.re = if c.re > median { 1.0 } else { -1.0 };
            }
        }
        fft2(&mut j, true);
        let half = h / 2;
        let mut window = vec![0.0f32; h * 4 * w];
        for wr in 0..h {
            let y = (wr + hh - half) % hh;
            for c in 0..4 * w {
                window[wr * 4 * w + c] = j[y * ww + w + c].re as f32;
            }
        }
        let plane = Plane {
            data: &window,
            stride: 4 * w,
            rows: h,
        };
        let (x1, y1, _) = plane.peak(0, 2 * w, opts.subpixel);
        let (x2, y2, _) = plane.peak(2 * w, 4 * w, opts.subpixel);
        (
            0.5 * ((x1 - w as f64) + (3.0 * w as f64 - x2)),
            0.5 * (y1 - y2),
        )
    };
    let (f, b) = (way(r, t), way(t, r));
    (0.5 * (f.0 - b.0), 0.5 * (f.1 - b.1))
}
