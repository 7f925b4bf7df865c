//! Orthority's interior-parameter YAML: cameras by name, each with `type` (pinhole, brown,
//! opencv; fisheye is refused), `im_size: [W, H]`, `focal_len` (one value or [x, y]) in the
//! units of `sensor_size: [w, h]` (f_px = focal_len W / w, per axis; without `sensor_size`,
//! focal_len is normalised by the largest image side, as Orthority documents it), `cx`, `cy`
//! principal point offsets in OpenSfM's normalised coordinates (ours cx = (W - 1) / 2 + cx
//! max(W, H)), and OpenCV's coefficients by name (brown: k1, k2, p1, p2, k3; opencv: also k4..k6,
//! s1..s4; the tilt tx, ty has no aerorect term). Several cameras are read when they are all
//! the same. Written with `sensor_size` = the image size, so `focal_len` is in pixels; no skew.

use super::{Src, yaml_float};
use crate::IoError;
use aerorect_core::distortion::{OpenCv, OpenCvTerms};
use aerorect_core::{Camera, ImageSize};
use yaml_rust2::Yaml;

const COEFFICIENTS: [&str; 12] = [
    "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4",
];

pub(crate) fn read(text: &str, src: &Src) -> Result<Camera, IoError> {
    let docs = super::yaml_guard::load_yaml(text, src)?;
    let Some(Yaml::Hash(cameras)) = docs.first() else {
        return Err(src.err("not a mapping of cameras by name"));
    };
    let read = cameras
        .iter()
        .map(|(name, v)| {
            let name = name.as_str().unwrap_or("?").to_string();
            read_one(&name, v, src).map(|c| (name, c))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let Some((_, first)) = read.first() else {
        return Err(src.err("no camera in the file"));
    };
    if read.iter().any(|(_, c)| c != first) {
        let names: Vec<&str> = read.iter().map(|(n, _)| n.as_str()).collect();
        return Err(src.err(format!(
            "{} different cameras ('{}'): keep the one to convert",
            read.len(),
            names.join("', '")
        )));
    }
    Ok(first.clone())
}

fn number(v: &Yaml) -> Option<f64> {
    match v {
        Yaml::Integer(i) => Some(*i as f64),
        Yaml::Real(r) => r.parse().ok().filter(|x: &f64| x.is_finite()),
        _ => None,
    }
}

/// One number or a pair.
fn pair(v: &Yaml) -> Option<[f64; 2]> {
    match v {
        Yaml::Array(a) if a.len() == 2 => Some([number(&a[0])?, number(&a[1])?]),
        other => number(other).map(|x| [x, x]),
    }
}

fn read_one(name: &str, v: &Yaml, src: &Src) -> Result<Camera, IoError> {
    let Yaml::Hash(h) = v else {
        return Err(src.err(format!("camera '{name}' is not a mapping")));
    };
    let bad = |k: &str, v: &Yaml| src.err(format!("camera '{name}': {k} = {v:?} is invalid"));
    let kind = v["type"]
        .as_str()
        .ok_or_else(|| src.err(format!("camera '{name}': missing key type")))?;
    let allowed: &[&str] = match kind {
        "pinhole" => &[],
        "brown" => &COEFFICIENTS[..5],
        "opencv" => &COEFFICIENTS,
        other => {
            return Err(src.err(format!(
                "camera '{name}': type '{other}' has no aerorect lens (read: pinhole, brown, opencv)"
            )));
        }
    };
    let base = [
        "type",
        "im_size",
        "focal_len",
        "sensor_size",
        "cx",
        "cy",
        "name",
    ];
    for (k, val) in h {
        let k = k.as_str().unwrap_or("?");
        if (k == "tx" || k == "ty") && number(val) != Some(0.0) {
            return Err(src.err(format!(
                "camera '{name}': {k} = {val:?}: the tilted sensor has no aerorect term"
            )));
        }
        if !base.contains(&k) && !allowed.contains(&k) && k != "tx" && k != "ty" {
            return Err(src.err(format!(
                "camera '{name}': key '{k}' is not one of a {kind} camera's"
            )));
        }
    }
    let im = pair(&v["im_size"]).ok_or_else(|| bad("im_size", &v["im_size"]))?;
    let size = ImageSize::new(
        src.pixels("im_size[0]", im[0])?,
        src.pixels("im_size[1]", im[1])?,
    );
    let focal = pair(&v["focal_len"]).ok_or_else(|| bad("focal_len", &v["focal_len"]))?;
    let longest = im[0].max(im[1]);
    let [fx, fy] = match &v["sensor_size"] {
        Yaml::BadValue => [focal[0] * longest, focal[1] * longest],
        s => {
            let s = pair(s).ok_or_else(|| bad("sensor_size", s))?;
            [focal[0] * im[0] / s[0], focal[1] * im[1] / s[1]]
        }
    };
    let opt = |k: &str| match &v[k] {
        Yaml::BadValue => Ok(0.0),
        x => number(x).ok_or_else(|| bad(k, x)),
    };
    let mut c = [0.0; 12];
    for (slot, k) in c.iter_mut().zip(COEFFICIENTS) {
        *slot = opt(k)?;
    }
    // The model is the smallest that holds the non-zero terms.
    let mut lens = OpenCv::with_terms(OpenCvTerms::Standard);
    lens.set_coefficients(c);
    let [cx0, cy0] = size.centre();
    let k = [
        fx,
        fy,
        cx0 + opt("cx")? * longest,
        cy0 + opt("cy")? * longest,
        0.0,
    ];
    src.camera(k, lens, size)
}

pub(crate) fn write(camera: &Camera, src: &Src) -> Result<String, IoError> {
    src.refuse_skew(camera)?;
    let lens = src.lens(camera)?;
    let terms = lens.effective_terms();
    src.refuse_others(&lens, &COEFFICIENTS)?;
    let has_lens = camera.distortion.is_some();
    let (kind, names): (&str, &[&str]) = match terms {
        _ if !has_lens => ("pinhole", &[]),
        OpenCvTerms::Standard => ("brown", &COEFFICIENTS[..5]),
        _ => ("opencv", &COEFFICIENTS),
    };
    let k = &camera.intrinsics;
    let (w, h) = (camera.size.width, camera.size.height);
    let longest = w.max(h) as f64;
    let [cx0, cy0] = camera.size.centre();
    let focal = if k.fx == k.fy {
        yaml_float(k.fx)
    } else {
        format!("[{}, {}]", yaml_float(k.fx), yaml_float(k.fy))
    };
    let mut s = format!(
        "aerorect:\n  type: {kind}\n  im_size: [{w}, {h}]\n  focal_len: {focal}\n  \
         sensor_size: [{}, {}]\n  cx: {}\n  cy: {}\n",
        yaml_float(w as f64),
        yaml_float(h as f64),
        yaml_float((k.cx - cx0) / longest),
        yaml_float((k.cy - cy0) / longest)
    );
    let c = lens.coefficients();
    for n in names {
        let i = COEFFICIENTS.iter().position(|x| x == n).unwrap_or(0);
        s += &format!("  {n}: {}\n", yaml_float(c[i]));
    }
    Ok(s)
}
