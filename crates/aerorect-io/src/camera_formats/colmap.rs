//! COLMAP `cameras.txt`: `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...` a line, `#` comments.
//! COLMAP's pixel origin is the top-left corner of the image (the first pixel's centre at
//! (0.5, 0.5)): our cx, cy = COLMAP's - 0.5. Models read: SIMPLE_PINHOLE (f, cx, cy), PINHOLE
//! (fx, fy, cx, cy), SIMPLE_RADIAL (f, cx, cy, k), RADIAL (f, cx, cy, k1, k2), OPENCV (fx, fy,
//! cx, cy, k1, k2, p1, p2), FULL_OPENCV (fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6); the
//! radial terms are OpenCV's k1, k2 and p1, p2 are in OpenCV's order. The fisheye models have no
//! aerorect lens and are refused. A file of several cameras is read when they are all the same
//! camera (one per image of one lens); otherwise it is an error naming the ids. Written: the
//! smallest of PINHOLE, OPENCV, FULL_OPENCV that holds the lens (COLMAP has no skew and no
//! thin prism).

use super::{Src, num};
use crate::IoError;
use aerorect_core::distortion::{OpenCv, OpenCvTerms};
use aerorect_core::{Camera, ImageSize};

/// Whether the first data line names a COLMAP model.
pub(crate) fn looks_like(text: &str) -> bool {
    data_lines(text)
        .next()
        .and_then(|l| l.split_whitespace().nth(1))
        .is_some_and(|m| params_of(m).is_some())
}

fn data_lines(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
}

/// A model's parameter names, in COLMAP's order.
fn params_of(model: &str) -> Option<&'static [&'static str]> {
    Some(match model {
        "SIMPLE_PINHOLE" => &["f", "cx", "cy"],
        "PINHOLE" => &["fx", "fy", "cx", "cy"],
        "SIMPLE_RADIAL" => &["f", "cx", "cy", "k1"],
        "RADIAL" => &["f", "cx", "cy", "k1", "k2"],
        "OPENCV" => &["fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"],
        "FULL_OPENCV" => &[
            "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6",
        ],
        _ => return None,
    })
}

pub(crate) fn read(text: &str, src: &Src) -> Result<Camera, IoError> {
    let cameras = data_lines(text)
        .map(|l| read_line(l, src))
        .collect::<Result<Vec<_>, _>>()?;
    let Some((_, first)) = cameras.first() else {
        return Err(src.err("no camera line (CAMERA_ID MODEL WIDTH HEIGHT PARAMS...)"));
    };
    if cameras.iter().any(|(_, c)| c != first) {
        let ids: Vec<&str> = cameras.iter().map(|(id, _)| id.as_str()).collect();
        return Err(src.err(format!(
            "{} different cameras (ids {}): keep the one to convert",
            cameras.len(),
            ids.join(", ")
        )));
    }
    Ok(first.clone())
}

fn read_line(line: &str, src: &Src) -> Result<(String, Camera), IoError> {
    let t: Vec<&str> = line.split_whitespace().collect();
    if t.len() < 4 {
        return Err(src.err(format!("line '{line}': fewer than 4 fields")));
    }
    let (id, model) = (t[0].to_string(), t[1]);
    let names = params_of(model).ok_or_else(|| {
        src.err(format!(
            "camera {id}: model {model} has no aerorect lens (read: SIMPLE_PINHOLE, PINHOLE, \
             SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV)"
        ))
    })?;
    let size = ImageSize::new(
        src.pixels("WIDTH", src.number("WIDTH", t[2])?)?,
        src.pixels("HEIGHT", src.number("HEIGHT", t[3])?)?,
    );
    if t.len() - 4 != names.len() {
        return Err(src.err(format!(
            "camera {id}: {model} has {} parameters ({}), the line {}",
            names.len(),
            names.join(", "),
            t.len() - 4
        )));
    }
    let mut v = std::collections::HashMap::new();
    for (n, s) in names.iter().zip(&t[4..]) {
        v.insert(*n, src.number(n, s)?);
    }
    let get = |n: &str| v.get(n).copied().unwrap_or(0.0);
    let (fx, fy) = match v.get("f") {
        Some(f) => (*f, *f),
        None => (get("fx"), get("fy")),
    };
    // The model is the smallest that holds the non-zero terms (FULL_OPENCV is also COLMAP's
    // only model with k3).
    let mut lens = OpenCv::with_terms(OpenCvTerms::Standard);
    let order = ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"];
    let mut c = [0.0; 12];
    for (slot, n) in c.iter_mut().zip(order) {
        *slot = get(n);
    }
    lens.set_coefficients(c);
    let k = [fx, fy, get("cx") - 0.5, get("cy") - 0.5, 0.0];
    Ok((id, src.camera(k, lens, size)?))
}

pub(crate) fn write(camera: &Camera, src: &Src) -> Result<String, IoError> {
    src.refuse_skew(camera)?;
    let lens = src.lens(camera)?;
    src.refuse_others(&lens, &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"])?;
    let k = &camera.intrinsics;
    let c = lens.coefficients();
    let mut params = vec![k.fx, k.fy, k.cx + 0.5, k.cy + 0.5];
    let model = if c[..8].iter().all(|v| *v == 0.0) {
        "PINHOLE"
    } else if c[4..8].iter().all(|v| *v == 0.0) {
        params.extend(&c[..4]);
        "OPENCV"
    } else {
        params.extend(&c[..8]);
        "FULL_OPENCV"
    };
    let p: Vec<String> = params.iter().map(|v| num(*v)).collect();
    Ok(format!(
        "# Camera list with one line of data per camera:\n\
         #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\
         # Number of cameras: 1\n\
         1 {model} {} {} {}\n",
        camera.size.width,
        camera.size.height,
        p.join(" ")
    ))
}
