//! The misalignment of two georeferenced frames on one grid, measured on their overlap with
//! the phase correlator.

use crate::Error;
use aerorect_core::error::Num;
use aerorect_io::GeoReference;
use serde::Serialize;

/// The misalignment of two georeferenced frames on one grid, measured on their overlap.
#[derive(Debug, Clone, Serialize)]
pub struct OverlapShift {
    /// Patches matched (both frames valid and textured, a clear correlation peak).
    pub patches: usize,
    /// Median shift of B relative to A, pixels (x east, y south) and metres (east, north).
    pub median_px: [f64; 2],
    pub median_m: [f64; 2],
    /// RMS of the patch shifts' length, pixels.
    pub rms_px: f64,
    pub gsd_m: f64,
    pub overlap_px: [usize; 2],
}

/// Offset of B's pixel grid in A's pixels; refused unless it is whole pixels (within 1e-6
/// px): grids half a pixel apart are two grids, and rounding the offset away would report
/// that half pixel as the frames' misalignment.
fn grid_offset(
    a: &std::path::Path,
    b: &std::path::Path,
    ga: &GeoReference,
    gb: &GeoReference,
) -> Result<[i64; 2], Error> {
    let gsd = ga.pixel_size[0];
    let off = [
        (gb.top_left[0] - ga.top_left[0]) / gsd,
        (ga.top_left[1] - gb.top_left[1]) / gsd,
    ];
    let frac = off.map(|o| o - o.round());
    if frac.iter().all(|f| f.abs() <= 1e-6) && off.iter().all(|o| o.abs() < 1e12) {
        return Ok(off.map(|o| o.round() as i64));
    }
    Err(Error::Invalid(format!(
        "{} and {} are not on one grid: origins ({}, {}) and ({}, {}) differ by \
         ({:.3}, {:.3}) pixels of {} m, off whole pixels by {} px, {} px",
        a.display(),
        b.display(),
        ga.top_left[0],
        ga.top_left[1],
        gb.top_left[0],
        gb.top_left[1],
        off[0],
        off[1],
        gsd,
        Num(frac[0].abs()),
        Num(frac[1].abs()),
    )))
}

/// Measures where frame B's content sits relative to frame A's over their common area, with
/// the phase correlator on `patch` x `patch` tiles. Both must share a CRS and GSD.
pub fn overlap_shift(
    a: &std::path::Path,
    b: &std::path::Path,
    patch: usize,
) -> Result<OverlapShift, Error> {
    use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
    let geo = |p: &std::path::Path| -> Result<GeoReference, Error> {
        aerorect_io::read_georeference(p)?.ok_or_else(|| {
            Error::Invalid(format!(
                "{}: not georeferenced (no GeoTIFF keys, no world file)",
                p.display()
            ))
        })
    };
    let (ga, gb) = (geo(a)?, geo(b)?);
    if !ga.crs.same_as(&gb.crs)
        || (ga.pixel_size[0] - gb.pixel_size[0]).abs() > 1e-9 * ga.pixel_size[0]
    {
        return Err(Error::Invalid(format!(
            "{} and {} are not on one grid (CRS {} / {}, GSD {} / {})",
            a.display(),
            b.display(),
            ga.crs,
            gb.crs,
            ga.pixel_size[0],
            gb.pixel_size[0]
        )));
    }
    let gsd = ga.pixel_size[0];
    let ia = crate::motion::gray(&aerorect_io::read_image(a)?)?;
    let ib = crate::motion::gray(&aerorect_io::read_image(b)?)?;
    let off = grid_offset(a, b, &ga, &gb)?;
    let (sa, sb) = (ia.size(), ib.size());
    let [x0, y0, x1, y1] = aerorect_geo::common_window(sa, sb, off);
    if x1 - x0 < patch as i64 || y1 - y0 < patch as i64 {
        return Err(Error::Invalid(
            "the frames do not overlap by one patch".into(),
        ));
    }
    let mut pc = PhaseCorrelator::new(
        patch,
        patch,
        PhaseOptions {
            weighting: Weighting::Phase,
            window: true,
            smooth: 0.0,
        },
    )
    .map_err(Error::from)?;
    let (mut pa, mut pb) = (vec![0f32; patch * patch], vec![0f32; patch * patch]);
    let mut shifts = Vec::new();
    let step = patch as i64;
    let mut y = y0;
    while y + step <= y1 {
        let mut x = x0;
        while x + step <= x1 {
            for r in 0..patch {
                let ra = (y as usize + r) * sa.width + x as usize;
                let rb = (y - off[1]) as usize * sb.width + r * sb.width + (x - off[0]) as usize;
                pa[r * patch..(r + 1) * patch].copy_from_slice(&ia.plane(0)[ra..ra + patch]);
                pb[r * patch..(r + 1) * patch].copy_from_slice(&ib.plane(0)[rb..rb + patch]);
            }
            // Tiles with nodata (0) in either frame are not compared.
            let valid = !pa.iter().chain(pb.iter()).any(|&v| v == 0.0);
            if valid
                && let Ok(e) = pc.estimate(&pa, &pb)
                && e.confidence > 0.05
                && e.dx.abs().max(e.dy.abs()) < patch as f64 / 4.0
            {
                shifts.push([e.dx, e.dy]);
            }
            x += step;
        }
        y += step;
    }
    if shifts.is_empty() {
        return Err(Error::Invalid(
            "no overlapping patch could be matched".into(),
        ));
    }
    let median = |d: usize| {
        let mut v: Vec<f64> = shifts.iter().map(|s| s[d]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (mx, my) = (median(0), median(1));
    let rms = (shifts
        .iter()
        .map(|s| s[0] * s[0] + s[1] * s[1])
        .sum::<f64>()
        / shifts.len() as f64)
        .sqrt();
    Ok(OverlapShift {
        patches: shifts.len(),
        median_px: [mx, my],
        median_m: [mx * gsd, -my * gsd],
        rms_px: rms,
        gsd_m: gsd,
        overlap_px: [(x1 - x0) as usize, (y1 - y0) as usize],
    })
}
