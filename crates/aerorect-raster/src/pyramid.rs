//! Image pyramids: 2 x 2 box reduction, with the pixel-centre convention
//! x_full = 2 x_half + 0.5 (so `full_from_level` is exact for every level).

use crate::Raster;
use aerorect_core::ImageSize;

/// The 2 x 2 mean of every block (a trailing odd row or column is dropped).
pub fn half(src: &Raster<f32>) -> Raster<f32> {
    let s = src.size();
    let size = ImageSize::new((s.width / 2).max(1), (s.height / 2).max(1));
    let planes = src
        .planes()
        .iter()
        .map(|p| {
            let mut out = Vec::with_capacity(size.width * size.height);
            for r in 0..size.height {
                let (r0, r1) = ((2 * r).min(s.height - 1), (2 * r + 1).min(s.height - 1));
                for c in 0..size.width {
                    let (c0, c1) = ((2 * c).min(s.width - 1), (2 * c + 1).min(s.width - 1));
                    out.push(
                        0.25 * (p[r0 * s.width + c0]
                            + p[r0 * s.width + c1]
                            + p[r1 * s.width + c0]
                            + p[r1 * s.width + c1]),
                    );
                }
            }
            out
        })
        .collect();
    Raster::from_planes(size, planes).unwrap_or_else(|_| src.clone())
}

/// Levels 0 (the image) to the first whose larger side is at most `max_side`.
pub fn pyramid(src: &Raster<f32>, max_side: usize) -> Vec<Raster<f32>> {
    let mut levels = vec![src.clone()];
    while let Some(top) = levels.last() {
        let s = top.size();
        if s.width.max(s.height) <= max_side.max(16) || s.width.min(s.height) < 32 {
            break;
        }
        let next = half(top);
        levels.push(next);
    }
    levels
}

/// The full-resolution position of pixel (x, y) of level `level`.
pub fn full_from_level(level: usize, p: [f64; 2]) -> [f64; 2] {
    let f = (1u64 << level) as f64;
    p.map(|x| f * (x + 0.5) - 0.5)
}

/// The level-`level` position of full-resolution pixel (x, y).
pub fn level_from_full(level: usize, p: [f64; 2]) -> [f64; 2] {
    let f = (1u64 << level) as f64;
    p.map(|x| (x + 0.5) / f - 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A linear ramp stays the same ramp at every level, read through `full_from_level`.
    #[test]
    fn a_ramp_is_sampled_at_the_stated_centres() {
        let size = ImageSize::new(128, 96);
        let plane: Vec<f32> = (0..128 * 96)
            .map(|i| (3 * (i % 128) + 5 * (i / 128)) as f32)
            .collect();
        let levels = pyramid(&Raster::from_planes(size, vec![plane]).expect("r"), 16);
        assert_eq!(levels.len(), 3);
        for (l, img) in levels.iter().enumerate() {
            let s = img.size();
            for (x, y) in [(0, 0), (s.width - 1, 3), (2, s.height - 1)] {
                let [fx, fy] = full_from_level(l, [x as f64, y as f64]);
                let want = 3.0 * fx + 5.0 * fy;
                assert!((img.plane(0)[y * s.width + x] as f64 - want).abs() < 1e-3);
                let back = level_from_full(l, [fx, fy]);
                assert!((back[0] - x as f64).abs() < 1e-12 && (back[1] - y as f64).abs() < 1e-12);
            }
        }
    }
}
