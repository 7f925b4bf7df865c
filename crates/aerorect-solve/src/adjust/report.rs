//! The adjustment's statistics and its adjusted frames and cameras.

use super::blocks::{CameraParam, DatumParam, FrameParam, Param, State};
use super::residuals::{Problem, world_from_camera};
use super::solve::Storage;
use super::{
    AdjustFrame, AdjustReport, Adjusted, CameraAdjustment, Datum, DatumAdjustment, FrameAdjustment,
    GaugeHold, GpsDrift, Termination,
};

/// Residual RMS per frame (with counts and outliers) and overall.
pub(super) type Rms = (Vec<(f64, usize, usize)>, f64);

/// Standard deviations by parameter.
pub(super) type Sigmas = std::collections::HashMap<Param, f64>;

/// What the solve gave, for the report.
pub(super) struct Fit {
    pub before: Rms,
    pub after: Rms,
    /// One per free parameter, by [`Param`] (held ones have none: 0). A map: looked up per
    /// frame in a list, they grew with the square of the frames.
    pub sigmas: Sigmas,
    pub iterations: usize,
    pub termination: Termination,
    pub gauge: Vec<GaugeHold>,
    pub t0: std::time::Instant,
    /// Each frame's robust position weight at the end.
    pub position_weights: Vec<f64>,
}

/// Standard deviations of the free parameters: the diagonal of the reduced system's inverse
/// (Gauss-Newton, undamped), scaled by the a-posteriori variance factor. The normal
/// equations are formed in the solve's `storage`, and factorised with its symbolic factor.
pub(super) fn standard_deviations(p: &Problem<'_>, s: &State, storage: Storage) -> Sigmas {
    let free: Vec<(usize, Param)> = p.layout.free().collect();
    let nan = || free.iter().map(|&(_, q)| (q, f64::NAN)).collect();
    let Some(lin) = p.linear(s, storage.linear) else {
        return nan();
    };
    let mut inverses = storage.inverses;
    let (entries, _) = lin.reduced(0.0, &mut inverses);
    let mut factoriser = storage.factoriser;
    let factor = factoriser.factor(p.layout.len(), &entries, faer::Par::Seq);
    let Some(variances) = factor.and_then(|f| f.inverse_diagonal()) else {
        return nan();
    };
    let (_, rms_all) = p.rms(s);
    let scale = (rms_all / p.opts.pixel_sigma).max(1.0);
    let diag: Vec<f64> = variances
        .iter()
        .map(|v| v.max(0.0).sqrt() * scale)
        .collect();
    free.into_iter().map(|(i, q)| (q, diag[i])).collect()
}

/// Every free parameter's standard deviation as unknown (NaN): a solve that does not report
/// them ([`super::AdjustOptions::standard_deviations`]).
pub(super) fn unknown_deviations(p: &Problem<'_>) -> Sigmas {
    p.layout.free().map(|(_, q)| (q, f64::NAN)).collect()
}

fn sigma_of(fit: &Fit, q: Param) -> f64 {
    fit.sigmas.get(&q).copied().unwrap_or(0.0)
}

fn frame_report(p: &Problem<'_>, s: &State, fit: &Fit, f: usize) -> FrameAdjustment {
    let b = &s.frames[f];
    let sd = |q| sigma_of(fit, Param::Frame(f, q));
    FrameAdjustment {
        datum_offset_m: p.datum_offset(s, f).into(),
        rotation_deg: b.rotation.map(f64::to_degrees).into(),
        rotation_sigma_deg: [0, 1, 2].map(|k| sd(FrameParam::Rotation(k)).to_degrees()),
        position_m: b.position.into(),
        position_sigma_m: [0, 1, 2].map(|k| sd(FrameParam::Position(k))),
        observations: fit.after.0[f].1,
        rms_before_px: fit.before.0[f].0,
        rms_after_px: fit.after.0[f].0,
        outliers: fit.after.0[f].2,
        position_weight: fit.position_weights.get(f).copied().unwrap_or(1.0),
    }
}

fn camera_report(s: &State, fit: &Fit, c: usize) -> CameraAdjustment {
    let v = &s.cameras[c];
    let sd = |q| sigma_of(fit, Param::Camera(c, q));
    CameraAdjustment {
        focal_scale: 1.0 + v.focal_scale,
        focal_scale_sigma: sd(CameraParam::FocalScale),
        principal_point_shift_px: v.principal_point,
        principal_point_sigma_px: [0, 1].map(|k| sd(CameraParam::PrincipalPoint(k))),
        radial_k1_k2: v.radial,
        radial_sigma: [0, 1].map(|k| sd(CameraParam::Radial(k))),
        boresight_deg: v.boresight.map(f64::to_degrees).into(),
        boresight_sigma_deg: [0, 1, 2].map(|k| sd(CameraParam::Boresight(k)).to_degrees()),
    }
}

fn datum_report(p: &Problem<'_>, s: &State, fit: &Fit) -> Option<DatumAdjustment> {
    let free = |q| p.layout.datum(q).is_some();
    let model = match (free(DatumParam::Shift(0)), free(DatumParam::Scale)) {
        (false, _) => return None,
        (true, false) => Datum::Shift,
        (true, true) => Datum::Similarity,
    };
    let sd = |q| sigma_of(fit, Param::Datum(q));
    let d = &s.datum;
    let drift = free(DatumParam::Drift(0)).then(|| GpsDrift {
        over_flight_m: d.drift.into(),
        sigma_m: [0, 1, 2].map(|k| sd(DatumParam::Drift(k))),
    });
    Some(DatumAdjustment {
        drift,
        model,
        centroid: p.centroid.into(),
        shift_m: d.shift.into(),
        shift_sigma_m: [0, 1, 2].map(|k| sd(DatumParam::Shift(k))),
        rotation_deg: d.rotation.map(f64::to_degrees).into(),
        rotation_sigma_deg: [0, 1, 2].map(|k| sd(DatumParam::Rotation(k)).to_degrees()),
        scale_ppm: d.scale * 1e6,
        scale_sigma_ppm: sd(DatumParam::Scale) * 1e6,
    })
}

/// The adjusted camera `c`.
fn adjusted_camera(p: &Problem<'_>, s: &State, c: usize) -> aerorect_core::Camera {
    use aerorect_core::distortion::{Distortion, OpenCv};
    let v = &s.cameras[c];
    let cam = &p.cameras[c];
    let mut out = cam.clone();
    if v.radial != [0.0; 2] {
        let mut lens = match &cam.distortion {
            Some(Distortion::OpenCv(o)) => *o,
            _ => OpenCv::default(),
        };
        (lens.k1, lens.k2) = (lens.k1 + v.radial[0], lens.k2 + v.radial[1]);
        out.distortion = Some(Distortion::OpenCv(lens));
    }
    let k = &mut out.intrinsics;
    let scale = 1.0 + v.focal_scale;
    (k.fx, k.fy, k.skew) = (k.fx * scale, k.fy * scale, k.skew * scale);
    (k.cx, k.cy) = (k.cx + v.principal_point[0], k.cy + v.principal_point[1]);
    out
}

pub(super) fn finish(p: &Problem<'_>, s: &State, fit: Fit) -> Adjusted {
    let frames = p
        .frames
        .iter()
        .enumerate()
        .map(|(f, fr)| {
            let b = &s.frames[f];
            let c = (nalgebra::Vector3::from(fr.centre) + b.position).into();
            AdjustFrame {
                camera: fr.camera,
                centre: c,
                world_from_camera: world_from_camera(fr, b, &s.cameras[fr.camera]),
                position_sigma_m: fr.position_sigma_m,
                attitude_sigma_deg: fr.attitude_sigma_deg,
            }
        })
        .collect();
    let report = AdjustReport {
        frames: (0..p.frames.len())
            .map(|f| frame_report(p, s, &fit, f))
            .collect(),
        cameras: (0..p.cameras.len())
            .map(|c| camera_report(s, &fit, c))
            .collect(),
        tie_points: p.ties.len(),
        observations: p.ties.iter().map(|t| t.observations.len()).sum(),
        iterations: fit.iterations,
        converged: fit.termination.converged(),
        termination: fit.termination,
        rms_before_px: fit.before.1,
        rms_after_px: fit.after.1,
        seconds: fit.t0.elapsed().as_secs_f64(),
        datum: datum_report(p, s, &fit),
        gauge: fit.gauge,
    };
    Adjusted {
        frames,
        cameras: (0..p.cameras.len())
            .map(|c| adjusted_camera(p, s, c))
            .collect(),
        report,
        corrections: super::Corrections {
            frames: s.frames.clone(),
            cameras: s.cameras.clone(),
            datum: s.datum,
        },
    }
}
