//! Checking the control points and finding the adjustment's starting values: points grouped
//! by image, the field's spread (planar or 3-D), and the DLT or Zhang start.

use super::CalibrationError;
use super::init::{PlaneView, Pose, dlt, zhang};
use super::inputs::{CalibrationOptions, Observation};
use aerorect_core::ImageSize;
use nalgebra::{DMatrix, Rotation3, Vector3};

/// Groups observations by image id (in first-seen order) and checks them.
pub(super) fn group(
    obs: &[Observation],
    need: usize,
) -> Result<(Vec<String>, Vec<Vec<usize>>), CalibrationError> {
    let (mut ids, mut views): (Vec<String>, Vec<Vec<usize>>) = (vec![], vec![]);
    for (i, o) in obs.iter().enumerate() {
        if o.world.iter().chain(&o.pixel).any(|v| !v.is_finite()) {
            return Err(CalibrationError::NotFinite {
                index: i,
                image: o.image.clone(),
            });
        }
        match ids.iter().position(|id| *id == o.image) {
            Some(k) => views[k].push(i),
            None => {
                ids.push(o.image.clone());
                views.push(vec![i]);
            }
        }
    }
    for (id, v) in ids.iter().zip(&views) {
        if v.len() < need {
            return Err(CalibrationError::TooFewInImage {
                image: id.clone(),
                got: v.len(),
                need,
            });
        }
    }
    Ok((ids, views))
}

/// Singular values (descending) of the centred world points of `idx`, and the plane basis.
fn spread(obs: &[Observation], idx: &[usize]) -> ([f64; 3], Vector3<f64>, nalgebra::Matrix3<f64>) {
    let n = idx.len() as f64;
    let c: Vector3<f64> = idx
        .iter()
        .map(|&i| Vector3::from(obs[i].world))
        .sum::<Vector3<f64>>()
        / n;
    let a = DMatrix::from_row_iterator(
        idx.len(),
        3,
        idx.iter().flat_map(|&i| {
            (Vector3::from(obs[i].world) - c)
                .iter()
                .copied()
                .collect::<Vec<_>>()
        }),
    );
    let svd = a.svd(false, true);
    let mut order: Vec<usize> = (0..3).collect();
    order.sort_by(|&x, &y| svd.singular_values[y].total_cmp(&svd.singular_values[x]));
    let v_t = svd.v_t.unwrap_or_else(|| DMatrix::identity(3, 3));
    let basis = nalgebra::Matrix3::from_rows(&[
        v_t.row(order[0])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
        v_t.row(order[1])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
        v_t.row(order[2])
            .into_owned()
            .fixed_columns::<3>(0)
            .into_owned(),
    ]);
    (
        [
            svd.singular_values[order[0]],
            svd.singular_values[order[1]],
            svd.singular_values[order[2]],
        ],
        c,
        basis,
    )
}

/// Starting intrinsics and poses.
pub(super) fn start(
    obs: &[Observation],
    views: &[Vec<usize>],
    ids: &[String],
    opts: &CalibrationOptions,
) -> Result<(nalgebra::Matrix3<f64>, Vec<Pose>), CalibrationError> {
    let all: Vec<usize> = (0..obs.len()).collect();
    let (sv, c, basis) = spread(obs, &all);
    let planar = sv[2] <= 1e-9 * sv[0];
    for (id, v) in ids.iter().zip(views) {
        let (s, _, _) = spread(obs, v);
        if s[1] <= 1e-9 * s[0] {
            return Err(CalibrationError::Collinear { image: id.clone() });
        }
    }
    if planar {
        if views.len() == 1 {
            return Err(CalibrationError::PlanarSingleImage);
        }
        // Plane coordinates (a, b) = first two basis rows of (X - c).
        let to_plane = |w: [f64; 3]| {
            let d = basis * (Vector3::from(w) - c);
            [d[0], d[1]]
        };
        let data: Vec<PlaneView> = views
            .iter()
            .map(|v| {
                (
                    v.iter().map(|&i| to_plane(obs[i].world)).collect(),
                    v.iter().map(|&i| obs[i].pixel).collect(),
                )
            })
            .collect();
        let (k, poses) = zhang(&data, opts.image_size.centre())?;
        // X_c = R_p (B (X - c)) + t_p  =>  R = R_p B, t = t_p - R c (B is a rotation or a reflection).
        let mut b = basis;
        if b.determinant() < 0.0 {
            b.row_mut(2).neg_mut();
        }
        let poses = poses
            .into_iter()
            .map(|p| {
                let r = Rotation3::from_scaled_axis(p.w).matrix() * b;
                let rot = Rotation3::from_matrix_unchecked(r);
                Pose {
                    w: rot.scaled_axis(),
                    t: p.t - r * c,
                }
            })
            .collect();
        Ok((k, poses))
    } else {
        let mut k0 = None;
        let mut poses = vec![];
        for v in views {
            let w: Vec<[f64; 3]> = v.iter().map(|&i| obs[i].world).collect();
            let p: Vec<[f64; 2]> = v.iter().map(|&i| obs[i].pixel).collect();
            let (k, pose) = dlt(&w, &p)?;
            k0.get_or_insert(k);
            poses.push(pose);
        }
        Ok((
            k0.ok_or(CalibrationError::TooFewPoints { got: 0, need: 6 })?,
            poses,
        ))
    }
}

/// Every measured point must lie in the image (pixel centres at integers: -0.5 .. W - 0.5).
pub(super) fn check_inside(obs: &[Observation], size: ImageSize) -> Result<(), CalibrationError> {
    let (w, h) = (size.width as f64, size.height as f64);
    let inside = |p: [f64; 2]| (-0.5..=w - 0.5).contains(&p[0]) && (-0.5..=h - 0.5).contains(&p[1]);
    match obs.iter().position(|o| !inside(o.pixel)) {
        None => Ok(()),
        Some(i) => Err(CalibrationError::OutsideImage {
            index: i + 1,
            image: obs[i].image.clone(),
            pixel: obs[i].pixel,
            size,
        }),
    }
}
