//! The planned, checked adjustment: the points and options checked, the starting values
//! found, one adjustment run and reported.

use super::CalibrationError;
use super::inputs::{CalibrationOptions, Observation};
use super::lm::minimise;
use super::problem::Calib;
use super::report::{CalibrationReport, held_terms, report};
use super::start::{check_inside, group, start};
use nalgebra::DVector;

const INTRINSICS: [&str; 5] = ["fx", "fy", "cx", "cy", "skew"];

/// One adjustment with the options as given (`calibrate` adds the identifiability check).
pub(crate) fn calibrate_once(
    obs: &[Observation],
    opts: &CalibrationOptions,
) -> Result<CalibrationReport, CalibrationError> {
    let plan = plan(obs, opts)?;
    let mut res = minimise(
        &plan.problem,
        plan.z0.clone(),
        opts.max_iterations,
        opts.stop_px,
        point_shift,
    );
    report(&plan.problem, &mut res, &plan.global, &plan.ids, opts)
}

/// The largest change of a predicted point (pixels) for a change `dr` of the residuals.
pub(super) fn point_shift(dr: &DVector<f64>) -> f64 {
    (0..dr.len() / 2)
        .map(|i| dr[2 * i].hypot(dr[2 * i + 1]))
        .fold(0.0, f64::max)
}

/// A checked, started adjustment: the problem, its starting free vector, the global
/// parameters' names and the image ids.
pub(super) struct Plan<'a> {
    pub problem: Calib<'a>,
    pub z0: DVector<f64>,
    pub global: Vec<&'static str>,
    pub ids: Vec<String>,
}

/// Checks the points and options and finds the starting values.
pub(super) fn plan<'a>(
    obs: &'a [Observation],
    opts: &CalibrationOptions,
) -> Result<Plan<'a>, CalibrationError> {
    if obs.len() < 6 {
        return Err(CalibrationError::TooFewPoints {
            got: obs.len(),
            need: 6,
        });
    }
    let (ids, views) = group(obs, 4)?;
    if views.len() == 1 && views[0].len() < 6 {
        // One image of a 3-D field: the DLT needs six points.
        return Err(CalibrationError::TooFewInImage {
            image: ids[0].clone(),
            got: views[0].len(),
            need: 6,
        });
    }
    check_inside(obs, opts.image_size)?;
    let (k, poses) = start(obs, &views, &ids, opts)?;
    let names = opts.model.model().names();
    let mut full0 = vec![
        k[(0, 0)],
        k[(1, 1)],
        k[(0, 2)],
        k[(1, 2)],
        if opts.skew { k[(0, 1)] } else { 0.0 },
    ];
    full0.extend(opts.model.model().params());
    for p in &poses {
        full0.extend(p.w.iter().chain(p.t.iter()));
    }
    for f in &opts.fix {
        // OpenCV's twelve names are accepted for any of its variants (`--fix k4,k5,k6` on the
        // five-term model holds terms it does not have).
        let known = opts.model.all_coefficient_names();
        if !INTRINSICS.contains(&f.as_str()) && !known.contains(&f.as_str()) {
            return Err(CalibrationError::UnknownParameter(f.clone()));
        }
    }
    let held = held_terms(opts);
    let is_fixed = |name: &str| {
        opts.fix.iter().any(|f| f == name)
            || held.iter().any(|(term, _)| *term == name)
            || (name == "skew" && !opts.skew)
            || (name == "fy" && opts.fixed_aspect.is_some())
    };
    let global: Vec<&'static str> = INTRINSICS
        .iter()
        .copied()
        .chain(names.iter().copied())
        .collect();
    let free: Vec<usize> = (0..full0.len())
        .filter(|&i| i >= global.len() || !is_fixed(global[i]))
        .collect();
    let aspect = opts.fixed_aspect;
    if let Some(a) = aspect {
        full0[1] = full0[0] * a;
    }
    let z0 = DVector::from_iterator(free.len(), free.iter().map(|&i| full0[i]));
    let problem = Calib::new(obs, views, opts.model.clone(), free, full0, aspect);
    Ok(Plan {
        problem,
        z0,
        global,
        ids,
    })
}
