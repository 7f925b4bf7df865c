//! A frame reduced for feature detection: one gray band on a 0..255 scale, box means of
//! `factor` x `factor` pixels.

use crate::{AnyRaster, Raster, RasterError};
use aerorect_core::ImageSize;
use rayon::prelude::*;

/// The full-resolution position of position `p` of a frame reduced by `factor` (box means, a
/// trailing partial block dropped): `factor (x + 0.5) - 0.5`.
pub fn full_from_reduced(factor: usize, p: [f64; 2]) -> [f64; 2] {
    let f = factor.max(1) as f64;
    p.map(|x| f * (x + 0.5) - 0.5)
}

/// Gray value (0..255) of each pixel: one band as is, two bands (gray + alpha) the first,
/// three or more ITU-R BT.601 luma of the first three (OpenCV's `cvtColor` weights); u16
/// divided by 257, f32 taken as already on the 0..255 scale.
fn gray(raster: &AnyRaster) -> Vec<f32> {
    fn luma<T: crate::Sample>(r: &Raster<T>, to: impl Fn(T) -> f32 + Sync) -> Vec<f32> {
        if r.bands() < 3 {
            return r.plane(0).par_iter().map(|&v| to(v)).collect();
        }
        let (a, b, c) = (r.plane(0), r.plane(1), r.plane(2));
        (0..a.len())
            .into_par_iter()
            .map(|i| 0.299 * to(a[i]) + 0.587 * to(b[i]) + 0.114 * to(c[i]))
            .collect()
    }
    match raster {
        AnyRaster::U8(r) => luma(r, |v| v as f32),
        AnyRaster::U16(r) => luma(r, |v| v as f32 / 257.0),
        AnyRaster::F32(r) => luma(r, |v| v),
    }
}

/// The gray frame reduced by `factor` (1 keeps it): each output pixel the mean of a `factor` x
/// `factor` block, so positions map back by [`full_from_reduced`].
pub fn gray_reduced(raster: &AnyRaster, factor: usize) -> Result<Raster<f32>, RasterError> {
    let f = factor.max(1);
    let s = raster.size();
    let size = ImageSize::new(s.width / f, s.height / f);
    if size.width == 0 || size.height == 0 {
        return Err(RasterError::Empty);
    }
    let g = gray(raster);
    if f == 1 {
        return Raster::from_planes(size, vec![g]);
    }
    let scale = 1.0 / (f * f) as f32;
    let mut out = vec![0f32; size.width * size.height];
    out.par_chunks_mut(size.width)
        .enumerate()
        .for_each(|(r, row)| {
            for dy in 0..f {
                let src = &g[(r * f + dy) * s.width..][..size.width * f];
                for (o, block) in row.iter_mut().zip(src.chunks_exact(f)) {
                    *o += block.iter().sum::<f32>();
                }
            }
            row.iter_mut().for_each(|o| *o *= scale);
        });
    Raster::from_planes(size, vec![out])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reduction_is_the_block_mean_and_positions_map_back_to_the_block_centre() {
        // 7 x 5 RGB, factor 3: a 2 x 1 result; the trailing column and rows dropped.
        let size = ImageSize::new(7, 5);
        let planes: Vec<Vec<u8>> = (0..3)
            .map(|b| (0..35).map(|i| (i * (b + 1)) as u8).collect())
            .collect();
        let r = AnyRaster::U8(Raster::from_planes(size, planes).expect("raster"));
        let g = gray_reduced(&r, 3).expect("reduce");
        assert_eq!(g.size(), ImageSize::new(2, 1));
        for (k, &v) in g.plane(0).iter().enumerate() {
            let mut want = 0.0;
            for y in 0..3 {
                for x in 3 * k..3 * k + 3 {
                    let i = (y * 7 + x) as f32;
                    want += (0.299 + 0.587 * 2.0 + 0.114 * 3.0) * i / 9.0;
                }
            }
            assert!((v - want).abs() < 1e-3, "{v} {want}");
        }
        // Block (0, 0) covers pixels 0..=2: its centre is pixel 1.
        assert_eq!(full_from_reduced(3, [0.0, 0.0]), [1.0, 1.0]);
        assert_eq!(full_from_reduced(4, [1.0, 0.0]), [5.5, 1.5]);
    }
}
