//! Automatic prefiltering for bilinear and bicubic downsampling (`WarpOptions::prefilter`).
//!
//! Where a destination pixel spans more than two source pixels, bilinear and bicubic read only
//! their 2 x 2 or 4 x 4 neighbours and alias. The destination is cut into `TILE` x `TILE` tiles;
//! each tile's scale rho (source pixels per destination pixel along the longer side of the
//! footprint: the larger length of the Jacobian's two columns, OpenGL's mipmap rule) is taken at
//! the tile's centre (else the smallest over its corners with a source), and the tile is resampled
//! from pyramid level k = floor(log2 rho), so the remaining scale rho / 2^k is in [1, 2). Levels
//! are 2 x 2 box means (`reduce_half`), the image's last odd row or column averaged with itself;
//! a level-k pixel i is centred on level-0 position (i + 0.5) 2^k - 0.5.
//!
//! When every tile has level 0 (scales below 2 everywhere), the warp is the plain one, bit for
//! bit. Tiles at level 0 beside prefiltered ones are also bit-identical to the plain warp (the same
//! coordinates and kernel). Validity (nodata, alpha) is always decided on level 0's footprints,
//! as for the plain warp. Neighbouring tiles at different levels differ in sharpness: a visible
//! seam where the scale crosses a power of two (no blending between levels).

use super::options::{Interp, WarpOptions};
use crate::error::RasterError;
use crate::map::PixelMap;
use crate::raster::{Raster, Sample};
use aerorect_core::ImageSize;
use rayon::prelude::*;

/// Tile side, destination pixels.
const TILE: usize = 64;

/// Per tile (row-major), the pyramid level to read.
pub(crate) struct Plan {
    tiles_x: usize,
    levels: Vec<usize>,
}

impl Plan {
    pub(crate) fn max_level(&self) -> usize {
        self.levels.iter().copied().max().unwrap_or(0)
    }
}

/// The local scale at destination (col, row): the larger length of the Jacobian's columns,
/// by central differences over one pixel. `None` without a source there.
pub(crate) fn scale_at<M: PixelMap>(map: &M, col: f64, row: f64) -> Option<f64> {
    let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let (l, r) = (
        map.source_of(col - 0.5, row)?,
        map.source_of(col + 0.5, row)?,
    );
    let (u, b) = (
        map.source_of(col, row - 0.5)?,
        map.source_of(col, row + 0.5)?,
    );
    let rho = d(l, r).max(d(u, b));
    rho.is_finite().then_some(rho)
}

/// Whether `opts` prefilter: bilinear or bicubic with `prefilter` set.
pub(crate) fn applies(opts: &WarpOptions) -> bool {
    opts.prefilter && matches!(opts.interp, Interp::Bilinear | Interp::Bicubic)
}

/// The deepest level a warp of an image of `src` reads: levels while the smaller side keeps at
/// least 2 pixels.
pub(crate) fn deepest_level(src: ImageSize) -> usize {
    (src.width.min(src.height).max(1).ilog2() as usize).saturating_sub(1)
}

/// The level with rho / 2^k in [1, 2), at most `max_level` (a relative 1e-9 absorbs rounding in
/// exact power-of-two scales).
fn level_of(rho: f64, max_level: usize) -> usize {
    if rho < 2.0 {
        return 0;
    }
    ((rho * (1.0 + 1e-9)).log2().floor() as usize).min(max_level)
}

/// Each tile's level; `None` when every tile reads level 0 (the plain warp applies).
pub(crate) fn plan<M: PixelMap>(map: &M, dst: ImageSize, src: ImageSize) -> Option<Plan> {
    let max_level = deepest_level(src);
    let (tiles_x, tiles_y) = (dst.width.div_ceil(TILE), dst.height.div_ceil(TILE));
    let mut levels = Vec::with_capacity(tiles_x * tiles_y);
    for ty in 0..tiles_y {
        for tx in 0..tiles_x {
            let (c0, r0) = ((tx * TILE) as f64, (ty * TILE) as f64);
            let (c1, r1) = (
                ((tx * TILE + TILE).min(dst.width) - 1) as f64,
                ((ty * TILE + TILE).min(dst.height) - 1) as f64,
            );
            let rho = scale_at(map, 0.5 * (c0 + c1), 0.5 * (r0 + r1)).or_else(|| {
                [(c0, r0), (c1, r0), (c0, r1), (c1, r1)]
                    .iter()
                    .filter_map(|&(c, r)| scale_at(map, c, r))
                    .reduce(f64::min)
            });
            levels.push(rho.map_or(0, |s| level_of(s, max_level)));
        }
    }
    levels
        .iter()
        .any(|&l| l > 0)
        .then_some(Plan { tiles_x, levels })
}

/// The 2 x 2 box mean of `src`, ceil(W / 2) x ceil(H / 2): a last odd column or row is averaged
/// with itself.
pub(crate) fn reduce_half<T: Sample>(src: &Raster<T>) -> Result<Raster<T>, RasterError> {
    let (w, h) = (src.width(), src.height());
    let size = ImageSize::new(w.div_ceil(2), h.div_ceil(2));
    let mut out = Raster::new(size, src.bands())?;
    for (b, plane) in out.planes_mut().iter_mut().enumerate() {
        let p = src.plane(b);
        plane
            .par_chunks_mut(size.width)
            .enumerate()
            .for_each(|(r, dst)| {
                let (r0, r1) = (2 * r, (2 * r + 1).min(h - 1));
                half_row(&p[r0 * w..r0 * w + w], &p[r1 * w..r1 * w + w], dst);
            });
    }
    Ok(out)
}

/// One row of [`reduce_half`] from the two rows it halves (the same row twice for a last odd
/// row): `dst` holds ceil(W / 2) samples.
pub(crate) fn half_row<T: Sample>(top: &[T], bottom: &[T], dst: &mut [T]) {
    let w = top.len();
    let pairs = top.chunks_exact(2).zip(bottom.chunks_exact(2));
    for (d, (t, b)) in dst.iter_mut().zip(pairs) {
        let sum = t[0].to_f32() + t[1].to_f32() + b[0].to_f32() + b[1].to_f32();
        *d = T::from_f32(0.25 * sum);
    }
    if w % 2 == 1 {
        // The last odd column is averaged with itself.
        let sum = top[w - 1].to_f32() + bottom[w - 1].to_f32();
        dst[w / 2] = T::from_f32(0.5 * sum);
    }
}

/// One tile's map: destination (col, row) of the tile -> position in pyramid level `level`.
struct TileMap<'a, M> {
    inner: &'a M,
    col0: usize,
    row0: usize,
    level: usize,
    /// Level-`level` position of the reduced crop's first pixel (zero at level 0).
    origin: [f64; 2],
}

impl<M: PixelMap> TileMap<'_, M> {
    #[inline]
    fn to_level(&self, v: f64, axis: usize) -> f64 {
        if self.level == 0 {
            return v;
        }
        (v + 0.5) / (1u64 << self.level) as f64 - 0.5 - self.origin[axis]
    }
}

impl<M: PixelMap> PixelMap for TileMap<'_, M> {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        let p = self
            .inner
            .source_of(col + self.col0 as f64, row + self.row0 as f64)?;
        Some([self.to_level(p[0], 0), self.to_level(p[1], 1)])
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        self.inner
            .source_row(row + self.row0, col0 + self.col0, xs, ys);
        if self.level > 0 {
            for (axis, vs) in [xs, ys].into_iter().enumerate() {
                for v in vs.iter_mut() {
                    *v = self.to_level(*v, axis);
                }
            }
        }
    }
}

/// The levels a prefiltered warp reads: level 0 (absent where the caller kept only the
/// reduced ones: [`super::levels::ReducedLevels`]) and levels 1.. reduced from the part of level
/// 0 whose first pixel is `origin` (a multiple of 2^K, K the deepest level).
pub(crate) struct Levels<'a, T> {
    pub(crate) level0: Option<&'a Raster<T>>,
    pub(crate) size0: ImageSize,
    pub(crate) reduced: &'a [Raster<T>],
    pub(crate) origin: [usize; 2],
}

/// Warps tile by tile from the planned levels (tile rows in parallel): each tile through the
/// plain warp into its own buffer, copied into `dst`.
pub(crate) fn run<T: Sample, M: PixelMap>(
    src: &Raster<T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
    plan: &Plan,
    build: super::types::Build,
) -> Result<(), RasterError> {
    let crop = crop_of(map, plan, dst.size(), src.size());
    let cropped_src = crop.map(|c| cropped(src, c)).transpose()?;
    let mut reduced: Vec<Raster<T>> = Vec::new();
    for _ in 0..plan.max_level() {
        let next = reduce_half(reduced.last().or(cropped_src.as_ref()).unwrap_or(src))?;
        reduced.push(next);
    }
    let levels = Levels {
        level0: Some(src),
        size0: src.size(),
        reduced: &reduced,
        origin: crop.map_or([0, 0], |c| [c.x0, c.y0]),
    };
    run_levels(&levels, map, opts, dst, plan, build)
}

/// [`run`] from levels at hand. A level-0 tile without level 0 gets nodata (and alpha 0): the
/// caller has made sure none of its pixels has a source ([`tiles_of_level0_have_no_source`]).
pub(crate) fn run_levels<T: Sample, M: PixelMap>(
    levels: &Levels<'_, T>,
    map: &M,
    opts: &WarpOptions,
    dst: &mut Raster<T>,
    plan: &Plan,
    build: super::types::Build,
) -> Result<(), RasterError> {
    let origin = |k: usize| {
        levels
            .origin
            .map(|v| if k == 0 { 0.0 } else { (v >> k) as f64 })
    };
    let nodata = opts.nodata_as::<T>()?;
    let width = dst.width();
    let bands = dst.bands();
    let mut bands_of_rows: Vec<Vec<&mut [T]>> = (0..dst.height().div_ceil(TILE))
        .map(|_| Vec::new())
        .collect();
    for plane in dst.planes_mut() {
        for (task, chunk) in bands_of_rows.iter_mut().zip(plane.chunks_mut(TILE * width)) {
            task.push(chunk);
        }
    }
    bands_of_rows
        .into_par_iter()
        .enumerate()
        .try_for_each(|(ty, mut chunks)| {
            let rows = chunks[0].len() / width;
            for tx in 0..plan.tiles_x {
                let k = plan.levels[ty * plan.tiles_x + tx];
                let cols = TILE.min(width - tx * TILE);
                let tmap = TileMap {
                    inner: map,
                    col0: tx * TILE,
                    row0: ty * TILE,
                    level: k,
                    origin: origin(k),
                };
                let mut tile = Raster::new(ImageSize::new(cols, rows), bands)?;
                let source = match k {
                    0 => levels.level0,
                    _ => levels.reduced.get(k - 1),
                };
                // Only level 0 may be missing: `plan`'s levels are within the image's.
                debug_assert!(k == 0 || source.is_some(), "level {k} missing");
                match source {
                    Some(src) => {
                        super::dispatch::dispatch(src, &tmap, opts, nodata, &mut tile, build);
                    }
                    None => no_source(&mut tile, nodata, opts.alpha),
                }
                if k > 0 {
                    outside_level0(levels.size0, &tmap, nodata, opts.alpha, &mut tile);
                }
                for (chunk, plane) in chunks.iter_mut().zip(tile.planes()) {
                    for (r, line) in plane.chunks(cols).enumerate() {
                        let start = r * width + tx * TILE;
                        chunk[start..start + cols].copy_from_slice(line);
                    }
                }
            }
            Ok(())
        })
}

/// What the plain warp writes where no pixel has a source: nodata, and alpha 0.
fn no_source<T: Sample>(tile: &mut Raster<T>, nodata: T, alpha: bool) {
    let image_bands = tile.bands() - usize::from(alpha);
    for (b, plane) in tile.planes_mut().iter_mut().enumerate() {
        plane.fill(if b < image_bands {
            nodata
        } else {
            T::default()
        });
    }
}

/// Whether no pixel of the tiles planned at level 0 has a source position (those that read
/// level 0 but would find nothing there).
pub(crate) fn tiles_of_level0_have_no_source<M: PixelMap>(
    map: &M,
    plan: &Plan,
    dst: ImageSize,
) -> bool {
    let (mut xs, mut ys) = (vec![0.0; TILE], vec![0.0; TILE]);
    plan.levels
        .iter()
        .enumerate()
        .filter(|(_, k)| **k == 0)
        .all(|(t, _)| {
            let (col0, row0) = ((t % plan.tiles_x) * TILE, (t / plan.tiles_x) * TILE);
            let cols = TILE.min(dst.width - col0);
            (row0..(row0 + TILE).min(dst.height)).all(|row| {
                map.source_row(row, col0, &mut xs[..cols], &mut ys[..cols]);
                xs[..cols]
                    .iter()
                    .zip(&ys[..cols])
                    .all(|(x, y)| !(x.is_finite() && y.is_finite()))
            })
        })
}

/// Writes nodata (and alpha 0) where the tile's pixels fall outside level 0's footprints: level
/// k covers a little more than the image (its last pixel may stand for one source pixel).
fn outside_level0<T: Sample, M: PixelMap>(
    src: ImageSize,
    tmap: &TileMap<'_, M>,
    nodata: T,
    alpha: bool,
    tile: &mut Raster<T>,
) {
    let cols = tile.width();
    let (mut xs, mut ys) = (vec![0.0; cols], vec![0.0; cols]);
    let (w, h) = (src.width as f64, src.height as f64);
    let image_bands = tile.bands() - usize::from(alpha);
    for r in 0..tile.height() {
        tmap.inner
            .source_row(r + tmap.row0, tmap.col0, &mut xs, &mut ys);
        for (c, (&x, &y)) in xs.iter().zip(ys.iter()).enumerate() {
            if x >= -0.5 && x < w - 0.5 && y >= -0.5 && y < h - 0.5 {
                continue;
            }
            for b in 0..image_bands {
                tile.plane_mut(b)[r * cols + c] = nodata;
            }
            if alpha {
                tile.plane_mut(image_bands)[r * cols + c] = T::default();
            }
        }
    }
}

/// The part of the source that the prefiltered tiles read: `x0`, `y0` multiples of 2^K (K the
/// deepest level), so its reduced levels are the whole image's, pixel for pixel.
#[derive(Clone, Copy)]
struct Crop {
    x0: usize,
    y0: usize,
    size: ImageSize,
}

/// The bounding box of the source positions of every prefiltered tile's pixels, grown by 4 level-K
/// pixels (bicubic reads 2 either side) and aligned to 2^K; `None` when it is the whole image
/// (or no pixel has a source). A warp of a small window (a mosaic tile) then reduces only the part
/// of the frame it sees.
fn crop_of<M: PixelMap>(map: &M, plan: &Plan, dst: ImageSize, src: ImageSize) -> Option<Crop> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let (mut xs, mut ys) = (vec![0.0; TILE], vec![0.0; TILE]);
    for (t, _) in plan.levels.iter().enumerate().filter(|(_, k)| **k > 0) {
        let (col0, row0) = ((t % plan.tiles_x) * TILE, (t / plan.tiles_x) * TILE);
        let cols = TILE.min(dst.width - col0);
        for row in row0..(row0 + TILE).min(dst.height) {
            map.source_row(row, col0, &mut xs[..cols], &mut ys[..cols]);
            for (&x, &y) in xs[..cols].iter().zip(&ys[..cols]) {
                if x.is_finite() && y.is_finite() {
                    (lo, hi) = ([lo[0].min(x), lo[1].min(y)], [hi[0].max(x), hi[1].max(y)]);
                }
            }
        }
    }
    if !lo[0].is_finite() {
        return None;
    }
    let a = 1usize << plan.max_level();
    let margin = 4.0 * a as f64;
    let start = |v: f64| ((v - margin).max(0.0) as usize / a) * a;
    let end = |v: f64, n: usize| ((v + margin).max(0.0).min(n as f64) as usize).div_ceil(a) * a;
    let (x0, y0) = (
        start(lo[0]).min(src.width - 1),
        start(lo[1]).min(src.height - 1),
    );
    let (x1, y1) = (
        end(hi[0], src.width).clamp(x0 + 1, src.width),
        end(hi[1], src.height).clamp(y0 + 1, src.height),
    );
    let size = ImageSize::new(x1 - x0, y1 - y0);
    (size != src).then_some(Crop { x0, y0, size })
}

/// The crop's pixels, every band.
fn cropped<T: Sample>(src: &Raster<T>, c: Crop) -> Result<Raster<T>, RasterError> {
    let w = src.width();
    let planes = src
        .planes()
        .iter()
        .map(|p| {
            (c.y0..c.y0 + c.size.height)
                .flat_map(|r| &p[r * w + c.x0..r * w + c.x0 + c.size.width])
                .copied()
                .collect()
        })
        .collect();
    Raster::from_planes(c.size, planes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 5 x 3 -> 3 x 2: 2 x 2 means, the last odd column and row averaged with themselves.
    #[test]
    fn reduce_half_is_the_block_mean_with_the_edge_repeated() {
        let p: Vec<f32> = (0..15).map(|i| (i * i) as f32).collect();
        let src = Raster::from_planes(ImageSize::new(5, 3), vec![p.clone()]).expect("raster");
        let half = reduce_half(&src).expect("reduced");
        assert_eq!(half.size(), ImageSize::new(3, 2));
        let at = |c: usize, r: usize| p[r.min(2) * 5 + c.min(4)];
        for r in 0..2 {
            for c in 0..3 {
                let want = 0.25
                    * (at(2 * c, 2 * r)
                        + at(2 * c + 1, 2 * r)
                        + at(2 * c, 2 * r + 1)
                        + at(2 * c + 1, 2 * r + 1));
                assert_eq!(half.plane(0)[r * 3 + c], want, "({c}, {r})");
            }
        }
    }

    #[test]
    fn the_level_leaves_a_scale_in_one_to_two() {
        for (rho, level) in [
            (1.0, 0),
            (1.99, 0),
            (2.0, 1),
            (3.9, 1),
            (4.0, 2),
            (15.9, 3),
            (1e6, 5),
        ] {
            assert_eq!(level_of(rho, 5), level, "rho {rho}");
        }
        // Exact powers of two computed with rounding error still land on their level.
        assert_eq!(level_of(4.0 * (1.0 - 1e-12), 5), 2);
    }
}
