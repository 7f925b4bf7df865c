//! The warp's dispatcher: the kernel of the interpolation over the whole destination, its rows
//! shared out over rayon's pool tile by tile; each row goes to the best build the CPU has
//! (`simd::row`).

use super::area;
use super::options::{Coordinates, Interp, WarpOptions};
use super::portable::{Bicubic, Bilinear, Nearest};
use super::scratch::Scratch;
use super::simd::row;
use super::types::{Build, Kernel, RowOut, RowPlan, SourceGeometry, row_strips};
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use rayon::prelude::*;

/// Runs `interp`'s kernel over the whole destination (no prefilter; arguments checked).
pub(crate) fn dispatch<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    nodata: T,
    dst: &mut Raster<T>,
    build: Build,
) {
    let g = SourceGeometry::of(src, build);
    // The AVX2 build moves the image's limits by the origin in f32: exact below 2^22 pixels.
    let small = src.width().max(src.height()) < 1 << 22;
    let fast = match opts.coordinates {
        Coordinates::Fast if small => map.projective(),
        _ => None,
    };
    let plan = RowPlan {
        map,
        fast: fast.as_ref(),
        nodata,
        alpha: opts.alpha,
    };
    match opts.interp {
        Interp::Nearest => run::<T, M, Nearest>(src, &g, &plan, dst),
        Interp::Bilinear => run::<T, M, Bilinear>(src, &g, &plan, dst),
        Interp::Bicubic => run::<T, M, Bicubic>(src, &g, &plan, dst),
        Interp::Average => area::run(src, map, nodata, opts.alpha, dst),
    }
}

/// About this many destination pixels per rayon task ...
const PIXELS_PER_TASK: usize = 32 * 1024;

/// ... and at least this many rows: a task walks its rows tile by tile (`TILE_COLS` columns),
/// so that the source pixels of a tile stay in cache from one row to the next even when the
/// destination rows cross the source at an angle (as OpenCV's warp blocks do).
const MIN_ROWS_PER_TASK: usize = 16;

const TILE_COLS: usize = 1024;

fn run<T: Sample, M: PixelMap, K: Kernel>(
    src: &Raster<T>,
    g: &SourceGeometry,
    plan: &RowPlan<'_, M, T>,
    dst: &mut Raster<T>,
) {
    let width = dst.width();
    let rows_per_task = (PIXELS_PER_TASK / width).max(MIN_ROWS_PER_TASK);
    row_strips(dst, rows_per_task)
        .into_par_iter()
        .enumerate()
        .for_each_init(Scratch::<K>::new, |scratch, (t, mut chunks)| {
            let first_row = t * rows_per_task;
            let rows = chunks[0].len() / width;
            for c0 in (0..width).step_by(TILE_COLS) {
                for r in 0..rows {
                    let out = RowOut {
                        chunks: &mut chunks,
                        start: r * width,
                        row: first_row + r,
                        cols: c0..(c0 + TILE_COLS).min(width),
                        alpha: plan.alpha,
                    };
                    row::<T, K, M>(src, plan, g, scratch, out);
                }
            }
        });
}
