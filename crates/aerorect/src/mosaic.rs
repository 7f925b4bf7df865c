//! One mosaic of many frames on one grid, built tile by tile so a flight of any length needs
//! only a tile, its margin and a few decoded frames in memory.
//!
//! Every frame at one GSD is planned on the global grid (pixel corners at multiples of the
//! GSD), so frames and mosaic align by whole pixels. Each ground cell takes the frame with the
//! lowest score there:
//!
//! `score = g_frame / cos(theta)`, with `g_frame` = GSD / sqrt(A) the frame's own ground
//! resolution at the cell (A: the area, in frame pixels, of the cell's four corners mapped into
//! the frame) and `tan(theta)` = the cell's horizontal distance from the camera's nadir point
//! over the camera's height above the ground (the lean of anything standing on the ground grows
//! with it). For a nadir frame over level ground this is the slant range over the focal length.
//! The score is evaluated exactly every 8 cells of each frame's grid and blended bilinearly
//! between, except along the frame's edges and hidden ground (`score`'s module doc).
//!
//! Labels change along seamlines. `Blend::None` takes the label's pixel; `Blend::Feather` gives
//! frame k the weight `clamp(0.5 + s_k / N, 0, 1) * min(1, c_k / N)`, where s_k is the signed
//! distance (px, positive inside) to the edge of k's label region and c_k the distance to the
//! nearest cell k does not cover: a linear cross-fade over N px centred on a seam between two
//! frames, and a fade-out inside a frame where the seam is that frame's own edge. The distances
//! are exact Euclidean transforms over the tile grown by N + 1 px, which gives the same weights
//! as over the whole mosaic (both terms saturate within N px).

mod distance;
mod labels;
mod score;

use crate::Error;
use crate::georef::OrthoPlan;
use aerorect_core::ImageSize;
use aerorect_geo::OrthoGrid;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One frame of a mosaic: its planned ortho on the shared grid and where the camera was.
#[derive(Debug, Clone)]
pub struct MosaicFrame {
    pub path: PathBuf,
    pub plan: OrthoPlan,
    /// The camera's position on the ground (world x, y).
    pub nadir_xy: [f64; 2],
    /// The camera's height above the ground (m).
    pub height_m: f64,
}

/// How frames meet at seamlines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Blend {
    /// Linear cross-fade over `feather_px` across each seam.
    Feather,
    /// Each cell from its best frame only.
    None,
}

impl std::str::FromStr for Blend {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "feather" => Ok(Blend::Feather),
            "none" => Ok(Blend::None),
            _ => Err(format!("unknown blend '{s}': expected feather or none")),
        }
    }
}

/// How to build a mosaic.
#[derive(Debug, Clone, PartialEq)]
pub struct MosaicOptions {
    pub blend: Blend,
    /// Width of the cross-fade across a seam (px).
    pub feather_px: usize,
    /// Output tile side (px, a multiple of 16).
    pub tile_px: usize,
    /// Decoded frames kept between tiles, shared by the threads compositing them: at least
    /// this many, more where `cache_bytes` holds more. At most the cache plus one per thread
    /// are held at once (a 4608 x 3456 RGB u8 photo is 48 MB); 8 held every frame a row of
    /// snowpeak's tiles needs (each of its 11 photos decoded once; 4 decoded them 39-40
    /// times).
    pub cache_frames: usize,
    /// The bytes of decoded frames the cache may hold beyond `cache_frames` (counted by the
    /// largest frame): [`crate::memory::cache_budget_bytes`] by default. A flight's tile rows
    /// cross every strip: with 8 frames kept, each of a simulated 144-frame flight's frames
    /// was decoded 3.3 times (up to 6), once per row of tiles it spans.
    pub cache_bytes: usize,
    /// Append an alpha band (opaque where a frame covers the cell).
    pub alpha: bool,
    /// The value of cells no frame covers.
    pub nodata: f64,
    /// The largest frame ortho (px, `--max-output-px`): the mosaic may be at most this many
    /// pixels per frame (its frames' orthos laid side by side), checked before any frame is
    /// rendered.
    pub max_output_px: u64,
}

impl Default for MosaicOptions {
    fn default() -> Self {
        Self {
            blend: Blend::Feather,
            feather_px: 16,
            tile_px: 512,
            cache_frames: 8,
            cache_bytes: crate::memory::cache_budget_bytes(),
            alpha: true,
            nodata: 0.0,
            max_output_px: aerorect_core::rectify::DEFAULT_MAX_OUTPUT_PX,
        }
    }
}

impl MosaicOptions {
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |m: String| Err(Error::Invalid(m));
        if self.tile_px == 0 || !self.tile_px.is_multiple_of(16) {
            return bad(format!(
                "mosaic tile {} px: must be a positive multiple of 16",
                self.tile_px
            ));
        }
        if self.blend == Blend::Feather && self.feather_px == 0 {
            return Err(Error::advice(
                "`blend` feather needs a feather width (`feather_px`) of at least 1 px",
            ));
        }
        if self.cache_frames == 0 {
            return bad("the frame cache must hold at least one frame".into());
        }
        if !self.nodata.is_finite() && !self.nodata.is_nan() {
            return bad(format!("nodata {} is not a number", self.nodata));
        }
        Ok(())
    }

    /// Cells beyond a tile whose labels its weights depend on.
    fn margin(&self) -> usize {
        match self.blend {
            Blend::Feather => self.feather_px + 1,
            Blend::None => 0,
        }
    }
}

/// A rectangle of mosaic pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Window {
    pub col0: usize,
    pub row0: usize,
    pub size: ImageSize,
}

impl Window {
    fn grown(&self, by: usize, within: ImageSize) -> Window {
        let (c0, r0) = (self.col0.saturating_sub(by), self.row0.saturating_sub(by));
        let c1 = (self.col0 + self.size.width + by).min(within.width);
        let r1 = (self.row0 + self.size.height + by).min(within.height);
        Window {
            col0: c0,
            row0: r0,
            size: ImageSize::new(c1 - c0, r1 - r0),
        }
    }
}

/// The mosaic's grid, its tiles and the frames each tile needs.
#[derive(Debug, Clone)]
pub struct MosaicPlan {
    pub grid: OrthoGrid,
    pub frames: Vec<MosaicFrame>,
    pub opts: MosaicOptions,
    /// The mosaic pixel of each frame grid's pixel (0, 0).
    offsets: Vec<[i64; 2]>,
    /// Per tile, row-major: the frames whose grid meets the tile grown by the margin.
    tiles: Vec<Vec<usize>>,
}

/// The whole-pixel index of a grid's top-left corner on the global grid of `gsd`.
fn grid_index(grid: &OrthoGrid, gsd: f64, file: &Path) -> Result<[i64; 2], Error> {
    let (i, j) = (grid.top_left[0] / gsd, -grid.top_left[1] / gsd);
    let off = (i - i.round()).abs().max((j - j.round()).abs());
    if (grid.gsd - gsd).abs() > 1e-9 * gsd || off > 1e-6 {
        return Err(Error::Invalid(format!(
            "{}: its grid (GSD {} m, corner {:?}) is not on the mosaic's grid of GSD {gsd} m",
            file.display(),
            grid.gsd,
            grid.top_left
        )));
    }
    Ok([i.round() as i64, j.round() as i64])
}

/// Refuses a mosaic of `size` px at `gsd` m over `frames` x `max_output_px` pixels (two frames
/// 900 km apart made a 24 Gpx grid), naming its footprint and a GSD that would fit.
fn check_mosaic_size(
    size: ImageSize,
    gsd: f64,
    frames: usize,
    max_output_px: u64,
) -> Result<(), Error> {
    let pixels = size.width as f64 * size.height as f64;
    let limit = (max_output_px as f64 * frames as f64).max(1.0);
    if pixels <= limit {
        return Ok(());
    }
    // Coarser by sqrt(pixels / limit), to the millimetre, then by millimetres until the
    // footprint fits with two pixels a side to spare (each frame's grid is snapped to the
    // global grid).
    let (w_m, h_m) = (size.width as f64 * gsd, size.height as f64 * gsd);
    let mut mm = (gsd * (pixels / limit).sqrt() * 1000.0).ceil().max(1.0);
    for _ in 0..10_000 {
        let g = mm / 1000.0;
        if ((w_m / g).ceil() + 2.0) * ((h_m / g).ceil() + 2.0) <= limit {
            break;
        }
        mm += 1.0;
    }
    let fits = mm / 1000.0;
    Err(Error::advice(format!(
        "the mosaic would be {} x {} px ({:.0} m x {:.0} m at {gsd} m/px), over the limit of \
         {limit:.0} px ({frames} frame(s) x `max_output_px` {max_output_px}): are the frames' \
         positions right? A GSD of {fits} m (`gsd_m`) would fit",
        size.width, size.height, w_m, h_m,
    )))
}

impl MosaicPlan {
    /// The union grid of `frames` (all planned at `gsd` on the global grid) and its tiles.
    pub fn new(frames: Vec<MosaicFrame>, gsd: f64, opts: MosaicOptions) -> Result<Self, Error> {
        opts.validate()?;
        if frames.is_empty() {
            return Err(Error::Invalid("a mosaic needs at least one frame".into()));
        }
        let index = frames
            .iter()
            .map(|f| grid_index(&f.plan.grid, gsd, &f.path))
            .collect::<Result<Vec<_>, _>>()?;
        let (mut lo, mut hi) = ([i64::MAX; 2], [i64::MIN; 2]);
        for (f, ix) in frames.iter().zip(&index) {
            let s = f.plan.grid.size;
            lo = [lo[0].min(ix[0]), lo[1].min(ix[1])];
            hi = [
                hi[0].max(ix[0] + s.width as i64),
                hi[1].max(ix[1] + s.height as i64),
            ];
        }
        let size = ImageSize::new((hi[0] - lo[0]) as usize, (hi[1] - lo[1]) as usize);
        check_mosaic_size(size, gsd, frames.len(), opts.max_output_px)?;
        let grid = OrthoGrid {
            top_left: [lo[0] as f64 * gsd, -(lo[1] as f64) * gsd],
            gsd,
            size,
        };
        let offsets: Vec<[i64; 2]> = index.iter().map(|i| [i[0] - lo[0], i[1] - lo[1]]).collect();
        let mut plan = Self {
            grid,
            frames,
            opts,
            offsets,
            tiles: vec![],
        };
        plan.tiles = plan
            .tile_windows()
            .map(|t| plan.meeting(t.grown(plan.opts.margin(), size)))
            .collect();
        Ok(plan)
    }

    /// The output tiles, row-major.
    pub fn tile_windows(&self) -> impl Iterator<Item = Window> + '_ {
        let (t, s) = (self.opts.tile_px, self.grid.size);
        (0..s.height).step_by(t).flat_map(move |r| {
            (0..s.width).step_by(t).map(move |c| Window {
                col0: c,
                row0: r,
                size: ImageSize::new(t.min(s.width - c), t.min(s.height - r)),
            })
        })
    }

    /// The frames whose grid meets `w`.
    fn meeting(&self, w: Window) -> Vec<usize> {
        (0..self.frames.len())
            .filter(|&k| {
                let ([c, r], s) = (self.offsets[k], self.frames[k].plan.grid.size);
                c < (w.col0 + w.size.width) as i64
                    && c + s.width as i64 > w.col0 as i64
                    && r < (w.row0 + w.size.height) as i64
                    && r + s.height as i64 > w.row0 as i64
            })
            .collect()
    }
}

mod assemble;
mod cache;
mod request;
mod run;
mod weights;

pub use request::{check_mosaic_name, frame_options, mosaic_adjusted, mosaic_options, run_mosaic};
pub use score::{LATTICE_MARGIN_PX, SCORE_LATTICE};

pub use run::{
    COG_MAX_PX, FrameUse, MosaicReport, MosaicRun, frames_from_photos, mosaic, mosaic_cog,
    mosaic_cog_with, mosaic_with,
};
