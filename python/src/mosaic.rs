//! A flight's mosaic tile by tile: planned once, its tiles rendered anywhere (each worker
//! plans the same mosaic from the same photos and options), and the tiled GeoTIFF written
//! where the tiles come together, the same file `aerorect mosaic` writes.

use crate::arrays::{array_from_raster, raster_from_array};
use crate::options::PhotoArgs;
use crate::{py_err, to_py};
use aerorect::io::GeoReference;
use aerorect::mosaic::{
    MosaicFrame, MosaicPlan, MosaicRun, Window, check_mosaic_name, frames_from_photos,
    mosaic_options,
};
use aerorect::raster::AnyRaster;
use anyhow::{Result, bail};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::collections::HashMap;
use std::path::PathBuf;

/// A planned mosaic: its grid, its tiles (row-major) and their frames.
#[pyclass(module = "aerorect", frozen)]
pub struct MosaicTiles {
    plan: MosaicPlan,
    geo: GeoReference,
    windows: Vec<Window>,
}

fn read_frame(f: &MosaicFrame) -> Result<AnyRaster, aerorect::Error> {
    Ok(aerorect::io::read_image(&f.path)?)
}

/// Plans the mosaic `aerorect mosaic` would write of these photos (without `--adjust`).
#[pyfunction]
#[pyo3(signature = (paths, opts=None, blend="feather", feather_px=16))]
pub fn plan_mosaic(
    py: Python<'_>,
    paths: Vec<PathBuf>,
    opts: Option<&Bound<'_, PyDict>>,
    blend: &str,
    feather_px: usize,
) -> PyResult<MosaicTiles> {
    let args = PhotoArgs::from_dict(opts)?;
    // A task's tiles keep the 8 frames they share at least, not a quarter of the machine's
    // memory: a Dask worker has its own memory limit, which that does not know.
    let mopts = aerorect::mosaic::MosaicOptions {
        cache_bytes: 0,
        ..mosaic_options(blend, feather_px, args.max_output_px()).map_err(py_err)?
    };
    py.detach(|| -> Result<_> {
        let (mut o, _) = args.flight_frames(&paths)?;
        o.warp.nodata = 0.0;
        o.warp.alpha = false;
        o.cog = None;
        let (frames, crs) = frames_from_photos(&paths, &o)?;
        let gsd = frames.first().map_or(1.0, |f| f.plan.grid.gsd);
        let plan = MosaicPlan::new(frames, gsd, mopts.clone())?;
        let geo = GeoReference {
            crs,
            pixel_size: [gsd, gsd],
            top_left: plan.grid.top_left,
            rotation: [0.0, 0.0],
            nodata: (!mopts.alpha).then_some(mopts.nodata),
        };
        let windows = plan.tile_windows().collect();
        Ok(MosaicTiles { plan, geo, windows })
    })
    .map_err(py_err)
}

#[pymethods]
impl MosaicTiles {
    /// The mosaic's (width, height) in pixels.
    #[getter]
    fn size(&self) -> (usize, usize) {
        (self.plan.grid.size.width, self.plan.grid.size.height)
    }

    /// Every output tile as (col0, row0, width, height), row-major.
    #[getter]
    fn windows(&self) -> Vec<(usize, usize, usize, usize)> {
        self.windows
            .iter()
            .map(|w| (w.col0, w.row0, w.size.width, w.size.height))
            .collect()
    }

    /// Renders tiles `indices` (of `windows`): `(arrays, cells)`, `cells[k]` the cells frame
    /// `k` gave them. Neighbouring tiles share decoded frames.
    fn render<'py>(
        &self,
        py: Python<'py>,
        indices: Vec<usize>,
    ) -> PyResult<(Bound<'py, PyList>, Vec<usize>)> {
        if let Some(i) = indices.iter().find(|&&i| i >= self.windows.len()) {
            return Err(py_err(anyhow::anyhow!(
                "tile {i}: the mosaic has {} tiles",
                self.windows.len()
            )));
        }
        let (tiles, cells) = py
            .detach(|| -> Result<_> {
                let run = MosaicRun::new(&self.plan, read_frame);
                let tiles = indices
                    .iter()
                    .map(|&i| run.tile(self.windows[i]))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok((tiles, run.cells()))
            })
            .map_err(py_err)?;
        let arrays = tiles
            .iter()
            .map(|t| array_from_raster(py, t))
            .collect::<PyResult<Vec<_>>>()?;
        Ok((PyList::new(py, arrays)?, cells))
    }

    /// Writes the tiled GeoTIFF (atomically), asking `fetch(i)` for tile `i`'s array;
    /// returns the mosaic's report (`cells` as given: the frames' use summed over the tasks).
    fn write<'py>(
        &self,
        py: Python<'py>,
        out: PathBuf,
        fetch: Bound<'py, PyAny>,
        cells: Vec<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let t0 = std::time::Instant::now();
        // The output's name only (the tiles' options were the plan's).
        check_mosaic_name(&out).map_err(py_err)?;
        for f in &self.plan.frames {
            if aerorect::io::same_file(&f.path, &out) {
                return Err(py_err(anyhow::anyhow!(
                    "the mosaic {} would overwrite its frame {}",
                    out.display(),
                    f.path.display()
                )));
            }
        }
        let at: HashMap<(usize, usize), usize> = self
            .windows
            .iter()
            .enumerate()
            .map(|(i, w)| ((w.col0, w.row0), i))
            .collect();
        let mut failure: Option<PyErr> = None;
        let written = aerorect::io::write_tiled_tiff::<anyhow::Error>(
            &out,
            self.plan.grid.size,
            self.plan.opts.tile_px,
            Some(&self.geo),
            |c, r, s| {
                let Some(&i) = at.get(&(c, r)) else {
                    bail!("no tile of the plan at ({c}, {r})");
                };
                let tile = fetch.call1((i,)).and_then(|a| raster_from_array(&a));
                match tile {
                    Ok(t) if t.size() == s => Ok(t),
                    Ok(t) => bail!(
                        "tile {i} is {} x {}, not {} x {}",
                        t.size().width,
                        t.size().height,
                        s.width,
                        s.height
                    ),
                    Err(e) => {
                        let msg = e.to_string();
                        failure = Some(e);
                        bail!("tile {i}: {msg}")
                    }
                }
            },
        );
        if let Some(e) = failure {
            return Err(e);
        }
        written.map_err(py_err)?;
        let frames: Vec<aerorect::mosaic::FrameUse> = self
            .plan
            .frames
            .iter()
            .enumerate()
            .map(|(k, f)| aerorect::mosaic::FrameUse {
                path: f.path.display().to_string(),
                cells: cells.get(k).copied().unwrap_or(0),
                loads: 0,
            })
            .collect();
        let report = aerorect::mosaic::MosaicReport {
            output: out.display().to_string(),
            size: [self.plan.grid.size.width, self.plan.grid.size.height],
            gsd_m: self.plan.grid.gsd,
            top_left: self.plan.grid.top_left,
            tiles: self.windows.len(),
            blend: self.plan.opts.blend,
            covered_cells: cells.iter().sum(),
            frames,
            seconds: t0.elapsed().as_secs_f64(),
        };
        to_py(py, &report)
    }
}
