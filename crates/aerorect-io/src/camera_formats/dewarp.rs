//! DJI's XMP DewarpData: `date;fx,fy,cx,cy,k1,k2,p1,p2,k3` (the date optional here), in pixels
//! of the image it was written for; cx, cy are offsets from the image centre ((W - 1) / 2,
//! (H - 1) / 2) and k1, k2, p1, p2, k3 OpenCV's model and order (CONVENTIONS.md, calibration
//! tags). It states no image size: reading needs one. Written without a date; no skew, no
//! rational or thin-prism terms.

use super::{Src, num};
use crate::IoError;
use aerorect_core::distortion::OpenCv;
use aerorect_core::{Camera, ImageSize};

/// One line of nine comma-separated numbers, after an optional `date;`.
pub(crate) fn looks_like(text: &str) -> bool {
    let body = text.trim().rsplit(';').next().unwrap_or("");
    let v: Vec<&str> = body.split(',').collect();
    v.len() == 9 && v.iter().all(|t| t.trim().parse::<f64>().is_ok())
}

pub(crate) fn read(text: &str, size: ImageSize, src: &Src) -> Result<Camera, IoError> {
    let body = text.trim().rsplit(';').next().unwrap_or("");
    let names = ["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"];
    let t: Vec<&str> = body.split(',').collect();
    if t.len() != names.len() {
        return Err(src.err(format!(
            "DewarpData '{}' has {} numbers, not nine (fx, fy, cx, cy, k1, k2, p1, p2, k3)",
            text.trim(),
            t.len()
        )));
    }
    let v = names
        .iter()
        .zip(&t)
        .map(|(n, s)| src.number(n, s))
        .collect::<Result<Vec<_>, _>>()?;
    let [cx0, cy0] = size.centre();
    let lens = OpenCv {
        k1: v[4],
        k2: v[5],
        p1: v[6],
        p2: v[7],
        k3: v[8],
        ..OpenCv::default()
    };
    src.camera([v[0], v[1], cx0 + v[2], cy0 + v[3], 0.0], lens, size)
}

pub(crate) fn write(camera: &Camera, src: &Src) -> Result<String, IoError> {
    src.refuse_skew(camera)?;
    let lens = src.lens(camera)?;
    src.refuse_others(&lens, &["k1", "k2", "p1", "p2", "k3"])?;
    let k = &camera.intrinsics;
    let [cx0, cy0] = camera.size.centre();
    let v = [
        k.fx,
        k.fy,
        k.cx - cx0,
        k.cy - cy0,
        lens.k1,
        lens.k2,
        lens.p1,
        lens.p2,
        lens.k3,
    ];
    let t: Vec<String> = v.iter().map(|x| num(*x)).collect();
    Ok(format!("{}\n", t.join(",")))
}
