//! The nearest kernel (portable build).

use crate::raster::Sample;
use crate::warp::types::{Kernel, SourceGeometry};

pub(crate) struct Nearest;

impl Kernel for Nearest {
    type Tap = u32;
    /// floor(x + 0.5) becomes origin + floor(offset).
    const FAST_SHIFT: f64 = 0.5;

    /// Branch-free like the bilinear one: the index is always valid, the flag tells inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut u32) -> bool {
        let nearest = |v: f64, n: usize| ((v + 0.5).max(0.0) as i32).min(n as i32 - 1) as u32;
        *tap = nearest(y, g.height) * g.width as u32 + nearest(x, g.width);
        g.inside(x, y)
    }

    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], _g: &SourceGeometry, tap: &u32) -> T {
        plane[*tap as usize]
    }
}
