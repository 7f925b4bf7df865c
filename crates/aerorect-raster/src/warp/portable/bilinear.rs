//! The bilinear kernel (portable build).

use crate::raster::Sample;
use crate::warp::types::{Kernel, SourceGeometry};

pub(crate) struct Bilinear;

#[derive(Clone, Copy, Default)]
pub(crate) struct BilinearTap {
    /// Index of the upper-left neighbour; the other three are `step_x`, `step_y` further on.
    offset: u32,
    fx: f32,
    fy: f32,
    /// The sample type's integer weights (`Sample::bilinear_weights`), made once for all bands.
    w: [i32; 4],
}

impl Kernel for Bilinear {
    type Tap = BilinearTap;

    /// Branch-free so that the loop vectorises: the taps are always valid indices (NaN and
    /// outside positions are clamped), the returned flag says whether the pixel is inside.
    #[inline(always)]
    fn prepare<T: Sample>(g: &SourceGeometry, x: f64, y: f64, tap: &mut BilinearTap) -> bool {
        let (x0, fx) = left_neighbour(x, g.width);
        let (y0, fy) = left_neighbour(y, g.height);
        *tap = BilinearTap {
            offset: y0 * g.width as u32 + x0,
            fx,
            fy,
            w: T::bilinear_weights((fx, fy)),
        };
        g.inside(x, y)
    }

    #[inline(always)]
    fn apply<T: Sample>(plane: &[T], g: &SourceGeometry, t: &BilinearTap) -> T {
        let o = t.offset as usize;
        let last = o + g.step_y + g.step_x;
        assert!(last < plane.len()); // one check instead of four; `prepare` keeps it true
        // SAFETY: o <= o + step_x, o + step_y <= last < plane.len(), checked just above.
        let p = unsafe {
            [
                *plane.get_unchecked(o),
                *plane.get_unchecked(o + g.step_x),
                *plane.get_unchecked(o + g.step_y),
                *plane.get_unchecked(last),
            ]
        };
        T::bilinear(p, (t.fx, t.fy), t.w)
    }
}

/// The left (upper) neighbour index and the fraction towards the next one, with the edge
/// repeated: x is clamped to [0, n - 1] (NaN to 0) and the index to [0, n - 2].
#[inline(always)]
fn left_neighbour(x: f64, n: usize) -> (u32, f32) {
    let xc = x.max(0.0).min((n - 1) as f64);
    let i = (xc as i32).min(n.saturating_sub(2) as i32);
    (i as u32, (xc - i as f64) as f32)
}
