//! The ortho of a frame over a DEM: the frame's border rays marched onto the terrain give the
//! footprint and the grid, and every output pixel is projected through the camera at its own
//! height.

use super::*;

/// Where rays from the camera meet the level z.
fn on_plane(pose: &Pose, rays: &[Vec3], z: f64) -> Vec<[f64; 2]> {
    rays.iter()
        .filter_map(|d| pose.level_point(*d, z))
        .collect()
}

/// The height grid under a frame: sampled from the DEM over the footprint's reach between the
/// lowest and highest terrain seen, at the DEM's own spacing (at least the GSD).
fn terrain_under(
    req: &OrthoRequest<'_>,
    dem: &Dem,
    rays: &[Vec3],
    fill: f64,
    range: (f64, f64),
) -> Result<(HeightGrid, aerorect_geo::Sampling), Error> {
    let pose = &req.pose;
    let reach = on_plane(pose, rays, range.0).into_iter().chain(on_plane(
        pose,
        rays,
        range.1.min(pose.centre[2] - 0.5),
    ));
    let b = bounds_of(reach);
    let cell = if dem.crs.is_geographic() {
        dem.cell_size[1] * 111_320.0
    } else {
        dem.cell_size[0].min(dem.cell_size[1])
    };
    let spacing = cell.max(req.gsd_m);
    let nodes = ((b[2] - b[0]) / spacing + 3.0) * ((b[3] - b[1]) / spacing + 3.0);
    if !(nodes.is_finite() && nodes <= 4.0e7) {
        return Err(Error::Invalid(format!(
            "{}: the frame's reach on the DEM ({:.0} x {:.0} m) is too large; is the camera height right?",
            dem.name,
            b[2] - b[0],
            b[3] - b[1]
        )));
    }
    HeightGrid::from_dem(dem, req.world, b, spacing, fill).map_err(Error::from)
}

/// The ortho of a frame over a DEM. Its horizon cut is planned on level ground at the fill
/// height. Where the ground under the far field lies lower, the rays run on past that cut
/// (`batch --ties correlation` of the `drone-xmp` photos: DJI_0030, at pitch -19 over its
/// ties' surface, came to 8311 x 7712 px where 64 Mpx were allowed, and the flight was
/// refused); and ground near the camera higher than the level moves the near edge towards it,
/// widening the grid. So an ortho over the limit is cut again ([`MAX_RECUTS`] times at most):
/// first at the lowest ground under the frame, then to a limit shrunk by as much as the last
/// cut overshot.
pub(super) fn plan_terrain(
    req: &OrthoRequest<'_>,
    dem: &Dem,
    fallback: Option<f64>,
    strict: bool,
    warp: WarpOptions,
) -> Result<OrthoPlan, Error> {
    let (lo, hi) = dem
        .range()
        .ok_or_else(|| Error::Invalid(format!("DEM {} has no valid height", dem.name)))?;
    let fill = fallback.unwrap_or(0.5 * (lo + hi));
    let mut cut = (fill.min(req.pose.centre[2] - 0.5), req.limits.max_output_px);
    let mut reach = Reach::plan(req, dem, cut, fill, (lo, hi))?;
    for _ in 0..MAX_RECUTS {
        let over = reach.grid.size.pixels() as f64 / req.limits.max_output_px as f64;
        if over <= 1.0 {
            break;
        }
        cut = match reach.range.0 < cut.0 {
            true => (reach.range.0, cut.1),
            false => (cut.0, (0.95 * cut.1 as f64 / over) as u64),
        };
        match Reach::plan(req, dem, cut, fill, (lo, hi)) {
            Ok(r) => reach = r,
            Err(_) => break,
        }
    }
    let Reach {
        geometry,
        f,
        terrain,
        sampling,
        range: (_, fhi),
        hits,
        grid,
        step,
    } = reach;
    if grid.size.pixels() as u64 > req.limits.max_output_px {
        return Err(Error::advice(format!(
            "the ortho over the DEM would be {} x {} px, over the limit of {} px (`max_output_px`)",
            grid.size.width, grid.size.height, req.limits.max_output_px
        )));
    }
    let mut warnings = Vec::new();
    if geometry.clipped {
        warnings
            .push("the far field near the horizon was cut to respect the output size limit".into());
    }
    if sampling.filled > 0 {
        let msg = format!(
            "DEM {}: {} of {} height nodes under the frame are nodata or outside it; they take {fill:.2} m",
            dem.name, sampling.filled, sampling.nodes
        );
        if strict {
            return Err(Error::advice(format!("{msg} (refused by `strict`)")));
        }
        warnings.push(msg);
    }
    let map = GroundMap {
        camera: req.camera.clone(),
        pose: req.pose,
        grid,
        terrain,
    };
    let map = if req.occlusion {
        let hidden = occlusion_mask(&map, step, fhi);
        let count = hidden.iter().filter(|&&h| h).count();
        if count > 0 {
            warnings.push(format!(
                "{count} output pixels are hidden behind nearer terrain (the occlusion test): left empty"
            ));
        }
        OrthoMap::Visible(Box::new(Visible { map, hidden }))
    } else {
        OrthoMap::Terrain(Box::new(map))
    };
    Ok(OrthoPlan {
        camera: req.camera.clone(),
        grid,
        map,
        footprint: hits,
        clipped: geometry.clipped,
        standard_from_oblique: f,
        warnings,
        warp,
    })
}

/// Horizon cuts planned again, at most, for an ortho over the DEM that overshoots the output
/// size limit ([`plan_terrain`]).
const MAX_RECUTS: usize = 3;

/// The part of a frame kept by a horizon cut planned on level ground, and where its rays meet
/// the terrain.
struct Reach {
    geometry: RectifyGeometry,
    f: Homography,
    /// The heights under the kept part.
    terrain: Terrain,
    sampling: aerorect_geo::Sampling,
    /// The lowest and highest of them.
    range: (f64, f64),
    /// Where the kept part's border rays meet the terrain.
    hits: Vec<[f64; 2]>,
    /// The grid over them.
    grid: OrthoGrid,
    /// The ray marching step (m).
    step: f64,
}

impl Reach {
    /// The frame cut on level ground at `cut`'s height to its output size limit (px), over
    /// the DEM (heights between `lo_hi`; holes take `fill`).
    fn plan(
        req: &OrthoRequest<'_>,
        dem: &Dem,
        cut: (f64, u64),
        fill: f64,
        lo_hi: (f64, f64),
    ) -> Result<Reach, Error> {
        let level = OrthoRequest {
            limits: RectifyLimits {
                max_output_px: cut.1,
            },
            ..req.clone()
        };
        let (geometry, f) = flat_geometry(&level, cut.0)?;
        let k_inv = req.camera.intrinsics.camera_from_pixel();
        let rays: Vec<Vec3> = geometry
            .footprint
            .iter()
            .map(|p| req.pose.world_direction(k_inv * Vec3::new(p[0], p[1], 1.0)))
            .collect();
        // Twice: the second pass bounds the reach with the heights actually under the frame.
        let (first, _) = terrain_under(req, dem, &rays, fill, lo_hi)?;
        let range = first
            .values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v as f64), b.max(v as f64))
            });
        let (heights, sampling) = terrain_under(req, dem, &rays, fill, range)?;
        let terrain = Terrain::Grid(heights);
        let step = 0.5
            * req
                .gsd_m
                .max(1e-3)
                .max(dem.cell_size[0].min(dem.cell_size[1]).min(5.0));
        let dense = densify(&rays, 4 * BORDER_SAMPLES_PER_SIDE);
        let hits: Vec<[f64; 2]> = dense
            .iter()
            .filter_map(|d| aerorect_geo::march_to_ground(&req.pose, *d, &terrain, range, step))
            .map(|p| [p[0], p[1]])
            .collect();
        if hits.len() < 3 {
            return Err(Error::Invalid(format!(
                "DEM {}: the frame's rays do not meet the terrain",
                dem.name
            )));
        }
        let grid = OrthoGrid::covering(bounds_of(hits.iter().copied()), req.gsd_m);
        Ok(Reach {
            geometry,
            f,
            terrain,
            sampling,
            range,
            hits,
            grid,
            step,
        })
    }
}

/// `n` rays spread along the closed polygon of `rays` (directions interpolated and renormalised).
fn densify(rays: &[Vec3], n: usize) -> Vec<Vec3> {
    let m = rays.len();
    if m == 0 {
        return vec![];
    }
    let per = n.div_ceil(m).max(1);
    (0..m)
        .flat_map(|i| {
            let (a, b) = (rays[i].normalize(), rays[(i + 1) % m].normalize());
            (0..per).map(move |s| {
                let t = s as f64 / per as f64;
                (a * (1.0 - t) + b * t).normalize()
            })
        })
        .collect()
}
