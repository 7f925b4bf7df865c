//! Compositing tiles: weights from the labels, frames rendered only over the tile, decoded
//! frames shared between the threads, and the tiled GeoTIFF or COG written from the tiles.

use super::assemble::{accumulate, assemble, paste};
use super::cache::FrameCache;
use super::labels::{NO_FRAME, best_of};
use super::weights::weights;
use super::{Blend, MosaicFrame, MosaicOptions, MosaicPlan, Window};
use crate::Error;
use crate::drone::{DroneOptions, plan_from_metadata, plan_from_pose, pose_for};
use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::GeoReference;
use aerorect_raster::AnyRaster;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// How much of the mosaic one frame gave.
#[derive(Debug, Clone, Serialize)]
pub struct FrameUse {
    pub path: String,
    /// Cells whose best frame it is.
    pub cells: usize,
    /// Times it was loaded: decoded, or handed over by an adjusted flight (more than once
    /// when the cache had let it go).
    pub loads: usize,
}

/// What building a mosaic did.
#[derive(Debug, Clone, Serialize)]
pub struct MosaicReport {
    pub output: String,
    pub size: [usize; 2],
    pub gsd_m: f64,
    pub top_left: [f64; 2],
    pub tiles: usize,
    pub blend: Blend,
    pub frames: Vec<FrameUse>,
    pub covered_cells: usize,
    pub seconds: f64,
}

/// Tiles of a plan, composited by any number of threads at once, sharing at most
/// `cache_frames` decoded frames (plus the one each thread is rendering).
/// `load` runs while its frame's slot is held, so it must not wait on rayon work (a rayon
/// thread waiting may be handed a tile that wants the same frame).
pub struct MosaicRun<'a, L> {
    plan: &'a MosaicPlan,
    cache: FrameCache<'a, L>,
    /// Per frame: cells taken.
    cells: Vec<AtomicUsize>,
}

impl<'a, L, R> MosaicRun<'a, L>
where
    L: Fn(&MosaicFrame) -> Result<R, Error> + Sync,
    R: Into<std::sync::Arc<AnyRaster>>,
{
    /// `load` decodes a frame (its image must have its camera's size).
    pub fn new(plan: &'a MosaicPlan, load: L) -> Self {
        Self {
            plan,
            cache: FrameCache::new(
                &plan.frames,
                load,
                (plan.opts.cache_frames, plan.opts.cache_bytes),
            ),
            cells: plan.frames.iter().map(|_| AtomicUsize::new(0)).collect(),
        }
    }

    /// Per frame: the cells it gave the tiles made so far (summed over the tiles).
    pub fn cells(&self) -> Vec<usize> {
        self.cells
            .iter()
            .map(|n| n.load(Ordering::Relaxed))
            .collect()
    }

    /// Per frame: its loads so far (more than one when the cache had let it go).
    pub fn loads(&self) -> Vec<usize> {
        self.cache.loads()
    }

    /// The mosaic's pixels over `tile`.
    pub fn tile(&self, tile: Window) -> Result<AnyRaster, Error> {
        let plan = self.plan;
        let format = self.cache.format()?;
        let margin = plan.opts.margin();
        let win = tile.grown(margin, plan.grid.size);
        let (cands, scores) = plan.scores_of(&plan.meeting(win), win);
        let (n, tw) = (tile.size.pixels(), tile.size.width);
        if cands.is_empty() {
            let acc = vec![Vec::new(); format.bands];
            return assemble(format, tile.size, acc, &vec![0.0; n], &plan.opts);
        }
        let labels = best_of(&cands, &scores, win.size);
        self.count_cells(tile, win, &labels);
        // A cell's value is its frames' weighted mean, and where one frame is the best of
        // every covered cell of the window it alone weighs in the tile, with a positive weight
        // on each of its cells. Integer samples then come out the same for any positive
        // weight (w v / w is v within 2 ulp, far inside the rounding), so its weights are
        // left 1 and 0, without the feather's distances (f32 samples would keep the ulps).
        let blend = match format.sample.is_integer() && one_frame(&labels) {
            true => Blend::None,
            false => plan.opts.blend,
        };
        let mut acc = vec![vec![0f32; n]; format.bands];
        let mut wsum = vec![0f32; n];
        for (j, &k) in cands.iter().enumerate() {
            // The frame is rendered over the box of the cells it weighs only, not the whole
            // tile: most of a tile lies outside any one frame. A pixel's value depends on the
            // window only where the warp evaluates a homography relative to the window's
            // origin, in its last bit (as it did relative to the tile's): on the snowpeak
            // flight 4 of 1.3 billion samples moved by 1 DN.
            let Some(w) = weights(
                (blend, plan.opts.feather_px),
                k,
                (win, tile),
                &labels,
                &scores[j],
            ) else {
                continue;
            };
            let Some(b) = w.positive_box() else {
                continue;
            };
            let img = self.cache.frame(k)?;
            let f = &plan.frames[k];
            let off = plan.offsets[k];
            let r = f.plan.render_window(
                &img,
                (tile.col0 + b.c0) as i64 - off[0],
                (tile.row0 + b.r0) as i64 - off[1],
                ImageSize::new(b.width(), b.height()),
            )?;
            let sums = (acc.as_mut_slice(), wsum.as_mut_slice());
            accumulate(sums, tw, (b, &w), &r, (format.bands, f.plan.warp.alpha));
        }
        assemble(format, tile.size, acc, &wsum, &plan.opts)
    }

    /// Adds the cells of `tile` each frame is best at (`labels` over `win`) to the counts.
    fn count_cells(&self, tile: Window, win: Window, labels: &[usize]) {
        let mut cells = vec![0usize; self.cells.len()];
        for r in 0..tile.size.height {
            let j = (r + tile.row0 - win.row0) * win.size.width + tile.col0 - win.col0;
            for k in labels[j..j + tile.size.width]
                .iter()
                .filter(|&&k| k != NO_FRAME)
            {
                cells[*k] += 1;
            }
        }
        for (total, n) in self.cells.iter().zip(cells) {
            if n > 0 {
                total.fetch_add(n, Ordering::Relaxed);
            }
        }
    }
}

/// Whether the labels name one frame at most.
fn one_frame(labels: &[usize]) -> bool {
    let first = labels.iter().find(|&&l| l != NO_FRAME);
    first.is_none_or(|&k| labels.iter().all(|&l| l == k || l == NO_FRAME))
}

/// The plan of a mosaic written to `out` and its georeference, after refusing an `out` that
/// names a frame.
fn prepare(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
) -> Result<(MosaicPlan, GeoReference), Error> {
    let gsd = frames.first().map_or(1.0, |f| f.plan.grid.gsd);
    let plan = MosaicPlan::new(frames, gsd, opts.clone())?;
    for f in &plan.frames {
        if aerorect_io::same_file(&f.path, out) {
            return Err(Error::Invalid(format!(
                "the mosaic {} would overwrite its frame {}",
                out.display(),
                f.path.display()
            )));
        }
    }
    let geo = GeoReference {
        crs,
        pixel_size: [gsd, gsd],
        top_left: plan.grid.top_left,
        rotation: [0.0, 0.0],
        nodata: (!opts.alpha).then_some(opts.nodata),
    };
    Ok((plan, geo))
}

fn report<L, R>(
    plan: &MosaicPlan,
    run: &MosaicRun<'_, L>,
    out: &Path,
    t0: std::time::Instant,
) -> MosaicReport
where
    L: Fn(&MosaicFrame) -> Result<R, Error> + Sync,
    R: Into<std::sync::Arc<AnyRaster>>,
{
    let (cells, loads) = (run.cells(), run.loads());
    let frames = plan
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| FrameUse {
            path: f.path.display().to_string(),
            cells: cells[k],
            loads: loads[k],
        })
        .collect();
    MosaicReport {
        output: out.display().to_string(),
        size: [plan.grid.size.width, plan.grid.size.height],
        gsd_m: plan.grid.gsd,
        top_left: plan.grid.top_left,
        tiles: plan.tile_windows().count(),
        blend: plan.opts.blend,
        covered_cells: cells.iter().sum(),
        frames,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn read_frame(f: &MosaicFrame) -> Result<AnyRaster, Error> {
    Ok(aerorect_io::read_image(&f.path)?)
}

/// Builds the mosaic of `frames` (all planned at one GSD on the global grid of `crs`) and
/// writes it to `out` as a tiled GeoTIFF, its tiles composited and compressed on every thread
/// of the rayon pool; atomically (nothing is left when a frame fails). The file is the same,
/// byte for byte, on any number of threads. Frames are decoded with `aerorect_io::read_image`.
pub fn mosaic(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
) -> Result<MosaicReport, Error> {
    mosaic_with(frames, crs, out, opts, read_frame)
}

/// [`mosaic`] with the frames' images from `load` (an adjusted flight hands over the photos
/// its rounds decoded).
pub fn mosaic_with<L, R>(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
    load: L,
) -> Result<MosaicReport, Error>
where
    L: Fn(&MosaicFrame) -> Result<R, Error> + Sync,
    R: Into<std::sync::Arc<AnyRaster>>,
{
    let t0 = std::time::Instant::now();
    let (plan, geo) = prepare(frames, crs, out, opts)?;
    let run = MosaicRun::new(&plan, load);
    aerorect_io::write_tiled_tiff_parallel::<Error>(
        out,
        plan.grid.size,
        opts.tile_px,
        Some(&geo),
        |c, r, s| {
            run.tile(Window {
                col0: c,
                row0: r,
                size: s,
            })
        },
    )?;
    Ok(report(&plan, &run, out, t0))
}

/// The largest mosaic (pixels) [`mosaic_cog`] composites in memory: the COG writer takes a
/// whole raster.
pub const COG_MAX_PX: usize = 200_000_000;

/// [`mosaic`], composited (in batches of tiles, each batch on every thread) into one raster
/// and written as a cloud-optimised GeoTIFF (an alpha band becomes its internal mask); a
/// mosaic over [`COG_MAX_PX`] pixels is refused before any frame is read.
pub fn mosaic_cog(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
    cog: &aerorect_io::CogOptions,
) -> Result<MosaicReport, Error> {
    mosaic_cog_with(frames, crs, out, (opts, cog), read_frame)
}

/// [`mosaic_cog`] with the frames' images from `load`.
pub fn mosaic_cog_with<L, R>(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    (opts, cog): (&MosaicOptions, &aerorect_io::CogOptions),
    load: L,
) -> Result<MosaicReport, Error>
where
    L: Fn(&MosaicFrame) -> Result<R, Error> + Sync,
    R: Into<std::sync::Arc<AnyRaster>>,
{
    let t0 = std::time::Instant::now();
    let (plan, geo) = prepare(frames, crs, out, opts)?;
    let size = plan.grid.size;
    if size.pixels() > COG_MAX_PX {
        return Err(Error::advice(format!(
            "the mosaic is {} x {} px ({:.0} Mpx): a cloud-optimised GeoTIFF is composited in memory, up to {} Mpx; write the tiled GeoTIFF (without `cog`) or use a coarser GSD",
            size.width,
            size.height,
            size.pixels() as f64 / 1e6,
            COG_MAX_PX / 1_000_000
        )));
    }
    let run = MosaicRun::new(&plan, load);
    let mut whole: Option<AnyRaster> = None;
    let windows: Vec<Window> = plan.tile_windows().collect();
    for batch in windows.chunks(aerorect_io::tiles_per_batch()) {
        let tiles: Vec<Result<AnyRaster, Error>> = batch.par_iter().map(|&w| run.tile(w)).collect();
        for (&w, t) in batch.iter().zip(tiles) {
            paste(&mut whole, size, &t?, w)?;
        }
    }
    let whole = whole.ok_or_else(|| Error::Invalid("the mosaic is empty".into()))?;
    let mut cog = cog.clone();
    if opts.alpha {
        cog.mask = aerorect_io::CogMask::AlphaBand;
    }
    aerorect_io::write_cog(out, &whole, &geo, &cog)?;
    Ok(report(&plan, &run, out, t0))
}

/// Plans photos for a mosaic from their metadata (or `opts.poses`): one GSD for all (`opts`'s,
/// else the finest frame's own, to the millimetre) and one CRS (`opts.crs`, else the first
/// frame's UTM zone, which every frame must share). A photo's size is read from its header:
/// damaged pixels are found when its tiles are made (and nothing is written).
pub fn frames_from_photos(
    paths: &[PathBuf],
    opts: &DroneOptions,
) -> Result<(Vec<MosaicFrame>, Crs), Error> {
    let mut inputs = Vec::with_capacity(paths.len());
    for p in paths {
        let meta = aerorect_io::read_photo_metadata(p)?;
        let size = aerorect_io::read_image_size(p)?;
        inputs.push((p.clone(), meta, size));
    }
    let plan_all = |o: &DroneOptions| -> Result<Vec<_>, Error> {
        inputs
            .iter()
            .map(|(p, meta, size)| {
                let file = p.display().to_string();
                match o.poses.as_deref().map(|t| pose_for(t, p)) {
                    Some(Some(pose)) => plan_from_pose(pose, meta, *size, o, &file),
                    Some(None) => Err(Error::Invalid(format!("{file}: not in the pose table"))),
                    None => plan_from_metadata(meta, *size, o, &file),
                }
            })
            .collect()
    };
    let mut o = opts.clone();
    let mut planned = plan_all(&o)?;
    if o.gsd_m.is_none() {
        let finest = planned
            .iter()
            .map(|p| p.1.gsd_m)
            .fold(f64::INFINITY, f64::min);
        o.gsd_m = Some(((finest * 1000.0).round() / 1000.0).max(0.001));
        planned = plan_all(&o)?;
    }
    let crs = planned[0].1.geo.crs.clone();
    let mut frames = Vec::with_capacity(planned.len());
    for ((plan, info), (path, _, _)) in planned.into_iter().zip(&inputs) {
        if info.geo.crs != crs {
            return Err(Error::advice(format!(
                "{}: in {:?}, the first frame in {crs:?}: give one output CRS (`crs`)",
                path.display(),
                info.geo.crs
            )));
        }
        frames.push(MosaicFrame {
            path: path.clone(),
            plan,
            nadir_xy: [info.pose.centre[0], info.pose.centre[1]],
            height_m: info.height_m,
        });
    }
    Ok((frames, crs))
}
