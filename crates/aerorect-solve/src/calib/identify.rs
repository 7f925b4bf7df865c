//! Terms the data cannot determine: a model's optional coefficient groups (OpenCV's rational
//! k4..k6 and thin-prism s1..s4) are fitted only when the points separate them from the rest.
//! A group is undetermined when one of its terms correlates with another free parameter by
//! |rho| >= 0.9999 (or the normal equations are singular): on a planar target seen by a
//! moderate lens the rational denominator duplicates k1..k3 (k1 and k4 correlate +0.999999 on
//! OpenCV's chessboard, with standard deviations of 20 for coefficients of 0.3). The group is
//! then held at its starting values and the adjustment rerun, with a warning naming the
//! correlation; the result is the smaller model's. A wide lens (r to 1.1) seen as a 3-D field in three
//! views correlates them at 0.9990 and keeps them free.

use super::CalibrationError;
use super::inputs::{CalibrationOptions, Observation};
use super::plan::calibrate_once;
use super::report::CalibrationReport;

/// Correlation above which a term is taken as undetermined.
const UNDETERMINED_RHO: f64 = 0.9999;

/// Calibrates a camera from control points (see the module documentation), holding the
/// model's optional terms at their starting values when the data cannot determine them.
pub fn calibrate(
    obs: &[Observation],
    opts: &CalibrationOptions,
) -> Result<CalibrationReport, CalibrationError> {
    let groups: Vec<(&str, &[&str])> = opts
        .model
        .optional_groups()
        .into_iter()
        .filter(|(_, terms)| terms.iter().any(|t| !opts.fix.iter().any(|f| f == t)))
        .collect();
    if groups.is_empty() {
        return calibrate_once(obs, opts);
    }
    let (held, why): (Vec<(&str, &[&str])>, Vec<String>) = match calibrate_once(obs, opts) {
        Ok(r) => {
            let found: Vec<_> = groups
                .iter()
                .filter_map(|g| undetermined(&r, g.1).map(|why| (*g, why)))
                .collect();
            if found.is_empty() {
                return Ok(r);
            }
            found.into_iter().unzip()
        }
        Err(CalibrationError::Singular(_)) => {
            let why = vec!["the normal equations are singular".to_string(); groups.len()];
            (groups, why)
        }
        Err(e) => return Err(e),
    };
    let mut o = opts.clone();
    for (_, terms) in &held {
        o.fix.extend(terms.iter().map(|t| t.to_string()));
    }
    let mut r = calibrate_once(obs, &o)?;
    for ((name, terms), why) in held.iter().zip(why) {
        r.warnings.push(format!(
            "{} (the {name} terms) held at their start: these points cannot determine them ({why}); \
             a 3-D field or views reaching further into the image corners can",
            terms.join(", ")
        ));
    }
    Ok(r)
}

/// Why a group's terms are undetermined in `r`, if they are.
fn undetermined(r: &CalibrationReport, terms: &[&str]) -> Option<String> {
    r.correlations
        .iter()
        .filter(|c| terms.contains(&c.a.as_str()) || terms.contains(&c.b.as_str()))
        .filter(|c| c.rho.abs() >= UNDETERMINED_RHO)
        .max_by(|a, b| a.rho.abs().total_cmp(&b.rho.abs()))
        .map(|c| format!("{} and {} correlated {:+.6}", c.a, c.b, c.rho))
}
