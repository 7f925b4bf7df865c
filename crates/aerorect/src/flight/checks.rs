//! The records against the images after a solve: each frame's GPS fix where the adjustment
//! moved it, and the warnings where a fix or a recorded attitude contradicts the images by
//! more than its prior allows.

use super::*;
use aerorect_solve::adjust::FrameAdjustment;

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
    /// The offset's whitened norm, less what the solved datum gives the frame (the block's
    /// common shift and GPS drift, where solved: `adjustment.frames[k].datum_offset_m`);
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
            let sigma = a.position_sigma_or(default);
            // Against what the solved datum (the block's common shift, its drift) gives
            // the frame.
            let sigmas = (0..3)
                .map(|k| ((r.position_m[k] - r.datum_offset_m[k]) / sigma[k]).powi(2))
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
            "the images contradict the GPS positions of {} frames (moved beyond {THREE_SIGMA_3D} sigma from where the block's common shift (and drift, where one was solved) puts them, three sigma of a 3-D offset; down-weighted where the weight is below 1): {}",
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

/// Three sigma of a 2-D vector: two independent N(0, sigma) components have a norm beyond
/// 3.44 sigma in 0.27 % of cases (chi-square with 2 degrees of freedom at 99.73 %: 11.83).
pub const THREE_SIGMA_2D: f64 = 3.44;

/// The least tilt (degrees) of a whole block from its recorded attitudes worth a warning,
/// however many frames pin their mean: above the usual bias of a gimbal's or an autopilot's
/// level (a degree), below the eBee's camera mounting offset (about 3 degrees against a
/// reconstruction).
pub const COMMON_TILT_FLOOR_DEG: f64 = 2.0;

/// The tilt (degrees) the images give the flight's frames in common against their recorded
/// attitudes (the mean of the turns' horizontal axes, each frame weighed by its prior; frames
/// started at nadir along their GPS track, which recorded nothing, left out), its standard
/// deviation from the priors alone, and the frames counted; `None` with fewer than three.
pub(super) fn common_tilt_deg(
    frames: &[Frame],
    adjust_frames: &[AdjustFrame],
    report: &AdjustReport,
    flight_sigma_deg: f64,
) -> Option<(f64, f64, usize)> {
    let (mut sw, mut sx, mut sy, mut n) = (0.0, 0.0, 0.0, 0);
    for ((f, a), r) in frames.iter().zip(adjust_frames).zip(&report.frames) {
        if f.info.attitude.source == crate::photo_source::AttitudeSource::GpsTrack {
            continue;
        }
        let s = a.attitude_sigma_deg.unwrap_or(flight_sigma_deg);
        let w = 1.0 / (s * s);
        (sw, sx, sy, n) = (
            sw + w,
            sx + w * r.rotation_deg[0],
            sy + w * r.rotation_deg[1],
            n + 1,
        );
    }
    (n >= 3 && sw > 0.0).then(|| ((sx / sw).hypot(sy / sw), 1.0 / sw.sqrt(), n))
}

/// A warning where the images tilt the whole flight from its recorded attitudes
/// ([`common_tilt_deg`]'s tilt, sigma and frames) beyond what their priors allow of a mean
/// ([`THREE_SIGMA_2D`] of its sigma) and beyond [`COMMON_TILT_FLOOR_DEG`]: a camera mounted
/// off the attitudes' axes, or, where `gps_levels` (nothing but the GPS heights levels the
/// block: no DEM, no ground control, and an order of the frames that cannot tell a drift from
/// a tilt), a GPS drifting in height.
pub(super) fn common_tilt_warning(
    (tilt, sigma, n): (f64, f64, usize),
    gps_levels: bool,
) -> Option<String> {
    if tilt <= (THREE_SIGMA_2D * sigma).max(COMMON_TILT_FLOOR_DEG) {
        return None;
    }
    let cause = match gps_levels {
        true => {
            "a camera mounted off the attitudes' axes (--adjust-boresight solves for it), or GPS heights that drift over the flight, which tilt a block as this one is where its strips were all flown one way (--dem or --gcps tell the two apart)"
        }
        false => "a camera mounted off the attitudes' axes (--adjust-boresight solves for it)",
    };
    Some(format!(
        "the images tilt the whole flight by {tilt:.1} deg from its recorded attitudes ({n} frames, whose mean the priors know to {sigma:.2} deg): {cause}"
    ))
}

/// The warning for a flight with no recorded attitudes that nothing but the GPS heights
/// levels (no DEM, no ground control, a block its GPS frees and spread enough for a drift
/// whose frames' order cannot tell one from a tilt): a GPS whose height drifts over the flight
/// would tilt it unseen. With recorded attitudes, [`common_tilt_warning`] measures such a tilt
/// instead.
pub(super) fn unseen_drift_warning() -> String {
    "nothing but the GPS heights levels this flight (no DEM, no ground control, no recorded attitudes), and the order its photos were taken in cannot tell a drift in those heights from a tilt (strips all flown one way): a GPS whose height drifts over the flight would tilt it unseen; --dem or --gcps would tell".to_string()
}

/// One block of a flight that falls apart: frames tied to each other and to no frame of
/// another block, so nothing but their GPS places the blocks against each other.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BlockReport {
    pub frames: Vec<String>,
    /// Image observations of the block's tie points.
    pub observations: usize,
    /// The block's own residual RMS after the adjustment (px).
    pub rms_after_px: f64,
}

/// The blocks of a flight whose reliable pairs fall into two or more sets that share no frame
/// (empty for a flight in one piece). Frames no reliable pair reaches are not in any block:
/// they are the report's unconnected frames.
pub(super) fn blocks(
    frames: &[String],
    reports: &[PairReport],
    adjusted: &[FrameAdjustment],
) -> Vec<BlockReport> {
    let index: std::collections::HashMap<&str, usize> = frames
        .iter()
        .enumerate()
        .map(|(k, f)| (f.as_str(), k))
        .collect();
    let links = reports
        .iter()
        .filter(|r| r.reliable)
        .filter_map(|r| Some((*index.get(r.a.as_str())?, *index.get(r.b.as_str())?)));
    let sets = aerorect_solve::adjust::connected_by(frames.len(), links);
    if sets.len() < 2 {
        return Vec::new();
    }
    let mut out: Vec<BlockReport> = sets
        .iter()
        .map(|set| block_report(frames, set, adjusted))
        .collect();
    out.sort_by_key(|b| std::cmp::Reverse(b.frames.len()));
    out
}

fn block_report(frames: &[String], set: &[usize], adjusted: &[FrameAdjustment]) -> BlockReport {
    let (mut n, mut sum) = (0usize, 0.0);
    for f in set.iter().filter_map(|&f| adjusted.get(f)) {
        n += f.observations;
        sum += f.observations as f64 * f.rms_after_px * f.rms_after_px;
    }
    BlockReport {
        frames: set.iter().map(|&f| frames[f].clone()).collect(),
        observations: n,
        rms_after_px: if n > 0 { (sum / n as f64).sqrt() } else { 0.0 },
    }
}

/// The warning for a flight in separate blocks (none for one in one piece).
pub(super) fn blocks_warning(blocks: &[BlockReport]) -> Option<String> {
    (blocks.len() >= 2).then(|| {
        let each: Vec<String> = blocks
            .iter()
            .map(|b| {
                format!(
                    "{} frames from {}, rms {:.2} px",
                    b.frames.len(),
                    b.frames.first().map_or("", String::as_str),
                    b.rms_after_px
                )
            })
            .collect();
        format!(
            "the flight falls into {} blocks that share no tie point ({}): each is adjusted from \
             its own ties, and only their GPS places them against each other (the report lists them \
             under blocks)",
            blocks.len(),
            each.join("; ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair(a: &str, b: &str, reliable: bool) -> PairReport {
        PairReport {
            a: a.into(),
            b: b.into(),
            patches: 0,
            inliers: 0,
            misalignment_before_m: 0.0,
            misalignment_after_m: None,
            reliable,
        }
    }

    fn frame(observations: usize, rms: f64) -> FrameAdjustment {
        FrameAdjustment {
            rotation_deg: [0.0; 3],
            rotation_sigma_deg: [0.0; 3],
            position_m: [0.0; 3],
            position_sigma_m: [0.0; 3],
            datum_offset_m: [0.0; 3],
            observations,
            rms_before_px: 0.0,
            rms_after_px: rms,
            outliers: 0,
            position_weight: 1.0,
        }
    }

    #[test]
    fn two_blocks_are_found_and_reported_each_with_its_own_rms() {
        let names: Vec<String> = ["a", "b", "c", "d", "e", "f"].map(String::from).into();
        // a-b-c tie, d-e tie, c-d only unreliably; f ties nothing.
        let reports = [
            pair("a", "b", true),
            pair("b", "c", true),
            pair("c", "d", false),
            pair("d", "e", true),
            pair("e", "f", false),
        ];
        let adjusted = [
            (10, 1.0),
            (20, 1.0),
            (10, 1.0),
            (30, 2.0),
            (10, 0.0),
            (0, 0.0),
        ]
        .map(|(n, r)| frame(n, r));
        let b = blocks(&names, &reports, &adjusted);
        assert_eq!(b.len(), 2);
        assert_eq!(b[0].frames, ["a", "b", "c"]);
        assert_eq!((b[0].observations, b[0].rms_after_px), (40, 1.0));
        assert_eq!(b[1].frames, ["d", "e"]);
        // sqrt((30 * 4 + 10 * 0) / 40).
        assert!((b[1].rms_after_px - 3.0f64.sqrt()).abs() < 1e-12);
        let w = blocks_warning(&b).unwrap_or_default();
        assert!(
            w.contains("2 blocks") && w.contains("3 frames from a"),
            "{w}"
        );
        // Joined by one more reliable pair: one block, no report and no warning.
        let mut joined = reports.to_vec();
        joined.push(pair("c", "d", true));
        assert!(blocks(&names, &joined, &adjusted).is_empty());
        assert!(blocks_warning(&[]).is_none());
    }
}
