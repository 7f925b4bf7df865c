//! The ground the flight's own tie points describe, for a flight with no DEM: each tie point
//! intersected through the adjusted frames, the points a frame misses by more than
//! [`SURFACE_MAX_RESIDUAL_PX`] left out, the rest gridded at [`SURFACE_CELL_M`] (the median of
//! each cell), the empty cells filled ring by ring from their neighbours and then relaxed
//! towards a membrane stretched between the points (beyond the points the surface keeps the
//! height of its edge), over the frames' footprints.
//! The frames are then rendered over it as over a `--dem`, so that hills no longer shift
//! between overlapping frames by their relief's parallax (OpenDroneMap renders on a 2.5-D
//! surface from its reconstruction's points the same way).

use super::*;
use crate::georef::bounds_of;
use aerorect_core::Vec3;
use aerorect_geo::Dem;
use aerorect_solve::adjust::{OrientedFrames, PosedFrames, one_point};
use std::sync::Arc;

/// A tie point whose intersection misses its observations by more than this (px, rms over
/// its views: three times the ties' 0.5 px sigma) is left out of the surface: a mismatch, or
/// a point on something that moved.
pub const SURFACE_MAX_RESIDUAL_PX: f64 = 1.5;

/// Fewer tie points than this (after the residual check) make no surface: the level ground
/// stays.
pub const MIN_SURFACE_POINTS: usize = 50;

/// Nor does a flight whose ties mostly miss their intersection (under this fraction kept): its
/// orientation cannot place points in 3-D (the five DJI frames of the shared data, adjusted to
/// 8.4 px rms, keep 65 of 170).
pub const MIN_SURFACE_KEPT: f64 = 0.5;

/// The surface's cell (m): fine enough to keep every tie point's height where it is.
pub const SURFACE_CELL_M: f64 = 2.0;

/// The most cells of the surface: a coarser cell beyond it.
pub const SURFACE_MAX_CELLS: usize = 1_000_000;

/// Sweeps of the membrane between the points (see `relaxed`): the gaps of ten or so cells
/// between neighbouring tie points settle; wider ones keep much of the ring-by-ring fill
/// (nearer points weigh more). On the senseFly photos, whose ties lie tens of metres apart,
/// the frames' agreement depends on it: 1000 sweeps moved 2281/2282 from 1.72 to 3.58 px
/// (2188/2189 0.52 -> 0.60, 2280/2281 1.67 -> 1.59).
pub const SURFACE_SWEEPS: usize = 300;

/// The surface's name, as a DEM's would be its file.
pub const SURFACE_NAME: &str = "the tie-point surface";

/// What the surface was made of, for the flight's report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SurfaceReport {
    /// Tie points intersected and kept; left out (residual over
    /// [`SURFACE_MAX_RESIDUAL_PX`], rays that do not meet, heights far off the rest).
    pub tie_points: usize,
    pub rejected: usize,
    pub cell_m: f64,
    /// [xmin, ymin, xmax, ymax] in the flight's CRS, and the grid's columns and rows.
    pub extent: [f64; 4],
    pub size: [usize; 2],
    /// Lowest and highest height of the surface (m).
    pub heights_m: [f64; 2],
    /// RMS of the kept points' heights about the surface (m): the relief finer than a cell
    /// and the points' own noise.
    pub spread_m: f64,
}

/// The surface as a DEM in the flight's CRS, and its report.
#[derive(Debug, Clone)]
pub struct TieSurface {
    pub dem: Arc<Dem>,
    pub report: SurfaceReport,
}

/// The tie points' surface through `frames` (the adjusted orientation), or `None` with fewer
/// than [`MIN_SURFACE_POINTS`] points that pass the residual check, or fewer than
/// [`MIN_SURFACE_KEPT`] of the ties.
pub fn tie_surface(
    ties: &[TiePoint],
    frames: OrientedFrames<'_>,
    crs: &Crs,
) -> Result<Option<TieSurface>, Error> {
    let candidates: Vec<&TiePoint> = ties
        .iter()
        .filter(|t| t.control.is_none() && t.observations.len() >= 2)
        .filter(|t| !seen_from_one_point(t, frames))
        .collect();
    let points: Vec<[f64; 3]> = timing::time("tie surface: points", || {
        let posed = frames.posed();
        candidates
            .par_iter()
            .filter_map(|t| ground_point(t, frames, &posed))
            .collect()
    });
    let points = without_far_heights(points);
    if points.len() < MIN_SURFACE_POINTS
        || (points.len() as f64) < MIN_SURFACE_KEPT * candidates.len() as f64
    {
        return Ok(None);
    }
    let rejected = candidates.len() - points.len();
    let extent = surface_extent(&points, frames);
    let cell = cell_size(extent);
    let (w, h) = grid_size(extent, cell);
    let fixed = cell_medians(&points, extent, cell, (w, h));
    let mut values = fixed.clone();
    timing::time("tie surface: fill", || fill_outwards(&mut values, (w, h)));
    let values = timing::time("tie surface: relax", || relaxed(values, &fixed, (w, h)));
    let dem = Dem {
        name: SURFACE_NAME.into(),
        values,
        width: w,
        height: h,
        top_left: [extent[0], extent[3]],
        cell_size: [cell, cell],
        crs: crs.clone(),
    };
    dem.validate()?;
    let spread_m = spread(&dem, &points);
    let (lo, hi) = dem.range().unwrap_or((f64::NAN, f64::NAN));
    let report = SurfaceReport {
        tie_points: points.len(),
        rejected,
        cell_m: cell,
        extent: [
            extent[0],
            extent[3] - h as f64 * cell,
            extent[0] + w as f64 * cell,
            extent[3],
        ],
        size: [w, h],
        heights_m: [lo, hi],
        spread_m,
    };
    Ok(Some(TieSurface {
        dem: Arc::new(dem),
        report,
    }))
}

/// Whether a tie's frames saw it from (nearly) one point ([`one_point`]): their largest
/// baseline under 2 % of the first frame's range to its first guess. Its rays meet at under
/// about a degree, so its height is the level ground's guess, not a measurement, and the
/// surface leaves it out (it is not counted among the candidates either). Two DJI frames from
/// one hover point, their 4,672 ties against the nadir pair's 208, left a five-frame flight
/// with no surface at all: under half its ties intersected.
fn seen_from_one_point(t: &TiePoint, frames: OrientedFrames<'_>) -> bool {
    let centre = |o: &aerorect_solve::adjust::Observation| {
        frames.frames.get(o.frame).map(|f| Vec3::from(f.centre))
    };
    let Some(Some(first)) = t.observations.first().map(centre) else {
        return false;
    };
    let mut baseline = 0.0f64;
    for o in &t.observations[1..] {
        let Some(c) = centre(o) else {
            return false;
        };
        baseline = baseline.max((c - first).norm());
    }
    one_point(baseline, (Vec3::from(t.ground) - first).norm())
}

/// Tie `t`'s point through the frames, if its rays meet within
/// [`SURFACE_MAX_RESIDUAL_PX`] of every view (rms); `posed`: the same frames posed once.
fn ground_point(
    t: &TiePoint,
    frames: OrientedFrames<'_>,
    posed: &PosedFrames<'_>,
) -> Option<[f64; 3]> {
    let start = match &t.observations[..] {
        [a, b, ..] => frames.rays_meet(a, b),
        _ => None,
    };
    let x = posed.intersect(&t.observations, start.unwrap_or(t.ground))?;
    let mut sum = 0.0;
    for o in &t.observations {
        let p = posed.pixel_of(o.frame, x)?;
        sum += (p[0] - o.pixel[0]).powi(2) + (p[1] - o.pixel[1]).powi(2);
    }
    let rms = (sum / t.observations.len() as f64).sqrt();
    (rms <= SURFACE_MAX_RESIDUAL_PX).then_some(x)
}

/// The points without those whose height is further from the median than ten robust sigmas
/// (1.4826 MAD) or 5 m, whichever is more: rays that met far above or below the ground.
fn without_far_heights(points: Vec<[f64; 3]>) -> Vec<[f64; 3]> {
    let mut z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let Some(mid) = median(&mut z) else {
        return points;
    };
    let mut dev: Vec<f64> = z.iter().map(|v| (v - mid).abs()).collect();
    let mad = median(&mut dev).unwrap_or(0.0);
    let limit = (10.0 * 1.4826 * mad).max(5.0);
    points
        .into_iter()
        .filter(|p| (p[2] - mid).abs() <= limit)
        .collect()
}

/// [xmin, ymin, xmax, ymax] of the points and of every frame's footprint on the level of the
/// points' median height (the image corners' rays), a tenth wider on each side.
fn surface_extent(points: &[[f64; 3]], frames: OrientedFrames<'_>) -> [f64; 4] {
    let mut z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let level = median(&mut z).unwrap_or(0.0);
    let corners = (0..frames.frames.len()).flat_map(|k| footprint_corners(frames, k, level));
    let b = bounds_of(points.iter().map(|p| [p[0], p[1]]).chain(corners));
    let pad = 0.1 * (b[2] - b[0]).max(b[3] - b[1]);
    [b[0] - pad, b[1] - pad, b[2] + pad, b[3] + pad]
}

/// Where frame `k`'s image corners' rays meet the level `level` (x, y). A corner above the
/// horizon, or one absurdly far (a grazing ray), does not count.
fn footprint_corners(frames: OrientedFrames<'_>, k: usize, level: f64) -> Vec<[f64; 2]> {
    let Some((f, cam)) = frames
        .frames
        .get(k)
        .and_then(|f| Some((f, frames.cameras.get(f.camera)?)))
    else {
        return Vec::new();
    };
    let (w, h) = (cam.size.width as f64, cam.size.height as f64);
    [[0.0, 0.0], [w, 0.0], [0.0, h], [w, h]]
        .into_iter()
        .filter_map(|c| {
            let p = frames.ray_at_height(k, c, level)?;
            let near =
                (p[0] - f.centre[0]).hypot(p[1] - f.centre[1]) < 20.0 * (f.centre[2] - level);
            near.then_some([p[0], p[1]])
        })
        .collect()
}

/// [`SURFACE_CELL_M`], or coarser to fit [`SURFACE_MAX_CELLS`].
fn cell_size(e: [f64; 4]) -> f64 {
    let area = (e[2] - e[0]) * (e[3] - e[1]);
    SURFACE_CELL_M.max((area / SURFACE_MAX_CELLS as f64).sqrt())
}

fn grid_size(e: [f64; 4], cell: f64) -> (usize, usize) {
    let n = |d: f64| ((d / cell).ceil() as usize).max(2);
    (n(e[2] - e[0]), n(e[3] - e[1]))
}

/// The median height of the points in each cell (NaN: none).
fn cell_medians(points: &[[f64; 3]], e: [f64; 4], cell: f64, (w, h): (usize, usize)) -> Vec<f32> {
    let mut bins: Vec<Vec<f64>> = vec![Vec::new(); w * h];
    for p in points {
        let c = ((p[0] - e[0]) / cell).floor();
        let r = ((e[3] - p[1]) / cell).floor();
        if c >= 0.0 && r >= 0.0 && (c as usize) < w && (r as usize) < h {
            bins[r as usize * w + c as usize].push(p[2]);
        }
    }
    bins.iter_mut()
        .map(|b| median(b).map_or(f32::NAN, |m| m as f32))
        .collect()
}

/// Fills the empty (NaN) cells ring by ring from the cells with a height: each takes the
/// mean of its 8 neighbours filled before its ring, so that beyond the points the surface
/// keeps its edge's height.
fn fill_outwards(values: &mut [f32], (w, h): (usize, usize)) {
    loop {
        let ring: Vec<(usize, f32)> = (0..w * h)
            .into_par_iter()
            .filter(|&i| values[i].is_nan())
            .filter_map(|i| neighbour_mean(values, (w, h), i).map(|m| (i, m)))
            .collect();
        if ring.is_empty() {
            return;
        }
        for (i, m) in ring {
            values[i] = m;
        }
    }
}

fn neighbour_mean(values: &[f32], (w, h): (usize, usize), i: usize) -> Option<f32> {
    let (c, r) = ((i % w) as isize, (i / w) as isize);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for dr in -1..=1 {
        for dc in -1..=1 {
            let (cc, rr) = (c + dc, r + dr);
            if cc < 0 || rr < 0 || cc >= w as isize || rr >= h as isize {
                continue;
            }
            let v = values[rr as usize * w + cc as usize];
            if v.is_finite() {
                sum += v as f64;
                n += 1;
            }
        }
    }
    (n > 0).then(|| (sum / n as f64) as f32)
}

/// A membrane stretched over the points: [`SURFACE_SWEEPS`] Jacobi sweeps of Laplace's
/// equation, each cell without a point the mean of its four neighbours, the cells with points
/// (`fixed`, NaN elsewhere) held. Between tie points the ground is then the smoothest
/// surface through them, which neither overshoots them nor steps from one to the next.
fn relaxed(mut values: Vec<f32>, fixed: &[f32], (w, h): (usize, usize)) -> Vec<f32> {
    for _ in 0..SURFACE_SWEEPS {
        values = (0..w * h)
            .into_par_iter()
            .map(|i| match fixed[i].is_finite() {
                true => fixed[i],
                false => four_mean(&values, (w, h), i),
            })
            .collect();
    }
    values
}

fn four_mean(values: &[f32], (w, h): (usize, usize), i: usize) -> f32 {
    let (c, r) = (i % w, i / w);
    let (mut sum, mut n) = (0.0f32, 0.0f32);
    for (ok, j) in [
        (c > 0, i.wrapping_sub(1)),
        (c + 1 < w, i + 1),
        (r > 0, i.wrapping_sub(w)),
        (r + 1 < h, i + w),
    ] {
        if ok {
            sum += values[j];
            n += 1.0;
        }
    }
    sum / n
}

/// RMS of the points' heights about the surface (m).
fn spread(dem: &Dem, points: &[[f64; 3]]) -> f64 {
    let (sum, n) = points
        .iter()
        .filter_map(|p| Some((p[2] - dem.height_at(p[0], p[1])?).powi(2)))
        .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
    (sum / n.max(1) as f64).sqrt()
}
