//! A borrowed gray plane with clamped bilinear sampling, and a separable Gaussian blur.

/// One band of samples, row-major, `width x height`.
#[derive(Clone, Copy)]
pub struct Gray<'a> {
    pub data: &'a [f32],
    pub width: usize,
    pub height: usize,
}

impl Gray<'_> {
    /// The sample at integer (x, y), clamped to the image.
    pub fn at(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at (x, y) (pixel centres at integers), edges repeated.
    pub fn bilinear(&self, x: f64, y: f64) -> f64 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as isize, y0 as isize);
        let a = f64::from(self.at(x0, y0));
        let b = f64::from(self.at(x0 + 1, y0));
        let c = f64::from(self.at(x0, y0 + 1));
        let d = f64::from(self.at(x0 + 1, y0 + 1));
        (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    }

    pub fn contains(&self, x: f64, y: f64) -> bool {
        x >= 0.0 && y >= 0.0 && x <= (self.width - 1) as f64 && y <= (self.height - 1) as f64
    }
}

/// The normalised Gaussian kernel of `sigma`, radius ceil(3 sigma).
pub fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = (3.0 * sigma).ceil().max(1.0) as isize;
    let k: Vec<f64> = (-r..=r)
        .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let s: f64 = k.iter().sum();
    k.iter().map(|v| (v / s) as f32).collect()
}

/// `src` convolved with `kernel` along rows then columns, edges repeated.
pub fn blur(src: Gray<'_>, kernel: &[f32]) -> Vec<f32> {
    let (w, h) = (src.width, src.height);
    let r = (kernel.len() / 2) as isize;
    let mut tmp = vec![0f32; w * h];
    let ru = r as usize;
    for y in 0..h {
        let row = &src.data[y * w..(y + 1) * w];
        let out = &mut tmp[y * w..(y + 1) * w];
        for x in 0..w {
            if x >= ru && x + ru < w {
                // Interior: no clamping.
                let taps = &row[x - ru..=x + ru];
                out[x] = kernel.iter().zip(taps).map(|(k, v)| k * v).sum();
                continue;
            }
            let mut acc = 0f32;
            for (k, kv) in kernel.iter().enumerate() {
                let xx = (x as isize + k as isize - r).clamp(0, w as isize - 1) as usize;
                acc += kv * row[xx];
            }
            out[x] = acc;
        }
    }
    let mut out = vec![0f32; w * h];
    for (k, kv) in kernel.iter().enumerate() {
        for y in 0..h {
            let yy = (y as isize + k as isize - r).clamp(0, h as isize - 1) as usize;
            let (dst, srow) = (&mut out[y * w..(y + 1) * w], &tmp[yy * w..(yy + 1) * w]);
            for (d, s) in dst.iter_mut().zip(srow) {
                *d += kv * s;
            }
        }
    }
    out
}
