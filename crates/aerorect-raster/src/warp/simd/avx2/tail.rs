//! The last pixels of a block, through the portable kernels.

use crate::raster::Sample;
use crate::warp::types::{Kernel, SourceGeometry};

/// The last pixels of a block (fewer than a step), through the portable kernel: the same
/// arithmetic, so the builds still agree to the bit.
pub(crate) struct Tail {
    from: usize,
    pub(crate) n: usize,
    pub(crate) xs: [f64; 8],
    pub(crate) ys: [f64; 8],
}

impl Tail {
    pub(crate) fn new(from: usize, len: usize) -> Self {
        Self {
            from,
            n: len.saturating_sub(from).min(8),
            xs: [0.0; 8],
            ys: [0.0; 8],
        }
    }

    pub(crate) fn run<K: Kernel, T: Sample>(
        &self,
        g: &SourceGeometry,
        planes: &[&[T]],
        outs: &mut [&mut [T]],
        valid: &mut [bool],
        nodata: T,
    ) {
        for j in 0..self.n {
            let at = self.from + j;
            let mut tap = K::Tap::default();
            valid[at] = K::prepare::<T>(g, self.xs[j], self.ys[j], &mut tap);
            for (plane, out) in planes.iter().zip(outs.iter_mut()) {
                out[at] = if valid[at] {
                    K::apply(plane, g, &tap)
                } else {
                    nodata
                };
            }
        }
    }
}
