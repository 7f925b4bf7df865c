//! The AVX2 build of the row loop: per block, the positions, then the kernel's block.

use super::bicubic::bicubic_block;
use super::bilinear::bilinear_block;
use super::nearest::nearest_block;
use super::positions::{Buffered, Exact, Relative};
use super::sample::SimdSample;
use crate::map::PixelMap;
use crate::raster::Raster;
use crate::warp::block::BLOCK;
use crate::warp::portable::{Bicubic, Nearest};
use crate::warp::scratch::Scratch;
use crate::warp::types::{Kernel, RowOut, RowPlan, SourceGeometry};

/// Bands handled by the AVX2 kernels without allocating.
pub(crate) const MAX_SIMD_BANDS: usize = 8;

/// The AVX2 build: per block, the kernel's taps eight (four) pixels at a time, then each band.
///
/// # Safety
/// The CPU has AVX2; the source is at least 4 x 4 with at most `MAX_SIMD_BANDS` full planes.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn row_avx2<T: SimdSample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    mut out: RowOut<'_, '_, T>,
) {
    use std::any::TypeId;
    let kernel = TypeId::of::<K>();
    let nodata = plan.nodata;
    let bands = src.bands();
    let mut planes: [&[T]; MAX_SIMD_BANDS] = [&[]; MAX_SIMD_BANDS];
    for (p, b) in planes.iter_mut().zip(0..bands) {
        *p = src.plane(b);
    }
    let planes = &planes[..bands];
    let Scratch {
        xs,
        ys,
        valid,
        simd,
        ..
    } = scratch;
    let mut c0 = out.cols.start;
    while c0 < out.cols.end {
        let (n, fast) = plan.block::<K>(out.row, c0, BLOCK.min(out.cols.end - c0));
        let range = out.start + c0..out.start + c0 + n;
        let (xs, ys, valid) = (&mut xs[..n], &mut ys[..n], &mut valid[..n]);
        let mut outs: [&mut [T]; MAX_SIMD_BANDS] = Default::default();
        for (o, chunk) in outs.iter_mut().zip(out.chunks.iter_mut().take(bands)) {
            *o = &mut chunk[range.clone()];
        }
        let outs = &mut outs[..bands];
        let cubic = (&mut simd.cubic[..], &mut simd.base[..], &mut simd.state[..]);
        // SAFETY (all arms): AVX2 is enabled; the source is at least 4 x 4 with full planes;
        // positions and outputs are n long.
        match fast {
            Some(block) => {
                let rel = Relative::new(g, &block, n);
                if kernel == TypeId::of::<Nearest>() {
                    unsafe { nearest_block(g, &rel, planes, outs, valid, nodata) };
                } else {
                    let whole = n / 8 * 8;
                    let (px, py) = (&mut simd.px[..whole], &mut simd.py[..whole]);
                    rel.fill_offsets(px, py);
                    let pos = Buffered { rel: &rel, px, py };
                    if kernel == TypeId::of::<Bicubic>() {
                        unsafe { bicubic_block(g, &pos, planes, outs, valid, cubic, nodata) };
                    } else {
                        unsafe { bilinear_block(g, &pos, planes, outs, valid, nodata) };
                    }
                }
            }
            None if kernel == TypeId::of::<Bicubic>() => {
                plan.map.source_row(out.row, c0, xs, ys);
                let pos = Exact { xs, ys };
                unsafe { bicubic_block(g, &pos, planes, outs, valid, cubic, nodata) };
            }
            None => {
                plan.map.source_row(out.row, c0, xs, ys);
                let pos = Exact { xs, ys };
                if kernel == TypeId::of::<Nearest>() {
                    unsafe { nearest_block(g, &pos, planes, outs, valid, nodata) };
                } else {
                    unsafe { bilinear_block(g, &pos, planes, outs, valid, nodata) };
                }
            }
        }
        out.write_alpha(range, valid);
        c0 += n;
    }
}
