//! The portable build of the kernels, one file per kernel (nearest, bilinear, bicubic), and its
//! row loop (`row_body`). Every SIMD kernel does the same arithmetic in the same order, so the
//! builds agree bit for bit (see `warp/SIMD.md`).

mod bicubic;
mod bilinear;
mod nearest;

pub(crate) use bicubic::Bicubic;
pub use bicubic::keys_weights;
pub(crate) use bilinear::Bilinear;
pub(crate) use nearest::Nearest;

use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use crate::warp::block::BLOCK;
use crate::warp::scratch::Scratch;
use crate::warp::types::{Kernel, RowOut, RowPlan, SourceGeometry};

#[inline(always)]
pub(crate) fn row_body<T: Sample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    mut out: RowOut<'_, '_, T>,
) {
    let nodata = plan.nodata;
    let Scratch {
        xs,
        ys,
        taps,
        valid,
        ..
    } = scratch;
    let mut c0 = out.cols.start;
    while c0 < out.cols.end {
        let (n, fast) = plan.block::<K>(out.row, c0, BLOCK.min(out.cols.end - c0));
        let (xs, ys, taps, valid) = (&mut xs[..n], &mut ys[..n], &mut taps[..n], &mut valid[..n]);
        plan.positions(fast.as_ref(), out.row, c0, xs, ys);
        for (((x, y), tap), ok) in xs
            .iter()
            .zip(ys.iter())
            .zip(taps.iter_mut())
            .zip(valid.iter_mut())
        {
            *ok = K::prepare::<T>(g, *x, *y, tap);
        }
        let range = out.start + c0..out.start + c0 + n;
        for b in 0..src.bands() {
            let plane = src.plane(b);
            let dst = &mut out.chunks[b][range.clone()];
            for ((d, tap), &ok) in dst.iter_mut().zip(taps.iter()).zip(valid.iter()) {
                *d = if ok { K::apply(plane, g, tap) } else { nodata };
            }
        }
        out.write_alpha(range, valid);
        c0 += n;
    }
}
