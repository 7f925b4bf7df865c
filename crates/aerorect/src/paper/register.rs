//! Registration of a frame to a reference image (the paper's second baseline): tie points found
//! automatically, coarse to fine, then a projective or piecewise-affine transform.
//!
//! 1. Coarse: on the top of both pyramids (larger side <= `coarse_side`), every rotation
//!    (`rotation_step_deg` apart) and scale of a similarity is tried; phase correlation gives its
//!    translation and a peak height; the highest peak wins.
//! 2. Fine, from the top level down to full resolution: the frame is warped into the
//!    reference's grid with the current transform, patches on a grid are matched with the
//!    sub-pixel phase correlator, each match is a tie point, and seeded RANSAC fits the next
//!    homography.
//! 3. The final transform is fitted to the full-resolution inliers.

use crate::Error;
use aerorect_core::{Homography, ImageSize, Mat3, PlaneTransform};
use aerorect_raster::pyramid::{full_from_level, pyramid};
use aerorect_raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};
use aerorect_raster::{Raster, WarpOptions, warp};
use aerorect_solve::gcp::{fit_piecewise, fit_projective};
use aerorect_solve::ransac::{RansacOptions, ransac_homography};
use rayon::prelude::*;
use serde::Serialize;

/// The transform fitted to the tie points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TieModel {
    #[default]
    Projective,
    Piecewise,
}

impl TieModel {
    pub fn parse(name: &str) -> Result<Self, Error> {
        match name {
            "projective" => Ok(TieModel::Projective),
            "piecewise" => Ok(TieModel::Piecewise),
            _ => Err(Error::Invalid(format!(
                "unknown registration model '{name}': expected projective or piecewise"
            ))),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct RegisterOptions {
    pub model: TieModel,
    /// Side of the square patches matched at each level.
    pub patch: usize,
    /// At most this many patches per side of the grid.
    pub max_grid: usize,
    /// Matches whose phase-correlation peak is lower are dropped.
    pub min_confidence: f64,
    /// The inliers' median phase-correlation peak must reach this, or the registration is
    /// refused: unrelated images (noise, other scenes) give 0.08 to 0.10, as do random 64 px
    /// patches, yet RANSAC still finds a consensus of chance matches among them; overlapping
    /// frames give 0.23 (a simulated frame) to 0.43 (an aerial sequence).
    pub min_median_confidence: f64,
    /// RANSAC inlier distance at full resolution, image pixels.
    pub ransac_px: f64,
    pub coarse_side: usize,
    pub rotation_step_deg: f64,
    /// Scales tried by the coarse search: from 1/max_scale to max_scale.
    pub max_scale: f64,
    pub seed: u64,
}

impl Default for RegisterOptions {
    fn default() -> Self {
        Self {
            model: TieModel::Projective,
            patch: 64,
            max_grid: 24,
            min_confidence: 0.08,
            min_median_confidence: 0.15,
            ransac_px: 2.0,
            coarse_side: 256,
            rotation_step_deg: 5.0,
            max_scale: 2.0,
            seed: 1,
        }
    }
}

/// One tie point: a reference pixel and the frame pixel matched to it (full resolution).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TiePoint {
    pub u_ref: f64,
    pub v_ref: f64,
    pub u_image: f64,
    pub v_image: f64,
    /// Phase-correlation peak height of the match.
    pub confidence: f64,
    pub inlier: bool,
    /// Measured minus fitted image position, pixels (NaN beyond the transform's horizon).
    pub du: f64,
    pub dv: f64,
}

/// The coarse similarity found by the exhaustive search.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CoarseAlignment {
    pub rotation_deg: f64,
    pub scale: f64,
    pub peak: f64,
}

#[derive(Debug, Clone)]
pub struct Registration {
    pub model: TieModel,
    pub image_from_ref: PlaneTransform,
    /// The least-squares homography of the inliers (also the piecewise model's outside).
    pub homography: Homography,
    pub ties: Vec<TiePoint>,
    pub coarse: CoarseAlignment,
}

impl Registration {
    pub fn inliers(&self) -> usize {
        self.ties.iter().filter(|t| t.inlier).count()
    }

    /// sqrt(mean(du^2 + dv^2)) over the inliers.
    pub fn inlier_rms_px(&self) -> f64 {
        let r: Vec<f64> = self
            .ties
            .iter()
            .filter(|t| t.inlier)
            .map(|t| t.du * t.du + t.dv * t.dv)
            .collect();
        (r.iter().sum::<f64>() / r.len().max(1) as f64).sqrt()
    }
}

/// Registers `image` (gray) to `reference` (gray).
pub fn register(
    image: &Raster<f32>,
    reference: &Raster<f32>,
    opts: &RegisterOptions,
) -> Result<Registration, Error> {
    let side = opts.coarse_side;
    let img_pyr = pyramid(image, side);
    let ref_pyr = pyramid(reference, side);
    // The coarsest level both pyramids reach (both are reduced by the same factor there).
    let top = img_pyr.len().min(ref_pyr.len()) - 1;
    let (coarse, mut h) = coarse_search(&img_pyr[top], &ref_pyr[top], top, opts)?;
    let mut last = Vec::new();
    for level in (0..=top).rev() {
        for _pass in 0..2 {
            let ties = match_patches(&img_pyr[level], &ref_pyr[level], level, &h, opts)?;
            let (from, to): (Vec<[f64; 2]>, Vec<[f64; 2]>) = ties
                .iter()
                .map(|t| ([t.u_ref, t.v_ref], [t.u_image, t.v_image]))
                .unzip();
            let ransac = RansacOptions {
                threshold: opts.ransac_px * (1u64 << level) as f64,
                seed: opts.seed,
                ..RansacOptions::default()
            };
            let fit = match ransac_homography(&from, &to, &ransac) {
                Ok(fit) => fit,
                // A coarse level may see too little overlap; the finer levels get more patches.
                Err(_) if level > 0 => break,
                Err(e) => {
                    let at = format!("registration at full resolution: {} tie points", ties.len());
                    return Err(Error::context(at)(e));
                }
            };
            h = fit.model;
            last = ties
                .into_iter()
                .zip(fit.inliers)
                .map(|(t, inlier)| TiePoint { inlier, ..t })
                .collect();
        }
    }
    let reg = finish(last, opts.model, coarse)?;
    refuse_chance_matches(&reg, opts.min_median_confidence)?;
    Ok(reg)
}

/// Refuses a registration whose inliers' median peak is below `min`: their agreement is what
/// RANSAC finds among chance matches of unrelated images.
fn refuse_chance_matches(reg: &Registration, min: f64) -> Result<(), Error> {
    let mut peaks: Vec<f64> = reg
        .ties
        .iter()
        .filter(|t| t.inlier)
        .map(|t| t.confidence)
        .collect();
    peaks.sort_by(f64::total_cmp);
    let median = peaks.get(peaks.len() / 2).copied().unwrap_or(0.0);
    if median >= min {
        return Ok(());
    }
    Err(Error::Invalid(format!(
        "registration failed: the {} inliers of {} tie points have a median correlation peak \
         of {median:.3}, below {min} (unrelated images give about 0.09): \
         the images do not seem to overlap",
        peaks.len(),
        reg.ties.len()
    )))
}

/// Fits the final model to the inliers and fills every tie's residual.
fn finish(
    mut ties: Vec<TiePoint>,
    model: TieModel,
    coarse: CoarseAlignment,
) -> Result<Registration, Error> {
    let (from, to): (Vec<[f64; 2]>, Vec<[f64; 2]>) = ties
        .iter()
        .filter(|t| t.inlier)
        .map(|t| ([t.u_ref, t.v_ref], [t.u_image, t.v_image]))
        .unzip();
    let err =
        |e: aerorect_solve::SolveError| Error::context("registration: final fit to the inliers")(e);
    let homography = fit_projective(&from, &to).map_err(err)?;
    let image_from_ref = match model {
        TieModel::Projective => PlaneTransform::Projective(homography),
        TieModel::Piecewise => PlaneTransform::Piecewise(fit_piecewise(&from, &to).map_err(err)?),
    };
    for t in &mut ties {
        let m = image_from_ref
            .map(t.u_ref, t.v_ref)
            .unwrap_or([f64::NAN; 2]);
        (t.du, t.dv) = (t.u_image - m[0], t.v_image - m[1]);
    }
    Ok(Registration {
        model,
        image_from_ref,
        homography,
        ties,
        coarse,
    })
}

/// The pixel-centre scalings between full resolution and pyramid level `level`:
/// (full_from_level, level_from_full), as in [`full_from_level`].
fn level_scalings(level: usize) -> (Mat3, Mat3) {
    let f = (1u64 << level) as f64;
    let o = 0.5 * f - 0.5;
    let full = Mat3::new(f, 0.0, o, 0.0, f, o, 0.0, 0.0, 1.0);
    let lvl = Mat3::new(1.0 / f, 0.0, -o / f, 0.0, 1.0 / f, -o / f, 0.0, 0.0, 1.0);
    (full, lvl)
}

/// A full-resolution `image_from_ref` as seen between two level-`level` grids.
fn at_level(h: &Homography, level: usize) -> Homography {
    let (full, lvl) = level_scalings(level);
    Homography::new(lvl * h.matrix() * full).unwrap_or(*h)
}

/// `image` warped into `reference`'s grid by `image_from_ref` (NaN where it has no pixel).
fn warped(
    image: &Raster<f32>,
    image_from_ref: &Homography,
    size: ImageSize,
) -> Result<Raster<f32>, Error> {
    let opts = WarpOptions {
        nodata: f64::NAN,
        ..WarpOptions::default()
    };
    Ok(warp(image, image_from_ref, size, &opts)?)
}

/// The similarity `image_from_ref` (at full resolution) whose phase-correlation peak on level
/// `level` is highest over the rotation and scale grid.
fn coarse_search(
    image: &Raster<f32>,
    reference: &Raster<f32>,
    level: usize,
    opts: &RegisterOptions,
) -> Result<(CoarseAlignment, Homography), Error> {
    let rs = reference.size();
    let is = image.size();
    let [rcx, rcy] = rs.centre();
    let [icx, icy] = is.centre();
    let steps = (360.0 / opts.rotation_step_deg.clamp(0.5, 90.0)).round() as usize;
    let scales = scale_grid(opts.max_scale);
    let candidates: Vec<(f64, f64)> = (0..steps)
        .flat_map(|k| {
            let deg = k as f64 * 360.0 / steps as f64;
            scales.iter().map(move |&s| (deg, s))
        })
        .collect();
    let phase = PhaseOptions {
        weighting: Weighting::Phase,
        window: true,
        smooth: 0.0,
    };
    let similarity = |deg: f64, s: f64, d: [f64; 2]| {
        let (c, sn) = (deg.to_radians().cos() * s, deg.to_radians().sin() * s);
        // image = ic + s R (ref - rc + d)
        let (tx, ty) = (rcx - d[0], rcy - d[1]);
        Mat3::new(
            c,
            -sn,
            icx - (c * tx - sn * ty),
            sn,
            c,
            icy - (sn * tx + c * ty),
            0.0,
            0.0,
            1.0,
        )
    };
    let best = candidates
        .par_iter()
        .map_init(
            || PhaseCorrelator::new(rs.width, rs.height, phase),
            |pc, &(deg, s)| -> Option<(f64, f64, f64, [f64; 2])> {
                let pc = pc.as_mut().ok()?;
                let h = Homography::new(similarity(deg, s, [0.0, 0.0])).ok()?;
                let mut w = warped(image, &h, rs).ok()?;
                let valid = fill_invalid(w.plane_mut(0))?;
                if valid < rs.width * rs.height / 8 {
                    return None;
                }
                let e = pc.estimate(reference.plane(0), w.plane(0)).ok()?;
                Some((e.confidence, deg, s, [e.dx, e.dy]))
            },
        )
        .flatten()
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .ok_or_else(|| {
            Error::Invalid(
                "registration: no rotation or scale of the frame overlaps the reference".into(),
            )
        })?;
    let (peak, deg, s, d) = best;
    let h_level = Homography::new(similarity(deg, s, d))
        .map_err(Error::geometry("registration: coarse similarity"))?;
    let (full, lvl) = level_scalings(level);
    let h = Homography::new(full * h_level.matrix() * lvl)
        .map_err(Error::geometry("registration: coarse similarity"))?;
    Ok((
        CoarseAlignment {
            rotation_deg: deg,
            scale: s,
            peak,
        },
        h,
    ))
}

/// Scales from 1/max to max in steps of 2^(1/4).
fn scale_grid(max_scale: f64) -> Vec<f64> {
    let k = (max_scale.max(1.0).log2() * 4.0).round() as i32;
    (-k..=k).map(|i| 2f64.powf(i as f64 / 4.0)).collect()
}

/// Replaces NaN by the mean of the finite samples; returns how many were finite.
fn fill_invalid(p: &mut [f32]) -> Option<usize> {
    let (sum, n) = p
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0f64, 0usize), |(s, n), &v| (s + v as f64, n + 1));
    if n == 0 {
        return None;
    }
    let mean = (sum / n as f64) as f32;
    p.iter_mut()
        .filter(|v| !v.is_finite())
        .for_each(|v| *v = mean);
    Some(n)
}

/// Tie points of one level: patches of the reference on a grid, each matched against the frame
/// warped by `h` (full-resolution `image_from_ref`).
fn match_patches(
    image: &Raster<f32>,
    reference: &Raster<f32>,
    level: usize,
    h: &Homography,
    opts: &RegisterOptions,
) -> Result<Vec<TiePoint>, Error> {
    let rs = reference.size();
    let hl = at_level(h, level);
    let w = warped(image, &hl, rs)?;
    // Patches shrink on small levels so that a grid of them still fits the overlap.
    let p = (opts.patch.min(rs.width.min(rs.height) / 3) / 8 * 8).max(16);
    if p > rs.width.min(rs.height) {
        return Ok(Vec::new());
    }
    let grid = |len: usize| -> Vec<usize> {
        let room = len.saturating_sub(p);
        let n = (room / (p / 2).max(1) + 1).min(opts.max_grid).max(1);
        (0..n)
            .map(|k| if n == 1 { room / 2 } else { k * room / (n - 1) })
            .collect()
    };
    let origins: Vec<(usize, usize)> = grid(rs.height)
        .into_iter()
        .flat_map(|y| grid(rs.width).into_iter().map(move |x| (x, y)))
        .collect();
    let phase = PhaseOptions {
        weighting: Weighting::Phase,
        window: true,
        smooth: 0.0,
    };
    let ties = origins
        .par_iter()
        .map_init(
            || {
                (
                    PhaseCorrelator::new(p, p, phase),
                    vec![0f32; p * p],
                    vec![0f32; p * p],
                )
            },
            |(pc, a, b), &(x0, y0)| -> Option<TiePoint> {
                let pc = pc.as_mut().ok()?;
                for r in 0..p {
                    let row = (y0 + r) * rs.width + x0;
                    a[r * p..(r + 1) * p].copy_from_slice(&reference.plane(0)[row..row + p]);
                    b[r * p..(r + 1) * p].copy_from_slice(&w.plane(0)[row..row + p]);
                }
                // Patches mostly inside the frame are kept, their gaps filled with the mean.
                if b.iter().filter(|v| !v.is_finite()).count() * 4 > p * p {
                    return None;
                }
                fill_invalid(b)?;
                let e = pc.estimate(a, b).ok()?;
                if e.confidence < opts.min_confidence || e.dx.abs().max(e.dy.abs()) > p as f64 / 4.0
                {
                    return None;
                }
                let c = [
                    x0 as f64 + (p as f64 - 1.0) / 2.0,
                    y0 as f64 + (p as f64 - 1.0) / 2.0,
                ];
                let img = hl.map(c[0] + e.dx, c[1] + e.dy)?;
                let rf = full_from_level(level, c);
                let im = full_from_level(level, img);
                Some(TiePoint {
                    u_ref: rf[0],
                    v_ref: rf[1],
                    u_image: im[0],
                    v_image: im[1],
                    confidence: e.confidence,
                    inlier: false,
                    du: f64::NAN,
                    dv: f64::NAN,
                })
            },
        )
        .flatten()
        .collect();
    Ok(ties)
}
