//! Chessboard photos rendered through a known lens at a known pose, with their true corners:
//! every pixel integrates 4 x 4 sub-samples of the board (each traced back through the lens onto
//! the board's plane), then Gaussian blur and Gaussian noise. Written from the textbook pinhole
//! and radial-distortion formulas, independent of the detector under test.

use aerorect_core::ImageSize;
use aerorect_raster::Raster;
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A pinhole camera (OpenCV's frame: x right, y down, z forward) with radial k1, k2.
#[derive(Debug, Clone, Copy)]
pub struct Lens {
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub k1: f64,
    pub k2: f64,
}

/// The board and how it is seen.
#[derive(Debug, Clone, Copy)]
pub struct BoardShot {
    pub cols: usize,
    pub rows: usize,
    pub square_m: f64,
    /// Rotation vector (radians) and translation (m) of board -> camera: X_c = R X + t.
    pub rvec: [f64; 3],
    pub t: [f64; 3],
    pub blur_px: f64,
    /// Noise sigma in gray levels of 255.
    pub noise: f64,
    pub seed: u64,
}

const DARK: f64 = 30.0;
const LIGHT: f64 = 220.0;
const BACKGROUND: f64 = 120.0;
const SUB: usize = 4;

/// The rendered gray image (0..255 as f32) and the true inner corners in OpenCV's order
/// (row by row, X = column x square, Y = row x square; the square between corners 0, 1, cols
/// and cols + 1 is dark).
pub fn render_board(
    size: ImageSize,
    lens: &Lens,
    shot: &BoardShot,
) -> (Raster<f32>, Vec<[f64; 2]>) {
    let r = Rotation3::new(Vector3::from(shot.rvec)).into_inner();
    let t = Vector3::from(shot.t);
    let (w, h) = (size.width, size.height);
    let mut img = vec![0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let u = x as f64 - 0.5 + (sx as f64 + 0.5) / SUB as f64;
                    let v = y as f64 - 0.5 + (sy as f64 + 0.5) / SUB as f64;
                    acc += board_value(lens, shot, &r, &t, u, v);
                }
            }
            img[y * w + x] = acc / (SUB * SUB) as f64;
        }
    }
    let img = gaussian(&img, w, h, shot.blur_px);
    let mut rng = ChaCha8Rng::seed_from_u64(shot.seed);
    let noise = Normal::new(0.0, shot.noise.max(0.0)).unwrap();
    let plane: Vec<f32> = img
        .iter()
        .map(|v| (v + noise.sample(&mut rng)) as f32)
        .collect();
    let truth = (0..shot.rows)
        .flat_map(|row| (0..shot.cols).map(move |c| (c, row)))
        .map(|(c, row)| {
            let p = Vector3::new(c as f64 * shot.square_m, row as f64 * shot.square_m, 0.0);
            project(lens, &(r * p + t))
        })
        .collect();
    (Raster::from_planes(size, vec![plane]).unwrap(), truth)
}

/// The pixel of camera point `pc`.
pub fn project(lens: &Lens, pc: &Vector3<f64>) -> [f64; 2] {
    let (x, y) = (pc.x / pc.z, pc.y / pc.z);
    let r2 = x * x + y * y;
    let f = 1.0 + lens.k1 * r2 + lens.k2 * r2 * r2;
    [lens.fx * x * f + lens.cx, lens.fy * y * f + lens.cy]
}

/// The brightness where the ray of pixel (u, v) meets the board's plane.
fn board_value(
    lens: &Lens,
    shot: &BoardShot,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    u: f64,
    v: f64,
) -> f64 {
    let (xd, yd) = ((u - lens.cx) / lens.fx, (v - lens.cy) / lens.fy);
    let (mut x, mut y) = (xd, yd);
    for _ in 0..10 {
        let r2 = x * x + y * y;
        let f = 1.0 + lens.k1 * r2 + lens.k2 * r2 * r2;
        (x, y) = (xd / f, yd / f);
    }
    let rt = r.transpose();
    let origin = -(rt * t);
    let dir = rt * Vector3::new(x, y, 1.0);
    if dir.z.abs() < 1e-12 {
        return BACKGROUND;
    }
    let s = -origin.z / dir.z;
    if s <= 0.0 {
        return BACKGROUND;
    }
    let p = origin + dir * s;
    let (i, j) = ((p.x / shot.square_m).floor(), (p.y / shot.square_m).floor());
    let (c, rr) = (shot.cols as f64, shot.rows as f64);
    // Squares -1..=cols-1 by -1..=rows-1, a one-square white margin, then background.
    if i < -2.0 || j < -2.0 || i > c || j > rr {
        return BACKGROUND;
    }
    if i == -2.0 || j == -2.0 || i == c || j == rr {
        return LIGHT;
    }
    if (i as i64 + j as i64).rem_euclid(2) == 0 {
        DARK
    } else {
        LIGHT
    }
}

/// Separable Gaussian blur (edges repeated); `sigma <= 0` returns the image.
fn gaussian(src: &[f64], w: usize, h: usize, sigma: f64) -> Vec<f64> {
    if sigma <= 0.0 {
        return src.to_vec();
    }
    let rad = (3.0 * sigma).ceil() as isize;
    let k: Vec<f64> = (-rad..=rad)
        .map(|i| (-((i * i) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let sum: f64 = k.iter().sum();
    let pass = |src: &[f64], horizontal: bool| -> Vec<f64> {
        let mut out = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                out[y * w + x] = k
                    .iter()
                    .enumerate()
                    .map(|(n, kv)| {
                        let d = n as isize - rad;
                        let (xx, yy) = if horizontal {
                            ((x as isize + d).clamp(0, w as isize - 1) as usize, y)
                        } else {
                            (x, (y as isize + d).clamp(0, h as isize - 1) as usize)
                        };
                        kv * src[yy * w + xx]
                    })
                    .sum::<f64>()
                    / sum;
            }
        }
        out
    };
    pass(&pass(src, true), false)
}
