//! The accuracy report of a flight with ground control: every surveyed point intersected from
//! its marks through the recorded and the adjusted frames, its residuals in metres and in each
//! photo, the RMSE over control and over check points, and the ASPRS (2014) horizontal accuracy
//! class the check points meet.

use super::control::{ControlPoint, Resolved, Role};
use super::*;
use aerorect_solve::adjust::OrientedFrames;

/// A mark's residual: where the frames put the surveyed point against where it was marked.
#[derive(Debug, Clone, Serialize)]
pub struct MarkResidual {
    pub image: String,
    /// The mark's line in the GCP file.
    pub line: usize,
    pub mark_px: [f64; 2],
    pub predicted_px: Option<[f64; 2]>,
    pub residual_px: Option<f64>,
}

/// One surveyed point against the adjusted flight.
#[derive(Debug, Clone, Serialize)]
pub struct PointAccuracy {
    pub name: String,
    pub role: Role,
    /// The surveyed position in the flight's CRS (heights in the ground's vertical datum).
    pub surveyed: [f64; 3],
    /// Where the adjusted frames put it: its marks' rays intersected (two marks or more), or
    /// the one mark's ray at the surveyed height (then Z is not measured).
    pub estimated: Option<[f64; 3]>,
    /// Estimated minus surveyed, metres (Z `None` from one mark).
    pub residual_m: Option<[f64; 2]>,
    pub residual_z_m: Option<f64>,
    pub images: Vec<MarkResidual>,
}

/// Root mean square errors over a set of points, metres.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Rmse {
    /// Points with an estimate (in XY; `z_count` of them in Z).
    pub count: usize,
    pub z_count: usize,
    pub x_m: f64,
    pub y_m: f64,
    /// Radial: sqrt(x^2 + y^2).
    pub xy_m: f64,
    pub z_m: f64,
}

/// The ASPRS Positional Accuracy Standards for Digital Geospatial Data (2014), horizontal:
/// a class "N cm" is met when RMSE_x and RMSE_y are both at most N cm (Table B.3's classes).
pub const ASPRS_HORIZONTAL_CLASSES_CM: [f64; 24] = [
    0.63, 1.25, 2.5, 5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0, 22.5, 25.0, 27.5, 30.0, 45.0, 60.0,
    75.0, 100.0, 150.0, 200.0, 250.0, 300.0, 500.0, 1000.0,
];

/// The horizontal class the check points meet.
#[derive(Debug, Clone, Serialize)]
pub struct AsprsClass {
    /// The smallest class met (cm); `None` beyond 10 m.
    pub class_cm: Option<f64>,
    /// Horizontal accuracy at 95 % confidence, 1.7308 RMSE_r (NSSDA, RMSE_x ~ RMSE_y), m.
    pub accuracy_95_m: f64,
    /// The points it rests on (the standard asks for at least 20 check points).
    pub check_points: usize,
}

/// The flight's accuracy against its ground control.
#[derive(Debug, Clone, Serialize)]
pub struct AccuracyReport {
    pub file: String,
    pub points: Vec<PointAccuracy>,
    /// Over the control points, with the recorded and with the adjusted orientation.
    pub control_before: Rmse,
    pub control: Rmse,
    /// Over the check points (kept out of the solve), recorded and adjusted.
    pub check_before: Rmse,
    pub check: Rmse,
    /// From the check points; `None` without any.
    pub asprs_horizontal: Option<AsprsClass>,
    /// The frames' mean nadir ground sample distance (m), and the RMSEs in it.
    pub mean_gsd_m: f64,
    pub check_xy_gsd: Option<f64>,
    pub check_z_gsd: Option<f64>,
    /// Frames in blocks (sets the ties join) with no control point marked in them.
    pub unreached: Vec<String>,
}

/// The smallest ASPRS horizontal class RMSE_x and RMSE_y meet.
pub fn asprs_class(r: &Rmse) -> AsprsClass {
    let worst_cm = r.x_m.max(r.y_m) * 100.0;
    AsprsClass {
        class_cm: ASPRS_HORIZONTAL_CLASSES_CM
            .iter()
            .copied()
            .find(|&c| worst_cm <= c),
        accuracy_95_m: 1.7308 * r.xy_m,
        check_points: r.count,
    }
}

fn point_accuracy(p: &ControlPoint, frames: OrientedFrames<'_>, names: &[String]) -> PointAccuracy {
    let obs: Vec<Observation> = p
        .marks
        .iter()
        .map(|m| Observation {
            frame: m.frame,
            pixel: m.pixel,
            weight: 1.0,
        })
        .collect();
    let (estimated, z) = match (frames.intersect(&obs, p.ground), p.marks.first()) {
        (Some(x), _) => (Some(x), true),
        (None, Some(m)) if p.marks.len() == 1 => {
            (frames.ray_at_height(m.frame, m.pixel, p.ground[2]), false)
        }
        _ => (None, false),
    };
    let images = p
        .marks
        .iter()
        .map(|m| {
            let predicted = frames.pixel_of(m.frame, p.ground);
            MarkResidual {
                image: names[m.frame].clone(),
                line: m.line,
                mark_px: m.pixel,
                predicted_px: predicted,
                residual_px: predicted.map(|q| (q[0] - m.pixel[0]).hypot(q[1] - m.pixel[1])),
            }
        })
        .collect();
    PointAccuracy {
        name: p.name.clone(),
        role: p.role,
        surveyed: p.ground,
        estimated,
        residual_m: estimated.map(|e| [e[0] - p.ground[0], e[1] - p.ground[1]]),
        residual_z_m: estimated.filter(|_| z).map(|e| e[2] - p.ground[2]),
        images,
    }
}

/// The RMSE of the points of `role`.
pub fn rmse(points: &[PointAccuracy], role: Role) -> Rmse {
    let mut r = Rmse::default();
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for p in points.iter().filter(|p| p.role == role) {
        if let Some([dx, dy]) = p.residual_m {
            r.count += 1;
            (x, y) = (x + dx * dx, y + dy * dy);
        }
        if let Some(dz) = p.residual_z_m {
            r.z_count += 1;
            z += dz * dz;
        }
    }
    let n = r.count.max(1) as f64;
    (r.x_m, r.y_m) = ((x / n).sqrt(), (y / n).sqrt());
    r.xy_m = r.x_m.hypot(r.y_m);
    r.z_m = (z / r.z_count.max(1) as f64).sqrt();
    r
}

/// The accuracy of the recorded (`before`) and the adjusted (`after`) frames against the
/// control; `ties` (the round's) tell which frames a control point reaches.
pub(super) fn accuracy_report(
    control: &Resolved,
    (before, after): (OrientedFrames<'_>, OrientedFrames<'_>),
    frames: &[Frame],
    ties: &[TiePoint],
) -> AccuracyReport {
    let names: Vec<String> = frames
        .iter()
        .map(|f| f.input.display().to_string())
        .collect();
    let points: Vec<PointAccuracy> = control
        .points
        .iter()
        .map(|p| point_accuracy(p, after, &names))
        .collect();
    let recorded: Vec<PointAccuracy> = control
        .points
        .iter()
        .map(|p| point_accuracy(p, before, &names))
        .collect();
    let check = rmse(&points, Role::Check);
    let mean_gsd_m = frames.iter().map(|f| f.info.gsd_m).sum::<f64>() / frames.len().max(1) as f64;
    let marked: Vec<usize> = control
        .points
        .iter()
        .filter(|p| p.role == Role::Control)
        .flat_map(|p| p.marks.iter().map(|m| m.frame))
        .collect();
    let unreached = unreached(frames.len(), ties, &marked)
        .into_iter()
        .map(|k| names[k].clone())
        .collect();
    AccuracyReport {
        file: control.file.clone(),
        control_before: rmse(&recorded, Role::Control),
        control: rmse(&points, Role::Control),
        check_before: rmse(&recorded, Role::Check),
        check,
        asprs_horizontal: (check.count > 0).then(|| asprs_class(&check)),
        check_xy_gsd: (check.count > 0).then(|| check.xy_m / mean_gsd_m),
        check_z_gsd: (check.z_count > 0).then(|| check.z_m / mean_gsd_m),
        mean_gsd_m,
        points,
        unreached,
    }
}

/// The frames of the blocks the ties join (single frames too) with no marked frame in them.
fn unreached(frames: usize, ties: &[TiePoint], marked: &[usize]) -> Vec<usize> {
    let mut sets = aerorect_solve::adjust::connected(frames, ties);
    let tied: std::collections::BTreeSet<usize> = sets.iter().flatten().copied().collect();
    sets.extend((0..frames).filter(|f| !tied.contains(f)).map(|f| vec![f]));
    let mut out: Vec<usize> = sets
        .into_iter()
        .filter(|s| !s.iter().any(|f| marked.contains(f)))
        .flatten()
        .collect();
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(role: Role, xy: Option<[f64; 2]>, z: Option<f64>) -> PointAccuracy {
        PointAccuracy {
            name: "p".into(),
            role,
            surveyed: [0.0; 3],
            estimated: None,
            residual_m: xy,
            residual_z_m: z,
            images: vec![],
        }
    }

    #[test]
    fn rmse_counts_z_only_where_measured_and_keeps_roles_apart() {
        let pts = [
            point(Role::Check, Some([0.3, 0.0]), Some(0.2)),
            point(Role::Check, Some([0.0, 0.4]), None),
            point(Role::Control, Some([10.0, 10.0]), Some(10.0)),
        ];
        let r = rmse(&pts, Role::Check);
        assert_eq!((r.count, r.z_count), (2, 1));
        assert!((r.x_m - (0.09f64 / 2.0).sqrt()).abs() < 1e-12);
        assert!((r.y_m - (0.16f64 / 2.0).sqrt()).abs() < 1e-12);
        assert!((r.xy_m - (0.25f64 / 2.0).sqrt()).abs() < 1e-12);
        assert!((r.z_m - 0.2).abs() < 1e-12);
    }

    #[test]
    fn the_asprs_class_is_the_smallest_that_holds_the_larger_axis() {
        let at = |x: f64, y: f64| {
            asprs_class(&Rmse {
                count: 20,
                x_m: x,
                y_m: y,
                xy_m: x.hypot(y),
                ..Rmse::default()
            })
        };
        assert_eq!(at(0.04, 0.03).class_cm, Some(5.0));
        assert_eq!(
            at(0.03, 0.05).class_cm,
            Some(5.0),
            "a class holds its own value"
        );
        assert_eq!(at(0.051, 0.0).class_cm, Some(7.5));
        assert_eq!(at(0.005, 0.006).class_cm, Some(0.63));
        assert_eq!(at(12.0, 1.0).class_cm, None, "beyond 10 m");
        // NSSDA: 95 % is 1.7308 RMSE_r (ASPRS 2014, Annex D).
        assert!((at(0.3, 0.4).accuracy_95_m - 1.7308 * 0.5).abs() < 1e-12);
    }
}
