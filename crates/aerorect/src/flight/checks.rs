//! The records against the images after a solve: each frame's GPS fix where the adjustment
//! moved it, and the warnings where a fix or a recorded attitude contradicts the images by
//! more than its prior allows.

use super::*;

/// Three sigma of a 3-D vector: three independent N(0, sigma) components have a norm beyond
/// 3.76 sigma in 0.27 % of cases (chi-square with 3 degrees of freedom at 99.73 %: 14.16), as
/// one beyond 3 sigma. A fix's 3-D offset or a frame's 3-D turn compared with 3 sigma would be
/// flagged by chance in 3 % of frames (three frames of a hundred).
pub const THREE_SIGMA_3D: f64 = 3.76;

/// A frame's GPS position against the images: where the adjustment moved it, in metres and
/// in its prior's sigmas.
#[derive(Debug, Clone, Serialize)]
pub struct GpsCheck {
    pub frame: String,
    pub offset_m: [f64; 3],
    pub prior_sigma_m: [f64; 3],
    /// The offset's whitened norm (less the block's common shift, where one was solved);
    /// above [`THREE_SIGMA_3D`] the images contradict the fix.
    pub sigmas: f64,
    pub contradicted: bool,
    /// The weight the solve left the fix (below 1: down-weighted, the images won).
    pub weight: f64,
}

/// Every frame whose position was adjusted, against its prior (none when positions are held).
pub(super) fn gps_checks(
    frames: &[Frame],
    adjust_frames: &[AdjustFrame],
    report: &AdjustReport,
    default_sigma_m: Option<f64>,
) -> Vec<GpsCheck> {
    let Some(default) = default_sigma_m else {
        return vec![];
    };
    frames
        .iter()
        .zip(adjust_frames)
        .zip(&report.frames)
        .map(|((f, a), r)| {
            let sigma = a.position_sigma_m.unwrap_or([default; 3]);
            // Against the block's common shift where one was solved.
            let shift = report.datum.as_ref().map_or([0.0; 3], |d| d.shift_m);
            let sigmas = (0..3)
                .map(|k| ((r.position_m[k] - shift[k]) / sigma[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            GpsCheck {
                frame: f.input.display().to_string(),
                offset_m: r.position_m,
                prior_sigma_m: sigma,
                sigmas,
                contradicted: sigmas > THREE_SIGMA_3D,
                weight: r.position_weight,
            }
        })
        .collect()
}

/// Warnings where the images contradict the records by more than their priors allow: GPS
/// fixes moved beyond three sigmas, attitudes turned beyond three of their prior's sigmas (both
/// 3-D, so three sigma is [`THREE_SIGMA_3D`]).
pub(super) fn contradictions(
    frames: &[Frame],
    adjust_frames: &[AdjustFrame],
    report: &AdjustReport,
    fo: &FlightOptions,
    gps: &[GpsCheck],
) -> Vec<String> {
    let mut out = vec![];
    let moved: Vec<String> = gps
        .iter()
        .filter(|g| g.contradicted)
        .map(|g| {
            let d = g.offset_m;
            let m = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            format!(
                "{} ({m:.1} m, {:.1} sigma, weight {:.2})",
                g.frame, g.sigmas, g.weight
            )
        })
        .collect();
    if !moved.is_empty() {
        out.push(format!(
            "the images contradict the GPS positions of {} frames (moved beyond {THREE_SIGMA_3D} sigma from the block's common shift, three sigma of a 3-D offset; down-weighted where the weight is below 1): {}",
            moved.len(),
            moved.join(", ")
        ));
    }
    let turned: Vec<String> = frames
        .iter()
        .zip(adjust_frames)
        .zip(&report.frames)
        .filter_map(|((f, a), r)| {
            let prior = a.attitude_sigma_deg.unwrap_or(fo.attitude_sigma_deg);
            let w = r.rotation_deg;
            let turn = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            (turn > THREE_SIGMA_3D * prior).then(|| {
                format!(
                    "{} ({turn:.1} deg against a prior of {prior} deg)",
                    f.input.display()
                )
            })
        })
        .collect();
    if !turned.is_empty() {
        out.push(format!(
            "the recorded attitudes of {} frames contradict the images by more than {THREE_SIGMA_3D} times their prior (three sigma of a 3-D turn): {}",
            turned.len(),
            turned.join(", ")
        ));
    }
    out
}
