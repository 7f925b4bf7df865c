//! A zone plate with its analytic truth: the aliasing check of the area-aware downsampling
//! (tests/downsample.rs) and its benchmark read the same plate.

use aerorect_core::ImageSize;
use aerorect_raster::{PixelMap, Raster, Sample};

/// The zone plate 0.5 + 0.5 cos(k r^2) about the image centre of an n x n source; its local
/// frequency k r / pi cycles a pixel reaches `f_max` at the corners.
pub struct ZonePlate {
    n: usize,
    k: f64,
}

impl ZonePlate {
    pub fn new(n: usize, f_max: f64) -> Self {
        let r_max = (n as f64 - 1.0) / std::f64::consts::SQRT_2;
        Self {
            n,
            k: f_max * std::f64::consts::PI / r_max,
        }
    }

    pub fn at(&self, x: f64, y: f64) -> f64 {
        let c = 0.5 * (self.n as f64 - 1.0);
        let r2 = (x - c).powi(2) + (y - c).powi(2);
        0.5 + 0.5 * (self.k * r2).cos()
    }

    /// Local frequency at (x, y), cycles per source pixel.
    pub fn frequency(&self, x: f64, y: f64) -> f64 {
        let c = 0.5 * (self.n as f64 - 1.0);
        self.k * ((x - c).powi(2) + (y - c).powi(2)).sqrt() / std::f64::consts::PI
    }

    /// The plate sampled at pixel centres, scaled to [0, peak] and rounded to `T`.
    pub fn raster<T: Sample>(&self, peak: f64) -> Raster<T> {
        let n = self.n;
        let plane = (0..n * n)
            .map(|i| T::from_f32((peak * self.at((i % n) as f64, (i / n) as f64)) as f32))
            .collect();
        Raster::from_planes(ImageSize::new(n, n), vec![plane]).unwrap()
    }

    /// The truth at the output resolution: the analytic function averaged over each destination
    /// pixel's footprint (s x s points of the destination square, mapped exactly).
    pub fn box_filtered<M: PixelMap>(&self, map: &M, size: ImageSize, s: usize) -> Vec<f64> {
        (0..size.pixels())
            .map(|i| {
                let (c, r) = ((i % size.width) as f64, (i / size.width) as f64);
                let mut acc = 0.0;
                for j in 0..s {
                    for k in 0..s {
                        let dc = (k as f64 + 0.5) / s as f64 - 0.5;
                        let dr = (j as f64 + 0.5) / s as f64 - 0.5;
                        let [x, y] = map.source_of(c + dc, r + dr).unwrap();
                        acc += self.at(x, y);
                    }
                }
                acc / (s * s) as f64
            })
            .collect()
    }
}
