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

/// A sample's gray level on the 0..255 scale: u8 as is, u16 divided by 257, f32 taken as
/// already on that scale.
trait GrayLevel: crate::Sample {
    fn level(self) -> f32;
}

impl GrayLevel for u8 {
    fn level(self) -> f32 {
        self as f32
    }
}

impl GrayLevel for u16 {
    fn level(self) -> f32 {
        self as f32 / 257.0
    }
}

impl GrayLevel for f32 {
    fn level(self) -> f32 {
        self
    }
}

/// ITU-R BT.601 luma of one pixel's first three samples (OpenCV's `cvtColor` weights), each
/// sample's [`GrayLevel`]: the one place the reduction's colour weights are written.
#[inline(always)]
fn bt601<T: GrayLevel>(a: T, b: T, c: T) -> f32 {
    0.299 * a.level() + 0.587 * b.level() + 0.114 * c.level()
}

/// One pixel's gray value, read from a raster's planes: one band as is, two bands (gray +
/// alpha) the first, three or more ITU-R BT.601 luma of the first three (OpenCV's `cvtColor`
/// weights), each sample's [`GrayLevel`].
struct Luma<'a, T> {
    planes: [&'a [T]; 3],
    colour: bool,
}

impl<'a, T: GrayLevel> Luma<'a, T> {
    fn of(r: &'a Raster<T>) -> Self {
        let colour = r.bands() >= 3;
        let planes = match colour {
            true => [r.plane(0), r.plane(1), r.plane(2)],
            false => [r.plane(0); 3],
        };
        Self { planes, colour }
    }

    /// The gray values of pixels `start..start + len` into `out` (replacing what it held):
    /// [`Luma::at`]'s operations, over slices, which vectorises.
    fn row_into(&self, start: usize, len: usize, out: &mut Vec<f32>) {
        let [a, b, c] = self.planes.map(|p| &p[start..start + len]);
        out.clear();
        match self.colour {
            true => out.extend(a.iter().zip(b).zip(c).map(|((&a, &b), &c)| bt601(a, b, c))),
            false => out.extend(a.iter().map(|&a| a.level())),
        }
    }

    #[inline(always)]
    fn at(&self, i: usize) -> f32 {
        let [a, b, c] = self.planes;
        match self.colour {
            true => bt601(a[i], b[i], c[i]),
            false => a[i].level(),
        }
    }
}

/// The gray frame reduced by `factor` (1 keeps it): each output pixel the mean of a `factor` x
/// `factor` block, so positions map back by [`full_from_reduced`].
///
/// Reduced, each pixel's gray value is made where its block is summed, in the same operations
/// and order as the full gray frame's (summed a block row at a time): no full-resolution gray
/// frame is made (64 MB of f32 for a 16-Mpx photo, nearly a third of the snowpeak flight's page
/// faults). The test holds it to the full frame's reduction bit for bit.
pub fn gray_reduced(raster: &AnyRaster, factor: usize) -> Result<Raster<f32>, RasterError> {
    let f = factor.max(1);
    let s = raster.size();
    let size = ImageSize::new(s.width / f, s.height / f);
    if size.width == 0 || size.height == 0 {
        return Err(RasterError::Empty);
    }
    let out = match raster {
        AnyRaster::U8(r) => reduced(r, size, f),
        AnyRaster::U16(r) => reduced(r, size, f),
        AnyRaster::F32(r) => reduced(r, size, f),
    };
    Raster::from_planes(size, vec![out])
}

/// [`gray_reduced`]'s samples for a raster of `T`: `size` blocks of `f` x `f`.
fn reduced<T: GrayLevel>(r: &Raster<T>, size: ImageSize, f: usize) -> Vec<f32> {
    match f {
        1 if r.bands() < 3 => r.plane(0).par_iter().map(|&v| v.level()).collect(),
        1 => {
            let luma = Luma::of(r);
            (0..r.size().pixels())
                .into_par_iter()
                .map(|i| luma.at(i))
                .collect()
        }
        _ => reduce(&Luma::of(r), r.size().width, size, f),
    }
}

/// The block means of `luma` over a frame `width` pixels wide: `size` blocks of `f` x `f`.
fn reduce<T: GrayLevel>(luma: &Luma<'_, T>, width: usize, size: ImageSize, f: usize) -> Vec<f32> {
    let scale = 1.0 / (f * f) as f32;
    let mut out = vec![0f32; size.width * size.height];
    // Each of a block row's pixel rows made gray whole, then summed block by block (each
    // block's values in order from 0, as `at` one by one was): about half the time on RGB
    // photos (snowpeak's, reduced by 4).
    out.par_chunks_mut(size.width)
        .enumerate()
        .for_each_init(Vec::new, |line, (r, row)| {
            for dy in 0..f {
                luma.row_into((r * f + dy) * width, size.width * f, line);
                for (o, block) in row.iter_mut().zip(line.chunks_exact(f)) {
                    *o += block.iter().sum::<f32>();
                }
            }
            row.iter_mut().for_each(|o| *o *= scale);
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The full gray frame (each pixel's luma on its own), then its block sums a block row at
    /// a time: the reduction as it was made before it was fused.
    fn reduced_from_full(raster: &AnyRaster, f: usize) -> Vec<f32> {
        fn full<T: crate::Sample>(r: &Raster<T>, to: impl Fn(T) -> f32) -> Vec<f32> {
            match r.bands() >= 3 {
                true => (0..r.size().pixels())
                    .map(|i| {
                        let [a, b, c] = [0, 1, 2].map(|k| to(r.plane(k)[i]));
                        0.299 * a + 0.587 * b + 0.114 * c
                    })
                    .collect(),
                false => r.plane(0).iter().map(|&v| to(v)).collect(),
            }
        }
        let g = match raster {
            AnyRaster::U8(r) => full(r, |v| v as f32),
            AnyRaster::U16(r) => full(r, |v| v as f32 / 257.0),
            AnyRaster::F32(r) => full(r, |v| v),
        };
        let s = raster.size();
        let (w, h) = (s.width / f, s.height / f);
        let mut out = vec![0f32; w * h];
        for (r, row) in out.chunks_mut(w).enumerate() {
            for dy in 0..f {
                let src = &g[(r * f + dy) * s.width..][..w * f];
                for (o, block) in row.iter_mut().zip(src.chunks_exact(f)) {
                    *o += block.iter().sum::<f32>();
                }
            }
            row.iter_mut().for_each(|o| *o *= 1.0 / (f * f) as f32);
        }
        out
    }

    #[test]
    fn fused_reduction_is_the_full_gray_frames_bit_for_bit() {
        let size = ImageSize::new(23, 17);
        let n = size.pixels();
        let wave = |b: usize, i: usize| (i * 37 + b * 101 + i * i / 7) % 256;
        let planes = |bands: usize| -> Vec<Vec<usize>> {
            (0..bands)
                .map(|b| (0..n).map(|i| wave(b, i)).collect())
                .collect()
        };
        let u8s = |bands| {
            planes(bands)
                .iter()
                .map(|p| p.iter().map(|&v| v as u8).collect())
                .collect()
        };
        let u16s = |bands| {
            planes(bands)
                .iter()
                .map(|p| p.iter().map(|&v| (v * 257 + v / 3) as u16).collect())
                .collect()
        };
        let f32s = |bands| {
            planes(bands)
                .iter()
                .map(|p| p.iter().map(|&v| v as f32 * 0.77 + 0.1).collect())
                .collect()
        };
        let rasters = [
            AnyRaster::U8(Raster::from_planes(size, u8s(3)).expect("rgb")),
            AnyRaster::U8(Raster::from_planes(size, u8s(4)).expect("rgba")),
            AnyRaster::U8(Raster::from_planes(size, u8s(1)).expect("gray")),
            AnyRaster::U16(Raster::from_planes(size, u16s(3)).expect("rgb16")),
            AnyRaster::U16(Raster::from_planes(size, u16s(2)).expect("gray-alpha16")),
            AnyRaster::F32(Raster::from_planes(size, f32s(3)).expect("rgb32f")),
        ];
        for r in &rasters {
            for f in [2, 3, 4, 5] {
                let got = gray_reduced(r, f).expect("reduce");
                let want = reduced_from_full(r, f);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(got.plane(0)),
                    bits(&want),
                    "factor {f}, {} bands",
                    r.bands()
                );
            }
        }
    }

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
