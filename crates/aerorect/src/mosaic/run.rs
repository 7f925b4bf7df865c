//! Compositing tiles: weights from the labels, frames rendered only over the tile, a small
//! cache of decoded frames, and the tiled GeoTIFF writer.

use super::distance::distance_to;
use super::score::best_of;
use super::{Blend, MosaicFrame, MosaicOptions, MosaicPlan, Window};
use crate::Error;
use crate::drone::{DroneOptions, plan_from_metadata, plan_from_pose, pose_for};
use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::GeoReference;
use aerorect_raster::{AnyRaster, Raster, Sample};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How much of the mosaic one frame gave.
#[derive(Debug, Clone, Serialize)]
pub struct FrameUse {
    pub path: String,
    /// Cells whose best frame it is.
    pub cells: usize,
    /// Times it was decoded (more than once when the cache had let it go).
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

/// Sample type and bands of the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Format {
    sample: &'static str,
    bands: usize,
}

/// Tiles of a plan, one at a time, with at most `cache_frames` decoded frames held.
pub struct MosaicRun<'a, L> {
    plan: &'a MosaicPlan,
    load: L,
    cache: Vec<(usize, Arc<AnyRaster>)>,
    format: Option<Format>,
    /// Per frame: cells taken and decodes.
    pub cells: Vec<usize>,
    pub loads: Vec<usize>,
}

impl<'a, L: FnMut(&MosaicFrame) -> Result<AnyRaster, Error>> MosaicRun<'a, L> {
    /// `load` decodes a frame (its image must have its camera's size).
    pub fn new(plan: &'a MosaicPlan, load: L) -> Self {
        let n = plan.frames.len();
        Self {
            plan,
            load,
            cache: Vec::new(),
            format: None,
            cells: vec![0; n],
            loads: vec![0; n],
        }
    }

    fn frame(&mut self, k: usize) -> Result<Arc<AnyRaster>, Error> {
        if let Some(i) = self.cache.iter().position(|e| e.0 == k) {
            let e = self.cache.remove(i);
            self.cache.insert(0, e.clone());
            return Ok(e.1);
        }
        let f = &self.plan.frames[k];
        let img = (self.load)(f)?;
        self.loads[k] += 1;
        let name = f.path.display();
        if img.size() != f.plan.camera.size {
            return Err(Error::Invalid(format!(
                "{name}: the image is {} x {}, its plan is for {} x {}",
                img.size().width,
                img.size().height,
                f.plan.camera.size.width,
                f.plan.camera.size.height
            )));
        }
        let format = Format {
            sample: img.sample_name(),
            bands: img.bands(),
        };
        match self.format {
            None => self.format = Some(format),
            Some(want) if want != format => {
                return Err(Error::Invalid(format!(
                    "{name}: {} bands of {}, the mosaic's other frames have {} of {}",
                    format.bands, format.sample, want.bands, want.sample
                )));
            }
            Some(_) => {}
        }
        let img = Arc::new(img);
        self.cache.truncate(self.plan.opts.cache_frames - 1);
        self.cache.insert(0, (k, Arc::clone(&img)));
        Ok(img)
    }

    /// The mosaic's pixels over `tile`.
    pub fn tile(&mut self, tile: Window) -> Result<AnyRaster, Error> {
        let plan = self.plan;
        if self.format.is_none() {
            self.frame(0)?;
        }
        let margin = plan.opts.margin();
        let win = tile.grown(margin, plan.grid.size);
        let cands = plan.meeting(win);
        let scores: Vec<Vec<f64>> = cands.iter().map(|&k| plan.scores(k, win)).collect();
        let labels = best_of(&cands, &scores, win.size.pixels());
        let n = tile.size.pixels();
        for i in 0..n {
            let (c, r) = (i % tile.size.width, i / tile.size.width);
            let j = (r + tile.row0 - win.row0) * win.size.width + c + tile.col0 - win.col0;
            if let Some(k) = labels[j] {
                self.cells[k] += 1;
            }
        }
        let format = self.format.unwrap_or(Format {
            sample: "u8",
            bands: 1,
        });
        let mut acc = vec![vec![0f32; n]; format.bands];
        let mut wsum = vec![0f32; n];
        for (j, &k) in cands.iter().enumerate() {
            let w = weights(&plan.opts, k, win, tile, &labels, &scores[j]);
            if w.iter().all(|&v| v <= 0.0) {
                continue;
            }
            let img = self.frame(k)?;
            let f = &plan.frames[k];
            let off = plan.offsets[k];
            let r = f.plan.render_window(
                &img,
                tile.col0 as i64 - off[0],
                tile.row0 as i64 - off[1],
                tile.size,
            )?;
            // Cells with a weight are inside the frame; its alpha band, when planned with one,
            // says so too.
            let valid = f.plan.warp.alpha.then(|| r.plane_f32(format.bands));
            let bands: Vec<Vec<f32>> = (0..format.bands).map(|b| r.plane_f32(b)).collect();
            for i in 0..n {
                let wi = w[i];
                if wi <= 0.0
                    || valid.as_ref().is_some_and(|a| a[i] <= 0.0)
                    || bands.iter().any(|b| !b[i].is_finite())
                {
                    continue;
                }
                for (a, b) in acc.iter_mut().zip(&bands) {
                    a[i] += wi * b[i];
                }
                wsum[i] += wi;
            }
        }
        assemble(format, tile.size, acc, &wsum, &plan.opts)
    }
}

/// Frame k's weight over the cells of `tile`.
fn weights(
    opts: &MosaicOptions,
    k: usize,
    win: Window,
    tile: Window,
    labels: &[Option<usize>],
    scores: &[f64],
) -> Vec<f32> {
    let (ww, wh) = (win.size.width, win.size.height);
    let at = |c: usize, r: usize| (r + tile.row0 - win.row0) * ww + c + tile.col0 - win.col0;
    let cells = (0..tile.size.height).flat_map(|r| (0..tile.size.width).map(move |c| (c, r)));
    let mine: Vec<bool> = labels.iter().map(|l| *l == Some(k)).collect();
    match opts.blend {
        Blend::None => cells
            .map(|(c, r)| f32::from(u8::from(mine[at(c, r)])))
            .collect(),
        Blend::Feather => {
            if !mine.iter().any(|&m| m) {
                return vec![0.0; tile.size.pixels()];
            }
            let n = opts.feather_px as f32;
            let not_mine: Vec<bool> = mine.iter().map(|m| !m).collect();
            let uncovered: Vec<bool> = scores.iter().map(|s| !s.is_finite()).collect();
            let d_in = distance_to(&not_mine, ww, wh);
            let d_out = distance_to(&mine, ww, wh);
            let d_cov = distance_to(&uncovered, ww, wh);
            cells
                .map(|(c, r)| {
                    let i = at(c, r);
                    if uncovered[i] {
                        return 0.0;
                    }
                    let s = if mine[i] {
                        d_in[i] - 0.5
                    } else {
                        0.5 - d_out[i]
                    };
                    (0.5 + s / n).clamp(0.0, 1.0) * (d_cov[i] / n).min(1.0)
                })
                .collect()
        }
    }
}

/// The tile from its weighted sums: the frames' sample type, an alpha band when asked.
fn assemble(
    format: Format,
    size: ImageSize,
    acc: Vec<Vec<f32>>,
    wsum: &[f32],
    opts: &MosaicOptions,
) -> Result<AnyRaster, Error> {
    fn build<T: Sample>(
        size: ImageSize,
        acc: Vec<Vec<f32>>,
        wsum: &[f32],
        opts: &MosaicOptions,
    ) -> Result<Raster<T>, Error> {
        let nodata = T::from_f64_exact(opts.nodata).ok_or_else(|| {
            Error::Invalid(format!(
                "nodata {} does not fit the frames' {} samples",
                opts.nodata,
                T::NAME
            ))
        })?;
        let mut planes: Vec<Vec<T>> = acc
            .into_iter()
            .map(|a| {
                a.iter()
                    .zip(wsum)
                    .map(|(&v, &w)| if w > 0.0 { T::from_f32(v / w) } else { nodata })
                    .collect()
            })
            .collect();
        if opts.alpha {
            let a = wsum
                .iter()
                .map(|&w| if w > 0.0 { T::OPAQUE } else { T::default() });
            planes.push(a.collect());
        }
        Ok(Raster::from_planes(size, planes)?)
    }
    Ok(match format.sample {
        "u8" => AnyRaster::U8(build(size, acc, wsum, opts)?),
        "u16" => AnyRaster::U16(build(size, acc, wsum, opts)?),
        _ => AnyRaster::F32(build(size, acc, wsum, opts)?),
    })
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

fn report<L>(
    plan: &MosaicPlan,
    run: &MosaicRun<'_, L>,
    out: &Path,
    tiles: usize,
    t0: std::time::Instant,
) -> MosaicReport {
    let frames = plan
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| FrameUse {
            path: f.path.display().to_string(),
            cells: run.cells[k],
            loads: run.loads[k],
        })
        .collect();
    MosaicReport {
        output: out.display().to_string(),
        size: [plan.grid.size.width, plan.grid.size.height],
        gsd_m: plan.grid.gsd,
        top_left: plan.grid.top_left,
        tiles,
        blend: plan.opts.blend,
        covered_cells: run.cells.iter().sum(),
        frames,
        seconds: t0.elapsed().as_secs_f64(),
    }
}

fn read_frame(f: &MosaicFrame) -> Result<AnyRaster, Error> {
    Ok(aerorect_io::read_image(&f.path)?)
}

/// Builds the mosaic of `frames` (all planned at one GSD on the global grid of `crs`) and
/// writes it to `out` as a tiled GeoTIFF, tile by tile; atomically (nothing is left when a
/// frame fails). Frames are decoded with `aerorect_io::read_image`.
pub fn mosaic(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
) -> Result<MosaicReport, Error> {
    let t0 = std::time::Instant::now();
    let (plan, geo) = prepare(frames, crs, out, opts)?;
    let mut run = MosaicRun::new(&plan, read_frame);
    let mut tiles = 0;
    aerorect_io::write_tiled_tiff::<Error>(
        out,
        plan.grid.size,
        opts.tile_px,
        Some(&geo),
        |c, r, s| {
            tiles += 1;
            run.tile(Window {
                col0: c,
                row0: r,
                size: s,
            })
        },
    )?;
    Ok(report(&plan, &run, out, tiles, t0))
}

/// The largest mosaic (pixels) [`mosaic_cog`] composites in memory: the COG writer takes a
/// whole raster.
pub const COG_MAX_PX: usize = 200_000_000;

/// [`mosaic`], composited tile by tile into one raster and written as a cloud-optimised
/// GeoTIFF (an alpha band becomes its internal mask); a mosaic over [`COG_MAX_PX`] pixels is
/// refused before any frame is read.
pub fn mosaic_cog(
    frames: Vec<MosaicFrame>,
    crs: Crs,
    out: &Path,
    opts: &MosaicOptions,
    cog: &aerorect_io::CogOptions,
) -> Result<MosaicReport, Error> {
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
    let mut run = MosaicRun::new(&plan, read_frame);
    let mut whole: Option<AnyRaster> = None;
    let mut tiles = 0;
    let windows: Vec<Window> = plan.tile_windows().collect();
    for w in windows {
        let t = run.tile(w)?;
        tiles += 1;
        paste(&mut whole, size, &t, w)?;
    }
    let whole = whole.ok_or_else(|| Error::Invalid("the mosaic is empty".into()))?;
    let mut cog = cog.clone();
    if opts.alpha {
        cog.mask = aerorect_io::CogMask::AlphaBand;
    }
    aerorect_io::write_cog(out, &whole, &geo, &cog)?;
    Ok(report(&plan, &run, out, tiles, t0))
}

/// Copies `tile` into the mosaic `whole` (made, of the tile's type and bands, at the first).
fn paste(
    whole: &mut Option<AnyRaster>,
    size: ImageSize,
    tile: &AnyRaster,
    w: Window,
) -> Result<(), Error> {
    fn copy<T: Sample>(dst: &mut Raster<T>, src: &Raster<T>, w: Window) {
        let (width, tw) = (dst.size().width, w.size.width);
        for b in 0..src.bands() {
            let d = dst.plane_mut(b);
            for (r, row) in src.plane(b).chunks(tw).enumerate() {
                let at = (w.row0 + r) * width + w.col0;
                d[at..at + tw].copy_from_slice(row);
            }
        }
    }
    if whole.is_none() {
        let bands = tile.bands();
        *whole = Some(match tile {
            AnyRaster::U8(_) => AnyRaster::U8(Raster::new(size, bands)?),
            AnyRaster::U16(_) => AnyRaster::U16(Raster::new(size, bands)?),
            AnyRaster::F32(_) => AnyRaster::F32(Raster::new(size, bands)?),
        });
    }
    match (whole.as_mut(), tile) {
        (Some(AnyRaster::U8(d)), AnyRaster::U8(s)) if d.bands() == s.bands() => copy(d, s, w),
        (Some(AnyRaster::U16(d)), AnyRaster::U16(s)) if d.bands() == s.bands() => copy(d, s, w),
        (Some(AnyRaster::F32(d)), AnyRaster::F32(s)) if d.bands() == s.bands() => copy(d, s, w),
        _ => {
            return Err(Error::Invalid(
                "mosaic tiles of different sample types or bands".into(),
            ));
        }
    }
    Ok(())
}

/// Plans photos for a mosaic from their metadata (or `opts.poses`): one GSD for all (`opts`'s,
/// else the finest frame's own, to the millimetre) and one CRS (`opts.crs`, else the first
/// frame's UTM zone, which every frame must share). Each photo is decoded once for its size.
pub fn frames_from_photos(
    paths: &[PathBuf],
    opts: &DroneOptions,
) -> Result<(Vec<MosaicFrame>, Crs), Error> {
    let mut inputs = Vec::with_capacity(paths.len());
    for p in paths {
        let meta = aerorect_io::read_photo_metadata(p)?;
        let size = aerorect_io::read_image(p)?.size();
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
