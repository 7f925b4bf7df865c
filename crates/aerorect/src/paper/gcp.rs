//! Polynomial (or projective) correction from ground control points: the paper's baseline. The
//! fitted transform maps reference (output) pixels to image pixels, so the warp is indirect.

use crate::{Error, warp_any};
use aerorect_core::error::Num;
use aerorect_core::{ImageSize, PlaneTransform, RectifyLimits};
use aerorect_io::Gcp;
use aerorect_raster::{AnyRaster, WarpOptions};
use aerorect_solve::gcp::{GcpModel, fit_transform};
use serde::Serialize;

/// One GCP with its residual in image pixels: measured minus fitted (eq. 19's sign).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GcpResidual {
    pub u_image: f64,
    pub v_image: f64,
    pub u_ref: f64,
    pub v_ref: f64,
    pub du: f64,
    pub dv: f64,
}

/// The fitted coefficients, in the reference frame's own pixel coordinates.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Coefficients {
    /// u_image = sum u[k] * term k, v_image = sum v[k] * term k.
    Polynomial {
        terms: Vec<String>,
        u: Vec<f64>,
        v: Vec<f64>,
    },
    /// (u_image, v_image, 1) ~ matrix (u_ref, v_ref, 1), scaled so that matrix[2][2] = 1.
    Projective { matrix: [[f64; 3]; 3] },
}

/// A fitted GCP correction and the output grid it warps to.
#[derive(Debug, Clone)]
pub struct GcpPlan {
    pub model: GcpModel,
    pub image_from_ref: PlaneTransform,
    pub residuals: Vec<GcpResidual>,
    /// Reference coordinates of output pixel (0, 0).
    pub output_origin: [i64; 2],
    pub output_size: ImageSize,
}

fn solve_err(what: &str) -> impl FnOnce(aerorect_solve::SolveError) -> Error + '_ {
    Error::context::<aerorect_solve::SolveError>(what)
}

impl GcpPlan {
    /// Fits `model` to the GCPs. The output grid is `grid` (origin, size, in reference pixels)
    /// or else the bounding box of the image's border mapped into the reference frame by the
    /// same model fitted the other way (as GDAL does), refused beyond `limits`.
    pub fn fit(
        gcps: &[Gcp],
        model: GcpModel,
        image_size: ImageSize,
        grid: Option<([i64; 2], ImageSize)>,
        limits: RectifyLimits,
    ) -> Result<Self, Error> {
        let refs: Vec<[f64; 2]> = gcps.iter().map(|g| [g.u_ref, g.v_ref]).collect();
        let imgs: Vec<[f64; 2]> = gcps.iter().map(|g| [g.u_image, g.v_image]).collect();
        let image_from_ref = fit_transform(model, &refs, &imgs)
            .map_err(solve_err(&format!("{} fit to the GCPs", model.name())))?;
        let residuals = gcps
            .iter()
            .map(|g| {
                let m = image_from_ref
                    .map(g.u_ref, g.v_ref)
                    .unwrap_or([f64::NAN; 2]);
                GcpResidual {
                    u_image: g.u_image,
                    v_image: g.v_image,
                    u_ref: g.u_ref,
                    v_ref: g.v_ref,
                    du: g.u_image - m[0],
                    dv: g.v_image - m[1],
                }
            })
            .collect();
        let (output_origin, output_size) = match grid {
            Some(g) => within_limit(g, limits)?,
            None => {
                let ref_from_image = fit_transform(model, &imgs, &refs)
                    .map_err(solve_err("inverse fit for the output bounds"))?;
                footprint(&ref_from_image, image_size, limits)?
            }
        };
        Ok(Self {
            model,
            image_from_ref,
            residuals,
            output_origin,
            output_size,
        })
    }

    /// sqrt(mean(du^2 + dv^2)) over the GCPs.
    pub fn residual_rms_px(&self) -> f64 {
        let n = self.residuals.len().max(1) as f64;
        (self
            .residuals
            .iter()
            .map(|r| r.du * r.du + r.dv * r.dv)
            .sum::<f64>()
            / n)
            .sqrt()
    }

    pub fn coefficients(&self) -> Coefficients {
        match &self.image_from_ref {
            PlaneTransform::Polynomial(p) => {
                let [u, v] = p.raw_coefficients();
                Coefficients::Polynomial {
                    terms: p.kind().term_names(),
                    u,
                    v,
                }
            }
            PlaneTransform::Projective(h) => {
                let m = h.row_major();
                let s = m[2][2];
                Coefficients::Projective {
                    matrix: m.map(|r| r.map(|x| x / s)),
                }
            }
            // Not produced by a GCP fit (only registration makes piecewise maps).
            PlaneTransform::Piecewise(_) => Coefficients::Polynomial {
                terms: vec![],
                u: vec![],
                v: vec![],
            },
        }
    }

    /// Resamples `input` onto the output grid.
    pub fn run(&self, input: &AnyRaster, warp: &WarpOptions) -> Result<AnyRaster, Error> {
        let [x0, y0] = self.output_origin;
        let map = self.image_from_ref.after_translation(x0 as f64, y0 as f64);
        warp_any(input, &map, self.output_size, warp)
    }
}

/// A given output grid, refused (before anything is allocated) beyond the pixel limit.
fn within_limit(
    grid: ([i64; 2], ImageSize),
    limits: RectifyLimits,
) -> Result<([i64; 2], ImageSize), Error> {
    let (w, h) = (grid.1.width as u64, grid.1.height as u64);
    match w.checked_mul(h) {
        Some(pixels) if pixels <= limits.max_output_px => Ok(grid),
        pixels => Err(Error::advice(format!(
            "`grid` {w} x {h} = {} px exceeds the limit of {} px (`max_output_px`)",
            pixels.map_or("more than 2^64".to_string(), |p| p.to_string()),
            limits.max_output_px
        ))),
    }
}

/// The integer grid covering `transform` of the image's border (64 samples per edge).
fn footprint(
    ref_from_image: &PlaneTransform,
    size: ImageSize,
    limits: RectifyLimits,
) -> Result<([i64; 2], ImageSize), Error> {
    let (w, h) = (size.width as f64 - 1.0, size.height as f64 - 1.0);
    let border = (0..=64).flat_map(|k| {
        let t = k as f64 / 64.0;
        [[t * w, 0.0], [t * w, h], [0.0, t * h], [w, t * h]]
    });
    let ([x0, y0], [ow, oh]) = crate::covering_grid(border, |p| ref_from_image.map(p[0], p[1]))
        .map_err(|p| {
            Error::Invalid(format!(
                "image border pixel ({}, {}) has no reference position under the inverse fit",
                p[0], p[1]
            ))
        })?;
    let pixels = ow * oh;
    if pixels.is_nan() || pixels > limits.max_output_px as f64 {
        return Err(Error::Invalid(format!(
            "the image's footprint under the fit is {} x {} px, beyond the limit of {} px: \
             the GCPs do not constrain the border (give the output grid explicitly)",
            Num(ow),
            Num(oh),
            limits.max_output_px
        )));
    }
    Ok((
        [x0 as i64, y0 as i64],
        ImageSize::new(ow as usize, oh as usize),
    ))
}
