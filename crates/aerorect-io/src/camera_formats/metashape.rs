//! Agisoft Metashape's calibration XML (`<calibration>` with `projection`, `width`, `height`,
//! `f`, `cx`, `cy`, `b1`, `b2`, `k1`..`k4`, `p1`..`p4`). Metashape's frame model (its manual,
//! appendix "Camera models"):
//!   x' = x (1 + K1 r^2 + K2 r^4 + K3 r^6 + K4 r^8) + P1 (r^2 + 2 x^2) + 2 P2 x y
//!   y' = y (1 + K1 r^2 + ...) + P2 (r^2 + 2 y^2) + 2 P1 x y
//!   u = W / 2 + cx + x' (f + B1) + y' B2,  v = H / 2 + cy + y' f
//! with the first pixel's centre at (0.5, 0.5). So Metashape's P1 is OpenCV's p2 and its P2
//! OpenCV's p1 (swapped); cx, cy are offsets from the image centre, ours cx = (W - 1) / 2 + cx;
//! fx = f + B1, fy = f, skew = B2 (all pixels). K4 (r^8) and P3, P4 have no aerorect term:
//! non-zero is an error. Only `projection` frame is read; other elements (date, covariance)
//! are ignored. Written: f = fy, b1 = fx - fy, b2 = skew.

use super::{Src, num};
use crate::IoError;
use aerorect_core::distortion::OpenCv;
use aerorect_core::{Camera, ImageSize};

pub(crate) fn read(text: &str, src: &Src) -> Result<Camera, IoError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| src.err(e))?;
    let root = doc.root_element();
    if root.tag_name().name() != "calibration" {
        return Err(src.err(format!(
            "root element <{}>, not <calibration>",
            root.tag_name().name()
        )));
    }
    let text_of = |name: &str| {
        root.children()
            .find(|n| n.has_tag_name(name))
            .map(|n| n.text().unwrap_or("").trim().to_string())
    };
    if let Some(p) = text_of("projection").filter(|p| p != "frame") {
        return Err(src.err(format!(
            "projection '{p}' has no aerorect lens (read: frame)"
        )));
    }
    let get = |name: &str| -> Result<f64, IoError> {
        match text_of(name) {
            Some(t) => src.number(name, &t),
            None => Ok(0.0),
        }
    };
    let need = |name: &str| -> Result<f64, IoError> {
        let t = text_of(name).ok_or_else(|| src.err(format!("missing element <{name}>")))?;
        src.number(name, &t)
    };
    for name in ["k4", "p3", "p4"] {
        let v = get(name)?;
        if v != 0.0 {
            return Err(src.err(format!("{name} = {v}: aerorect's lens has no such term")));
        }
    }
    let size = ImageSize::new(
        src.pixels("width", need("width")?)?,
        src.pixels("height", need("height")?)?,
    );
    let f = need("f")?;
    let [cx0, cy0] = size.centre();
    let lens = OpenCv {
        k1: get("k1")?,
        k2: get("k2")?,
        k3: get("k3")?,
        // Metashape's P1 multiplies r^2 + 2x^2 in x: OpenCV's p2 (and P2 is OpenCV's p1).
        p1: get("p2")?,
        p2: get("p1")?,
        ..OpenCv::default()
    };
    let k = [
        f + get("b1")?,
        f,
        cx0 + get("cx")?,
        cy0 + get("cy")?,
        get("b2")?,
    ];
    src.camera(k, lens, size)
}

pub(crate) fn write(camera: &Camera, src: &Src) -> Result<String, IoError> {
    let lens = src.lens(camera)?;
    src.refuse_others(&lens, &["k1", "k2", "p1", "p2", "k3"])?;
    let k = &camera.intrinsics;
    let [cx0, cy0] = camera.size.centre();
    let fields = [
        ("f", k.fy),
        ("cx", k.cx - cx0),
        ("cy", k.cy - cy0),
        ("b1", k.fx - k.fy),
        ("b2", k.skew),
        ("k1", lens.k1),
        ("k2", lens.k2),
        ("k3", lens.k3),
        ("p1", lens.p2),
        ("p2", lens.p1),
    ];
    let body: String = fields
        .iter()
        .map(|(n, v)| format!("  <{n}>{}</{n}>\n", num(*v)))
        .collect();
    Ok(format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<calibration>\n  <projection>frame</projection>\n  \
         <width>{}</width>\n  <height>{}</height>\n{body}</calibration>\n",
        camera.size.width, camera.size.height
    ))
}
