//! The flight's frames and their first orientation: each photo planned from its metadata (or
//! its pose) on the matching grid, the flight's CRS, the grid's GSD within the matching
//! budget, the ground the frames are projected on, and the recorded poses and cameras.

use super::*;

/// One frame of the flight, planned from its metadata.
pub(super) struct Frame {
    pub(super) input: PathBuf,
    pub(super) info: DronePlanInfo,
    /// Its ortho plan on the matching grid with the recorded orientation.
    pub(super) coarse_plan: OrthoPlan,
    /// The photo's RTK standard deviations (m; east, north, up), if it has them.
    pub(super) rtk_std_m: Option<[f64; 3]>,
}

/// A frame's gray ortho on the matching grid (NaN: no data) and that ortho's plan.
#[derive(Clone)]
pub(super) struct Rendered {
    pub(super) coarse: Raster<f32>,
    pub(super) coarse_plan: OrthoPlan,
}

/// The flight's shared CRS: `--crs`, else the UTM zone of the first frame with a position.
pub(super) fn flight_crs(
    frames: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
) -> Result<Crs, Error> {
    if let Some(c) = &opts.crs {
        return Ok(c.clone());
    }
    let (lon, lat) = frames
        .iter()
        .find_map(|(_, m)| Some((m.longitude_deg?, m.latitude_deg?)))
        .ok_or_else(|| Error::Invalid("no frame of the flight has a GPS position".into()))?;
    Crs::utm_for(lon, lat).map_err(Error::from)
}

/// How frames are rendered on the matching grid: bilinear, prefiltered, NaN where no data.
pub(super) fn matching_warp() -> WarpOptions {
    WarpOptions {
        interp: Interp::Bilinear,
        nodata: f64::NAN,
        alpha: false,
        prefilter: true,
        ..WarpOptions::default()
    }
}

/// Plans a frame on the matching grid with its recorded orientation.
pub(super) fn plan_frame(
    input: &Path,
    meta: &PhotoMetadata,
    opts: &DroneOptions,
    (gsd, max_output_px): (f64, u64),
) -> Result<Frame, Error> {
    let file = input.display().to_string();
    let rtk_std_m = meta.dji.rtk_std_m;
    let size = timing::time("plan: photo size", || aerorect_io::read_image_size(input))?;
    let coarse_opts = DroneOptions {
        gsd_m: Some(gsd),
        warp: matching_warp(),
        limits: aerorect_core::RectifyLimits { max_output_px },
        occlusion: false,
        ..opts.clone()
    };
    let posed = opts
        .poses
        .as_deref()
        .map(|p| crate::drone::pose_for(p, input));
    let (coarse_plan, info) = match posed {
        Some(Some(pose)) => crate::drone::plan_from_pose(pose, meta, size, &coarse_opts, &file)?,
        Some(None) => return Err(Error::Invalid(format!("{file}: not in the pose table"))),
        None => plan_from_metadata(meta, size, &coarse_opts, &file)?,
    };
    Ok(Frame {
        input: input.to_path_buf(),
        info,
        coarse_plan,
        rtk_std_m,
    })
}

/// The terrain's height at world (x, y): the DEM (through its CRS), the level ground, or 0
/// (heights above the take-off point).
pub(super) fn ground_fn(
    opts: &DroneOptions,
    world: &Crs,
) -> Box<dyn Fn(f64, f64) -> f64 + Send + Sync> {
    if let Some(dem) = &opts.dem {
        return dem_ground(std::sync::Arc::clone(dem), world);
    }
    let z = opts.ground_height_m.unwrap_or(0.0);
    Box::new(move |_, _| z)
}

/// The ground `dem` describes, at (x, y) in `world`: its middle height off it.
pub(super) fn dem_ground(
    dem: std::sync::Arc<aerorect_geo::Dem>,
    world: &Crs,
) -> Box<dyn Fn(f64, f64) -> f64 + Send + Sync> {
    let range = dem.range();
    dem_ground_within(dem, world, range)
}

/// [`dem_ground`] of a DEM whose lowest and highest heights are known (`range`: its
/// [`aerorect_geo::Dem::range`]), without a pass over its cells for them.
pub(super) fn dem_ground_within(
    dem: std::sync::Arc<aerorect_geo::Dem>,
    world: &Crs,
    range: Option<(f64, f64)>,
) -> Box<dyn Fn(f64, f64) -> f64 + Send + Sync> {
    let mid = range.map_or(0.0, |r| 0.5 * (r.0 + r.1));
    let height_at = aerorect_geo::Dem::heights_in(dem, world);
    Box::new(move |x, y| height_at(x, y).unwrap_or(mid))
}

/// Every frame planned on the matching grid: at `gsd`, or coarser until every frame's ortho
/// fits [`MATCH_BUDGET_PX`] (with a warning); returns the GSD used.
pub(super) fn plan_matching(
    metas: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
    gsd: f64,
) -> Result<(f64, Vec<Frame>, Vec<String>), Error> {
    let (mut g, mut first) = (gsd, None);
    for _ in 0..8 {
        let planned: Vec<Result<Frame, Error>> = metas
            .par_iter()
            .map(|(p, m)| plan_frame(p, m, opts, (g, MATCH_BUDGET_PX)))
            .collect();
        if planned.iter().all(Result::is_ok) {
            let frames = planned.into_iter().collect::<Result<Vec<_>, _>>()?;
            let warnings = first
                .map(|(px, k): (u64, usize)| {
                    format!(
                        "matching grid: at {gsd:.4} m the ortho of {} would be {px} px, over the matching budget of {MATCH_BUDGET_PX} px; the frames are matched at {g:.4} m",
                        metas[k].0.display()
                    )
                })
                .into_iter()
                .collect();
            return Ok((g, frames, warnings));
        }
        // A frame over the budget plans with room to spare (a plan allocates no pixels):
        // its size says how much coarser the grid must be; any other failure is the frame's.
        let mut worst = (0u64, 0usize);
        for (k, r) in planned.into_iter().enumerate() {
            let Err(e) = r else { continue };
            let (p, m) = &metas[k];
            let Ok(f) = plan_frame(p, m, opts, (g, 64 * MATCH_BUDGET_PX)) else {
                return Err(e);
            };
            worst = worst.max((f.coarse_plan.grid.size.pixels() as u64, k));
        }
        first.get_or_insert(worst);
        g *= 1.02 * (worst.0 as f64 / MATCH_BUDGET_PX as f64).sqrt().max(1.0);
    }
    Err(Error::Invalid(format!(
        "matching grid: no GSD up to {g:.3} m keeps every frame's ortho within {MATCH_BUDGET_PX} px"
    )))
}

/// The ground a frame is projected on: the DEM, else the tie surface (`surface`, which
/// covers the frames' footprints; beyond it the level ground), else the level ground under it
/// as planned from its metadata.
pub(super) fn frame_ground(
    f: &Frame,
    opts: &DroneOptions,
    surface: Option<&std::sync::Arc<aerorect_geo::Dem>>,
) -> Ground {
    match (&opts.dem, surface) {
        (Some(dem), _) => Ground::Dem {
            dem: std::sync::Arc::clone(dem),
            fallback: None,
            strict: opts.strict,
        },
        (None, Some(s)) => Ground::Dem {
            dem: std::sync::Arc::clone(s),
            fallback: Some(level_ground(f)),
            strict: false,
        },
        (None, None) => Ground::Flat(level_ground(f)),
    }
}

/// The level ground under a frame as planned from its metadata.
pub(super) fn level_ground(f: &Frame) -> f64 {
    f.info.pose.centre[2] - f.info.height_m
}

/// The finest nadir GSD of the flight's frames (height over the focal length in pixels) and
/// the shortest side of their images.
pub(super) fn finest_gsd(
    metas: &[(PathBuf, PhotoMetadata)],
    opts: &DroneOptions,
) -> Result<(f64, usize), Error> {
    let ground = match (&opts.dem, opts.ground_height_m) {
        (_, Some(g)) => g,
        (Some(dem), None) => dem.range().map_or(0.0, |r| 0.5 * (r.0 + r.1)),
        (None, None) => 0.0,
    };
    let (mut best, mut short) = (f64::INFINITY, usize::MAX);
    for (p, m) in metas {
        // Only the matching grid's GSD depends on this: the camera file's own size, else the
        // size the photo's tags were written for.
        let cam = match (&opts.camera, m.width, m.height) {
            (Some(c), _, _) => c
                .camera(None)
                .or_else(|_| c.camera(Some(aerorect_io::read_image_size(p)?)))?,
            (None, Some(w), Some(h)) => {
                let size = ImageSize::new(w as usize, h as usize);
                crate::drone::camera_from_metadata(m, size, &p.display().to_string())?.camera
            }
            (None, _, _) => {
                let size = aerorect_io::read_image_size(p)?;
                crate::drone::camera_from_metadata(m, size, &p.display().to_string())?.camera
            }
        };
        let pose = match opts.poses.as_deref() {
            Some(t) => Some(crate::drone::pose_for(t, p).ok_or_else(|| {
                Error::Invalid(format!("{}: not in the pose table", p.display()))
            })?),
            None => None,
        };
        let h = match pose {
            Some(pose) => pose.z - ground,
            None => m.dji.relative_altitude_m.unwrap_or(100.0),
        };
        best = best.min(h.abs().max(1.0) / cam.intrinsics.fx);
        short = short.min(cam.size.width.min(cam.size.height));
    }
    Ok((best, short))
}

/// The recorded orientation: poses, the distinct cameras and each frame's camera index.
pub(super) struct Recorded {
    pub(super) poses: Vec<Pose>,
    pub(super) cameras: Vec<Camera>,
    pub(super) camera_of: Vec<usize>,
}

/// The recorded poses, the distinct cameras and each frame's camera index.
pub(super) fn recorded(frames: &[Frame]) -> Recorded {
    let mut cameras: Vec<Camera> = Vec::new();
    let mut camera_of = Vec::with_capacity(frames.len());
    for f in frames {
        let c = &f.info.camera.camera;
        let k = cameras.iter().position(|x| x == c).unwrap_or_else(|| {
            cameras.push(c.clone());
            cameras.len() - 1
        });
        camera_of.push(k);
    }
    Recorded {
        poses: frames.iter().map(|f| f.info.pose).collect(),
        cameras,
        camera_of,
    }
}
