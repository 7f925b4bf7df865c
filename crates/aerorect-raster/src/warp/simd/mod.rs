#![doc = include_str!("../SIMD.md")]

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512;

use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use crate::warp::portable::row_body;
use crate::warp::scratch::Scratch;
use crate::warp::types::{Kernel, RowOut, RowPlan, SourceGeometry};
#[cfg(target_arch = "x86_64")]
use avx2::row::{MAX_SIMD_BANDS, row_avx2};

/// Resamples one destination row. Uses the AVX2 build of the kernels where the CPU has it.
pub(crate) fn row<T: Sample, K: Kernel, M: PixelMap>(
    src: &Raster<T>,
    plan: &RowPlan<'_, M, T>,
    g: &SourceGeometry,
    scratch: &mut Scratch<K>,
    out: RowOut<'_, '_, T>,
) {
    #[cfg(target_arch = "x86_64")]
    if g.simd && g.width >= 4 && g.height >= 4 && src.bands() <= MAX_SIMD_BANDS {
        // SAFETY: `g.simd` is only set after `crate::cpu::avx2()` returned true;
        // the source is at least 4 x 4.
        let out = match same_type::<T, u8, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<u8, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        let out = match same_type::<T, u16, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<u16, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        let out = match same_type::<T, f32, M>(src, plan, out) {
            Ok((src, plan, out)) => {
                return unsafe { row_avx2::<f32, K, M>(src, &plan, g, scratch, out) };
            }
            Err(out) => out,
        };
        return row_body::<T, K, M>(src, plan, g, scratch, out);
    }
    row_body::<T, K, M>(src, plan, g, scratch, out);
}

/// The source, plan and row as sample type `S` when `T` is `S`; the row back otherwise.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::type_complexity)]
fn same_type<'s, 'p, 'a, 'b, T: Sample, S: Sample, M>(
    src: &'s Raster<T>,
    plan: &RowPlan<'p, M, T>,
    out: RowOut<'a, 'b, T>,
) -> Result<(&'s Raster<S>, RowPlan<'p, M, S>, RowOut<'a, 'b, S>), RowOut<'a, 'b, T>> {
    use std::any::TypeId;
    if TypeId::of::<T>() != TypeId::of::<S>() {
        return Err(out);
    }
    // SAFETY: T and S are the same type (equal TypeIds), so these casts change no type.
    let (src, chunks, nodata) = unsafe {
        (
            &*(src as *const Raster<T> as *const Raster<S>),
            &mut *(out.chunks as *mut [&'b mut [T]] as *mut [&'b mut [S]]),
            *(&plan.nodata as *const T as *const S),
        )
    };
    let plan = RowPlan {
        map: plan.map,
        fast: plan.fast,
        nodata,
        alpha: plan.alpha,
    };
    let out = RowOut {
        chunks,
        start: out.start,
        row: out.row,
        cols: out.cols,
        alpha: out.alpha,
    };
    Ok((src, plan, out))
}
