//! How firmly a flight without a DEM holds its tie points to the level ground.
//!
//! The level ground is a guess: over hills, every tie is a real point of the relief. It does
//! one job the images cannot: it levels a block whose GPS cannot decide its tilt (a single
//! strip, whose fixes lie on a line; a pair; frames from one point). Where a block's fixes
//! spread in two directions, they decide the tilt, and holding thousands of ties to a level
//! plane only pulls the block towards the relief's own mean slope. On the simulated fixed
//! wing (100 frames, GPS only, hills of 25 +- 26 m under a 105 m flight), ties held at
//! [`RELIEF_SIGMA_M`] left the frames 3.68 deg from the truth (median; 1.71 deg once their
//! common turn is taken out), held at [`FREE_RELIEF_SIGMA_M`] 0.38 deg (0.05 deg), and the
//! snowpeak strips, pairs and four-frame block need the level ground to stay upright.
//!
//! Ground control decides a block's tilt and height as a GPS does, and better: a block whose
//! control points decide its tilt is freed too, and the slope of its ties is the ground's,
//! however steep (the check below is for a GPS's drift).
//!
//! A GPS can also tilt a block that is level: a consumer receiver whose altitude drifts
//! 110 m over the same simulated flight tilted the freed block 14 deg (frames 14.4 deg off);
//! its ties then lie on a plane steeper than ground under a survey block is
//! ([`MAX_BLOCK_SLOPE_DEG`]), and the block solved on the level ground again is 5.7 deg off,
//! as before the blocks were freed (a DEM decides: 0.41 deg). Where the strips were flown in
//! an order that tells such a drift from a tilt, the drift is solved instead and the block
//! stays freed ([`super::drift`]: the same flight 0.83 deg off); this check remains for the
//! flights whose order does not.

use super::*;

/// A block's GPS decides its tilt when it does so to within this (degrees, one standard
/// deviation, [`gps_tilt_sigma_rad`]): the relief's own mean slope under a block, which
/// the level ground would impose instead, is degrees in hills (3.5 deg under the simulated
/// fixed wing).
pub const GPS_TILT_SIGMA_DEG: f64 = 1.0;

/// The standard deviation (m) a tie is held to the level ground with in a block whose GPS
/// decides its tilt: free in practice, but the ties of frames from one point still have a
/// depth.
pub const FREE_RELIEF_SIGMA_M: f64 = 1000.0;

/// A block freed from the level ground whose adjusted ties lie on a plane steeper than this
/// (degrees) was tilted by its GPS, not by its ground: it is solved again on the level ground.
/// The mean slope under a survey block is a few degrees in hill country (3.5 deg under the
/// simulated fixed wing); a consumer GPS whose altitude drifts 110 m over the same flight
/// (`bench/sim_flight.py`, SIM_FLIGHT_GPS_DRIFT) tilted it 14 deg.
pub const MAX_BLOCK_SLOPE_DEG: f64 = 8.0;

/// At most this many ties of a block are intersected to find its ground's slope.
const SLOPE_SAMPLE: usize = 2000;

/// How firmly a flight without a DEM holds each frame's ties to the level ground, and the
/// blocks it frees from it.
pub(super) struct Relief {
    /// Each frame's relief standard deviation (m).
    pub(super) sigmas_m: Vec<f64>,
    /// The blocks (frames the ties connect, each sorted) held at [`FREE_RELIEF_SIGMA_M`]
    /// because their GPS decides their tilt: their slope may be the GPS's drift
    /// ([`FlightPlan::level_steep_blocks`]).
    pub(super) freed: Vec<Vec<usize>>,
    /// The same for the blocks ground control holds ([`FlightPlan::control_holds`]): their
    /// slope is the ground's.
    pub(super) held: Vec<Vec<usize>>,
}

impl Relief {
    /// Whether any block is freed from the level ground.
    pub(super) fn any_freed(&self) -> bool {
        !self.freed.is_empty() || !self.held.is_empty()
    }
}

impl FlightPlan {
    /// The relief without a DEM: [`FREE_RELIEF_SIGMA_M`] in a block (frames that `ties`
    /// connect) whose recorded positions decide its tilt ([`GPS_TILT_SIGMA_DEG`]) or whose
    /// control points do ([`Self::control_holds`]), else [`RELIEF_SIGMA_M`].
    pub(super) fn relief(&self, ties: &[TiePoint]) -> Relief {
        let mut out = Relief {
            sigmas_m: vec![RELIEF_SIGMA_M; self.len()],
            freed: Vec::new(),
            held: Vec::new(),
        };
        for block in aerorect_solve::adjust::connected(self.len(), ties) {
            let centres: Vec<[f64; 2]> = block
                .iter()
                .map(|&k| {
                    let c = self.rec.poses[k].centre;
                    [c[0], c[1]]
                })
                .collect();
            // The block's loosest fix (a held position counts as exact).
            let sigma = block
                .iter()
                .map(|&k| self.frame_position_sigma_m(k).unwrap_or(0.0))
                .fold(0.0, f64::max);
            let decided = gps_tilt_sigma_rad(&centres, sigma) < GPS_TILT_SIGMA_DEG.to_radians();
            let list = match (self.control_holds(&block), decided) {
                (true, _) => &mut out.held,
                (false, true) => &mut out.freed,
                (false, false) => continue,
            };
            for &k in &block {
                out.sigmas_m[k] = FREE_RELIEF_SIGMA_M;
            }
            list.push(block);
        }
        out
    }
}

impl FlightPlan {
    /// Whether ground control fixes `block`'s tilt and height: the control points (not check
    /// points) marked in its frames decide its tilt as a block's GPS would
    /// ([`GPS_TILT_SIGMA_DEG`], with their surveys' loosest sigma). The level ground would
    /// otherwise pull the block towards the relief's mean height against them: on the
    /// simulated 5 x 4 nadir block with five GCPs, held at [`RELIEF_SIGMA_M`], the control
    /// points ended 7.2 m off in height (0.11 m over the DEM).
    fn control_holds(&self, block: &[usize]) -> bool {
        let Some(c) = &self.control else {
            return false;
        };
        let points: Vec<&control::ControlPoint> = c
            .points
            .iter()
            .filter(|p| p.role == control::Role::Control)
            .filter(|p| {
                p.marks
                    .iter()
                    .any(|m| block.binary_search(&m.frame).is_ok())
            })
            .collect();
        let xy: Vec<[f64; 2]> = points.iter().map(|p| [p.ground[0], p.ground[1]]).collect();
        let sigma = points.iter().flat_map(|p| p.sigma_m).fold(0.0, f64::max);
        gps_tilt_sigma_rad(&xy, sigma) < GPS_TILT_SIGMA_DEG.to_radians()
    }

    /// The blocks `relief` frees by their GPS ([`Relief::freed`]; not those ground control
    /// holds, whose slope is the ground's) whose `adjusted` ties lie on a plane steeper than
    /// [`MAX_BLOCK_SLOPE_DEG`]: each frame's relief sigma with those blocks held to the level
    /// ground again, and a warning naming them; none when no block is that steep.
    pub(super) fn level_steep_blocks(
        &self,
        relief: &Relief,
        ties: &[TiePoint],
        adjusted: &aerorect_solve::adjust::Adjusted,
    ) -> Option<(Vec<f64>, String)> {
        let mut levelled = relief.sigmas_m.clone();
        let mut steep = Vec::new();
        // A block ground control holds is not among them: on the simulated 5 x 4 block over
        // a 12-degree ramp, levelled again, its check points ended 6.8 m off in height.
        for block in &relief.freed {
            let Some(&first) = block.first() else {
                continue;
            };
            let slope = block_slope_deg(block, ties, adjusted);
            if slope.is_some_and(|s| s > MAX_BLOCK_SLOPE_DEG) {
                for &k in block {
                    levelled[k] = RELIEF_SIGMA_M;
                }
                steep.push(format!(
                    "{} frames from {} ({:.1} deg)",
                    block.len(),
                    self.frames[first].input.display(),
                    slope.unwrap_or(f64::NAN)
                ));
            }
        }
        (!steep.is_empty()).then(|| {
            (
                levelled,
                format!(
                    "the GPS tilts the ground under {} by more than {MAX_BLOCK_SLOPE_DEG} deg: \
                     taken as the GPS's drift, not the ground's slope, and solved on the level \
                     ground instead (give --dem to decide)",
                    steep.join(", ")
                ),
            )
        })
    }
}

/// The slope (degrees) of the ground under a block: of the plane through a sample of its
/// ties where the `adjusted` frames' rays meet ([`robust_slope_deg`]: a false match can meet
/// anywhere); `None` with fewer than three points or no plane.
fn block_slope_deg(
    block: &[usize],
    ties: &[TiePoint],
    adjusted: &aerorect_solve::adjust::Adjusted,
) -> Option<f64> {
    let origin = adjusted.frames.get(*block.first()?)?.centre;
    let own: Vec<&TiePoint> = ties
        .iter()
        .filter(|t| {
            t.observations
                .first()
                .is_some_and(|o| block.binary_search(&o.frame).is_ok())
        })
        .collect();
    let step = own.len().div_ceil(SLOPE_SAMPLE).max(1);
    let oriented = adjusted.oriented();
    let points: Vec<[f64; 3]> = own
        .iter()
        .step_by(step)
        .filter_map(|t| oriented.intersect(&t.observations, t.ground))
        .map(|x| [x[0] - origin[0], x[1] - origin[1], x[2] - origin[2]])
        .collect();
    robust_slope_deg(&points)
}

/// The slope (degrees) of the plane through `points`, fitted again without the points beyond
/// three robust standard deviations of the first fit.
fn robust_slope_deg(points: &[[f64; 3]]) -> Option<f64> {
    let plane = fit_plane(points)?;
    let off = |p: &[f64; 3]| (p[2] - plane[0] * p[0] - plane[1] * p[1] - plane[2]).abs();
    let mut offs: Vec<f64> = points.iter().map(off).collect();
    offs.sort_by(f64::total_cmp);
    let limit = 3.0 * 1.4826 * offs[offs.len() / 2];
    let kept: Vec<[f64; 3]> = points.iter().copied().filter(|p| off(p) <= limit).collect();
    let plane = fit_plane(&kept)?;
    Some(plane[0].hypot(plane[1]).atan().to_degrees())
}

/// The plane `z = a x + b y + c` through `points` by least squares: `[a, b, c]`; `None`
/// with fewer than three points or points on a line.
fn fit_plane(points: &[[f64; 3]]) -> Option<[f64; 3]> {
    if points.len() < 3 {
        return None;
    }
    let (mut a, mut b) = (
        nalgebra::Matrix3::<f64>::zeros(),
        nalgebra::Vector3::zeros(),
    );
    for p in points {
        let row = nalgebra::Vector3::new(p[0], p[1], 1.0);
        a += row * row.transpose();
        b += row * p[2];
    }
    let eigen = a.symmetric_eigenvalues();
    if eigen.min() <= 1e-10 * eigen.max() {
        return None;
    }
    let x = a.cholesky()?.solve(&b);
    Some([x[0], x[1], x[2]])
}

/// The standard deviation (radians) of the tilt that GPS fixes of `sigma_m` at `centres`
/// (x, y) decide: the least steep plane through them, `sigma / sqrt(n lambda)` with `lambda`
/// the smaller eigenvalue of the centres' covariance; infinite for fewer than three or
/// collinear centres.
pub(super) fn gps_tilt_sigma_rad(centres: &[[f64; 2]], sigma_m: f64) -> f64 {
    let n = centres.len() as f64;
    if centres.len() < 3 {
        return f64::INFINITY;
    }
    let mean = centres
        .iter()
        .fold([0.0, 0.0], |m, c| [m[0] + c[0] / n, m[1] + c[1] / n]);
    let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
    for p in centres {
        let (dx, dy) = (p[0] - mean[0], p[1] - mean[1]);
        a += dx * dx / n;
        b += dx * dy / n;
        c += dy * dy / n;
    }
    let eigen = nalgebra::Matrix2::new(a, b, b, c).symmetric_eigenvalues();
    let lambda = eigen.min();
    match lambda > 1e-12 * eigen.max() {
        true => sigma_m / (n * lambda).sqrt(),
        false => f64::INFINITY,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tilt fitted by least squares through heights with noise sigma over these centres
    /// has, about the axis along the spread, the standard deviation `sigma / sqrt(sum d^2)`,
    /// `d` the distances across it: a grid and its rotation agree with that closed form, and
    /// a line or a pair decides nothing.
    #[test]
    fn gps_tilt_sigma_is_the_plane_fits_closed_form() {
        // 10 x 3 frames, 20 m apart along x, 40 m across: across distances -40, 0, 40.
        let grid: Vec<[f64; 2]> = (0..30)
            .map(|i| [(i % 10) as f64 * 20.0, (i / 10) as f64 * 40.0])
            .collect();
        let want = 5.0 / (10.0 * (2.0 * 40.0f64.powi(2))).sqrt();
        let got = gps_tilt_sigma_rad(&grid, 5.0);
        assert!((got - want).abs() < 1e-12 * want, "{got} {want}");
        let (s, c) = 0.6f64.sin_cos();
        let turned: Vec<[f64; 2]> = grid
            .iter()
            .map(|p| [c * p[0] - s * p[1] + 500.0, s * p[0] + c * p[1] - 70.0])
            .collect();
        let again = gps_tilt_sigma_rad(&turned, 5.0);
        assert!((again - want).abs() < 1e-9 * want, "{again} {want}");
        let line: Vec<[f64; 2]> = (0..10).map(|i| [i as f64 * 3.0, i as f64 * 4.0]).collect();
        assert!(gps_tilt_sigma_rad(&line, 5.0).is_infinite());
        assert!(gps_tilt_sigma_rad(&grid[..2], 5.0).is_infinite());
        assert_eq!(gps_tilt_sigma_rad(&grid, 0.0), 0.0);
    }

    /// Points on hills over a plane of known slope, with false matches far off it: the
    /// robust fit finds the plane's slope, the plain least squares does not.
    #[test]
    fn robust_slope_finds_the_plane_under_hills_and_false_matches() {
        let (a, b) = (0.12f64, -0.05f64); // slope atan(0.13) = 7.41 deg
        let want = a.hypot(b).atan().to_degrees();
        let mut points: Vec<[f64; 3]> = (0..400)
            .map(|i| {
                let (x, y) = ((i % 20) as f64 * 15.0, (i / 20) as f64 * 12.0);
                let hill = 4.0 * (x / 37.0).sin() * (y / 29.0).cos();
                [x, y, a * x + b * y + 30.0 + hill]
            })
            .collect();
        let clean = robust_slope_deg(&points).unwrap_or(f64::NAN);
        assert!((clean - want).abs() < 0.1, "{clean} {want}");
        for k in 0..20 {
            points[k * 7][2] += 400.0 + 30.0 * k as f64;
        }
        let plain = fit_plane(&points).map(|p| p[0].hypot(p[1]).atan().to_degrees());
        assert!(plain.is_some_and(|s| (s - want).abs() > 1.0), "{plain:?}");
        let got = robust_slope_deg(&points).unwrap_or(f64::NAN);
        assert!((got - want).abs() < 0.1, "{got} {want}");
        assert!(fit_plane(&points[..2]).is_none());
        let line: Vec<[f64; 3]> = (0..9).map(|i| [i as f64, 2.0 * i as f64, 1.0]).collect();
        assert!(fit_plane(&line).is_none());
    }
}
