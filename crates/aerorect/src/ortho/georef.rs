//! Georeferenced orthorectification of one frame: a camera, its pose in a projected CRS and the
//! ground under it (level, or a DEM) give a north-up grid aligned to the GSD and the map from
//! its pixels to the frame's.
//!
//! Flat ground is a homography (then the lens): its footprint is the undistorted border of the
//! frame, cut near the horizon as `RectifyGeometry` does. Over a DEM the footprint is that
//! border's rays marched onto the terrain, and every output pixel is projected through the
//! camera at its own height.

use crate::{Error, warp_any};
use aerorect_core::error::Num;
use aerorect_core::orientation::standard_from_rotation;
use aerorect_core::{
    Camera, CameraRotation, Homography, Mat3, RectifyGeometry, RectifyLimits, Vec3,
};
use aerorect_geo::{
    Crs, Dem, GroundMap, HeightGrid, OrthoGrid, Pose, Terrain, Visible, occlusion_mask,
};
use aerorect_raster::{
    AnyRaster, LensDirection, LensMap, PixelMap, Raster, ReducedLevels, Then, WarpOptions,
    warp_levels,
};
use std::sync::Arc;

mod terrain;
use terrain::plan_terrain;

/// Points sampled on each side of the frame's border for footprints.
const BORDER_SAMPLES_PER_SIDE: usize = 64;

/// The ground under a frame.
#[derive(Debug, Clone)]
pub enum Ground {
    /// Level ground at this height of the world frame.
    Flat(f64),
    /// A DEM; holes and parts it does not cover take `fallback` (with a warning), or are an
    /// error when `strict`.
    Dem {
        dem: Arc<Dem>,
        fallback: Option<f64>,
        strict: bool,
    },
}

/// Everything one frame's ortho needs.
#[derive(Debug, Clone)]
pub struct OrthoRequest<'a> {
    pub camera: &'a Camera,
    pub pose: Pose,
    /// The world CRS the pose is in and the output is written in.
    pub world: &'a Crs,
    pub ground: &'a Ground,
    pub gsd_m: f64,
    pub limits: RectifyLimits,
    /// Over a DEM, leave the ground hidden behind nearer terrain empty (nodata).
    pub occlusion: bool,
}

#[derive(Debug, Clone)]
enum OrthoMap {
    Flat(Homography),
    Terrain(Box<GroundMap>),
    Visible(Box<Visible>),
}

/// A planned ortho: its grid, the map, and what planning found.
#[derive(Debug, Clone)]
pub struct OrthoPlan {
    pub camera: Camera,
    pub grid: OrthoGrid,
    map: OrthoMap,
    /// The ground covered, a polygon of world (x, y).
    pub footprint: Vec<[f64; 2]>,
    pub clipped: bool,
    /// `F` of the rotation (the frame's nadir standard image), for reports.
    pub standard_from_oblique: Homography,
    pub warnings: Vec<String>,
    pub warp: WarpOptions,
}

impl OrthoPlan {
    /// Resamples `input` onto the grid.
    pub fn run(&self, input: &AnyRaster) -> Result<AnyRaster, Error> {
        crate::check_input_size(input, self.camera.size, "camera")?;
        self.render_window(input, 0, 0, self.grid.size)
    }

    /// Resamples `input` onto the window of the grid whose top-left pixel is (`col0`, `row0`)
    /// (may lie outside the grid) and of `size`: the same pixels as [`Self::run`] there.
    pub fn render_window(
        &self,
        input: &AnyRaster,
        col0: i64,
        row0: i64,
        size: aerorect_core::ImageSize,
    ) -> Result<AnyRaster, Error> {
        self.warp_window(Whole(input), WarpWindow { col0, row0 }, size)
    }

    /// The whole grid from a frame's kept reduced levels (one band, as f32): the same pixels as
    /// [`Self::run`] of the frame, bit for bit; `None` where that run would read the frame at
    /// full resolution (its scale is under 2 somewhere).
    pub fn run_levels(&self, levels: &ReducedLevels<f32>) -> Result<Option<Raster<f32>>, Error> {
        if levels.size0() != self.camera.size {
            return Err(Error::Invalid(format!(
                "reduced levels of a {} x {} frame for a {} x {} camera",
                levels.size0().width,
                levels.size0().height,
                self.camera.size.width,
                self.camera.size.height
            )));
        }
        let at = WarpWindow { col0: 0, row0: 0 };
        self.warp_window(Reduced(levels), at, self.grid.size)
    }

    /// `source` warped through the plan's map seen from window `w`.
    fn warp_window<S: WarpSource>(
        &self,
        source: S,
        w: WarpWindow,
        size: aerorect_core::ImageSize,
    ) -> Result<S::Out, Error> {
        let lens = LensMap::of_camera(&self.camera, LensDirection::ObservedFromIdeal);
        let opts = &self.warp;
        match (&self.map, lens) {
            (OrthoMap::Flat(h), None) => source.warp(&w.of(h), size, opts),
            (OrthoMap::Flat(h), Some(lens)) => source.warp(&w.of(&Then(*h, lens)), size, opts),
            (OrthoMap::Terrain(m), _) => source.warp(&w.of(m.as_ref()), size, opts),
            (OrthoMap::Visible(m), _) => source.warp(&w.of(m.as_ref()), size, opts),
        }
    }

    /// Whether the map leaves out ground hidden from the camera (nearer terrain in the way)
    /// anywhere in the output pixels `cols` x `rows` (inclusive ranges, clamped to the grid).
    pub fn hides_any(&self, cols: [usize; 2], rows: [usize; 2]) -> bool {
        let OrthoMap::Visible(v) = &self.map else {
            return false;
        };
        let s = self.grid.size;
        if s.width == 0 || s.height == 0 || cols[0] > cols[1] || rows[0] > rows[1] {
            return false;
        }
        let (c0, c1) = (cols[0].min(s.width - 1), cols[1].min(s.width - 1));
        (rows[0].min(s.height - 1)..=rows[1].min(s.height - 1))
            .any(|r| v.hidden[r * s.width + c0..=r * s.width + c1].contains(&true))
    }

    /// The frame pixel of an output pixel, hidden ground included.
    pub fn frame_pixel_of_unmasked(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        use aerorect_raster::PixelMap;
        match &self.map {
            OrthoMap::Visible(m) => m.map.source_of(col, row),
            _ => self.frame_pixel_of(col, row),
        }
    }

    /// The output pixel -> frame pixel map (for tests and other resamplers); `None` where the
    /// output pixel has no source (beyond the horizon, hidden).
    pub fn frame_pixel_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        use aerorect_raster::PixelMap;
        match &self.map {
            OrthoMap::Flat(h) => {
                let p = h.map(col, row)?;
                match LensMap::of_camera(&self.camera, LensDirection::ObservedFromIdeal) {
                    None => Some(p),
                    Some(lens) => lens.source_of(p[0], p[1]),
                }
            }
            OrthoMap::Terrain(m) => m.source_of(col, row),
            OrthoMap::Visible(m) => m.source_of(col, row),
        }
    }
}

/// What a plan warps: a whole frame, or a frame's kept reduced levels.
trait WarpSource {
    type Out;
    fn warp<M: PixelMap>(
        self,
        map: &M,
        size: aerorect_core::ImageSize,
        opts: &WarpOptions,
    ) -> Result<Self::Out, Error>;
}

struct Whole<'a>(&'a AnyRaster);

impl WarpSource for Whole<'_> {
    type Out = AnyRaster;
    fn warp<M: PixelMap>(
        self,
        map: &M,
        size: aerorect_core::ImageSize,
        opts: &WarpOptions,
    ) -> Result<AnyRaster, Error> {
        warp_any(self.0, map, size, opts)
    }
}

struct Reduced<'a>(&'a ReducedLevels<f32>);

impl WarpSource for Reduced<'_> {
    type Out = Option<Raster<f32>>;
    fn warp<M: PixelMap>(
        self,
        map: &M,
        size: aerorect_core::ImageSize,
        opts: &WarpOptions,
    ) -> Result<Option<Raster<f32>>, Error> {
        Ok(warp_levels(self.0, map, size, opts)?)
    }
}

#[derive(Clone, Copy)]
struct WarpWindow {
    col0: i64,
    row0: i64,
}

impl WarpWindow {
    fn of<M>(self, map: &M) -> Window<'_, M> {
        Window {
            map,
            col0: self.col0,
            row0: self.row0,
        }
    }
}

/// `map` seen from a window whose pixel (0, 0) is the map's (`col0`, `row0`).
struct Window<'a, M> {
    map: &'a M,
    col0: i64,
    row0: i64,
}

impl<M: aerorect_raster::PixelMap> aerorect_raster::PixelMap for Window<'_, M> {
    fn source_of(&self, col: f64, row: f64) -> Option<[f64; 2]> {
        self.map
            .source_of(col + self.col0 as f64, row + self.row0 as f64)
    }

    fn source_row(&self, row: usize, col0: usize, xs: &mut [f64], ys: &mut [f64]) {
        let (r, c) = (row as i64 + self.row0, col0 as i64 + self.col0);
        match (usize::try_from(r), usize::try_from(c)) {
            (Ok(r), Ok(c)) => self.map.source_row(r, c, xs, ys),
            _ => {
                for (i, (x, y)) in xs.iter_mut().zip(ys.iter_mut()).enumerate() {
                    let p = self
                        .map
                        .source_of((c + i as i64) as f64, r as f64)
                        .unwrap_or([f64::NAN; 2]);
                    (*x, *y) = (p[0], p[1]);
                }
            }
        }
    }
}

/// The flat-ground plan: the global GSD grid's index (i, j) has its centre at world
/// ((i + 0.5) g, -(j + 0.5) g, z), and `oblique_from_grid = K R^T T` with
/// `T (i, j, 1) = P - C`.
fn flat_geometry(req: &OrthoRequest<'_>, z: f64) -> Result<(RectifyGeometry, Homography), Error> {
    let (cam, pose, g) = (req.camera, &req.pose, req.gsd_m);
    let c = pose.centre;
    if (c[2] - z).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(Error::Invalid(format!(
            "the camera at height {} m is not above the ground at {z} m",
            c[2]
        )));
    }
    let t = Mat3::new(
        g,
        0.0,
        0.5 * g - c[0],
        0.0,
        -g,
        -0.5 * g - c[1],
        0.0,
        0.0,
        z - c[2],
    );
    let k = cam.intrinsics.pixel_from_camera();
    let r = pose.world_from_camera();
    let oblique_from_grid = Homography::new(k * r.transpose() * t)
        .map_err(Error::geometry("the ground-to-frame homography"))?;
    let rotation = CameraRotation::from_matrix(r).map_err(Error::geometry("camera rotation"))?;
    let f = standard_from_rotation(&cam.intrinsics, &rotation);
    let border: Vec<[f64; 2]> = cam
        .border_rays(BORDER_SAMPLES_PER_SIDE)
        .iter()
        .map(|ray| {
            let h = k * ray;
            [h.x / h.z, h.y / h.z]
        })
        .collect();
    let geometry = RectifyGeometry::from_base_homography_and_border(
        f,
        oblique_from_grid.inverse(),
        cam.size,
        border,
        req.limits,
    )
    .map_err(Error::geometry("rectify"))?;
    Ok((geometry, f))
}

/// Plans the ortho of one frame.
pub fn plan_ortho(req: &OrthoRequest<'_>, warp: WarpOptions) -> Result<OrthoPlan, Error> {
    let g = req.gsd_m;
    if !(g.is_finite() && g > 0.0) {
        return Err(Error::Invalid(format!(
            "GSD {} m must be a positive number of metres",
            Num(g)
        )));
    }
    let plan = match req.ground {
        Ground::Flat(z) => plan_flat(req, *z, warp),
        Ground::Dem {
            dem,
            fallback,
            strict,
        } => plan_terrain(req, dem, *fallback, *strict, warp),
    }?;
    refuse_too_coarse(&plan)?;
    Ok(plan)
}

/// The shortest side an ortho may have: below it the GSD is about the size of the footprint
/// and the image says nothing (`--gsd-m 1e6` used to give a 2 x 2 px ortho, exit 0).
pub const MIN_ORTHO_SIDE_PX: usize = 16;

/// Refuses a plan whose grid has a side under [`MIN_ORTHO_SIDE_PX`], naming the GSD, the
/// footprint's extent and the coarsest GSD that would do.
fn refuse_too_coarse(plan: &OrthoPlan) -> Result<(), Error> {
    let size = plan.grid.size;
    if size.width.min(size.height) >= MIN_ORTHO_SIDE_PX {
        return Ok(());
    }
    let b = bounds_of(plan.footprint.iter().copied());
    let (w, h) = (b[2] - b[0], b[3] - b[1]);
    Err(Error::Invalid(format!(
        "GSD {} m gives a {} x {} px ortho of a footprint about {w:.0} x {h:.0} m: \
         a side needs at least {MIN_ORTHO_SIDE_PX} px, so a GSD of {:.3} m or finer",
        Num(plan.grid.gsd),
        size.width,
        size.height,
        w.min(h) / MIN_ORTHO_SIDE_PX as f64,
    )))
}

fn plan_flat(req: &OrthoRequest<'_>, z: f64, warp: WarpOptions) -> Result<OrthoPlan, Error> {
    let (geometry, f) = flat_geometry(req, z)?;
    let g = req.gsd_m;
    let [i0, j0] = geometry.standard_origin;
    let grid = OrthoGrid {
        top_left: [i0 * g, -j0 * g],
        gsd: g,
        size: geometry.output_size,
    };
    let footprint = geometry
        .footprint
        .iter()
        .filter_map(|p| geometry.base_from_oblique.map(p[0], p[1]))
        .map(|b| [(b[0] + 0.5) * g, -(b[1] + 0.5) * g])
        .collect();
    let mut warnings = Vec::new();
    if geometry.clipped {
        warnings
            .push("the far field near the horizon was cut to respect the output size limit".into());
    }
    Ok(OrthoPlan {
        camera: req.camera.clone(),
        grid,
        map: OrthoMap::Flat(geometry.oblique_from_output),
        footprint,
        clipped: geometry.clipped,
        standard_from_oblique: f,
        warnings,
        warp,
    })
}

/// World (x, y) bounds [xmin, ymin, xmax, ymax] of points.
pub(crate) fn bounds_of(points: impl IntoIterator<Item = [f64; 2]>) -> [f64; 4] {
    points.into_iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    )
}

/// Reads a DEM GeoTIFF (any CRS the file states) for the terrain planner: [`aerorect_io::read_dem`].
pub fn load_dem(path: &std::path::Path) -> Result<Dem, Error> {
    Ok(aerorect_io::read_dem(path)?)
}
