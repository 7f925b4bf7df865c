//! OpenSfM / OpenDroneMap `cameras.json`: an object of cameras by id, each with
//! `projection_type`, `width`, `height` and its parameters, normalised by s = max(width,
//! height) about the image centre: OpenSfM's normalised coordinate of our pixel u is
//! (u - (W - 1) / 2) / s (its pixel + 0.5 - W / 2). `perspective`: `focal`, `k1`, `k2` (principal
//! point at the centre); `brown`: `focal_x`, `focal_y`, `c_x`, `c_y`, `k1`, `k2`, `k3`, `p1`,
//! `p2` (OpenCV's model and order, so fx = focal_x s, cx = (W - 1) / 2 + c_x s); `radial` and
//! `simple_radial` as brown with fewer terms. Keys ending in `_prior` are ignored; the fisheye
//! and spherical projections have no aerorect lens and are refused. Several cameras are read
//! when they are all the same. Written: `perspective` when it holds the camera exactly, else
//! `brown` (no skew, no rational or thin-prism terms).

use super::{Src, num};
use crate::IoError;
use aerorect_core::distortion::OpenCv;
use aerorect_core::{Camera, ImageSize};
use serde_json::{Map, Value};

const KEYS: [&str; 11] = [
    "focal", "focal_x", "focal_y", "c_x", "c_y", "k1", "k2", "k3", "p1", "p2", "width",
];

pub(crate) fn read(text: &str, src: &Src) -> Result<Camera, IoError> {
    let root: Map<String, Value> = serde_json::from_str(text).map_err(|e| src.err(e))?;
    let cameras = root
        .iter()
        .map(|(id, v)| match v {
            Value::Object(o) => read_one(id, o, src).map(|c| (id.clone(), c)),
            _ => Err(src.err(format!("camera '{id}' is not an object"))),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let Some((_, first)) = cameras.first() else {
        return Err(src.err("no camera in the file"));
    };
    if cameras.iter().any(|(_, c)| c != first) {
        let ids: Vec<&str> = cameras.iter().map(|(id, _)| id.as_str()).collect();
        return Err(src.err(format!(
            "{} different cameras ('{}'): keep the one to convert",
            cameras.len(),
            ids.join("', '")
        )));
    }
    Ok(first.clone())
}

fn read_one(id: &str, o: &Map<String, Value>, src: &Src) -> Result<Camera, IoError> {
    let projection = o
        .get("projection_type")
        .and_then(Value::as_str)
        .ok_or_else(|| src.err(format!("camera '{id}': missing projection_type")))?;
    if !["perspective", "brown", "radial", "simple_radial"].contains(&projection) {
        return Err(src.err(format!(
            "camera '{id}': projection_type '{projection}' has no aerorect lens (read: \
             perspective, brown, radial, simple_radial)"
        )));
    }
    if let Some(k) = o
        .keys()
        .find(|k| !(KEYS.contains(&k.as_str()) || *k == "height" || *k == "projection_type"))
        .filter(|k| !k.ends_with("_prior"))
    {
        return Err(src.err(format!("camera '{id}': unknown key '{k}'")));
    }
    let get = |k: &str| -> Result<Option<f64>, IoError> {
        match o.get(k) {
            None => Ok(None),
            Some(v) => match v.as_f64().filter(|x| x.is_finite()) {
                Some(x) => Ok(Some(x)),
                None => Err(src.err(format!("camera '{id}': {k} = {v} is not a number"))),
            },
        }
    };
    let need = |k: &str| -> Result<f64, IoError> {
        get(k)?.ok_or_else(|| src.err(format!("camera '{id}': missing key {k}")))
    };
    let size = ImageSize::new(
        src.pixels("width", need("width")?)?,
        src.pixels("height", need("height")?)?,
    );
    let s = size.width.max(size.height) as f64;
    let (fx, fy) = match get("focal")? {
        Some(f) => (f, f),
        None => (need("focal_x")?, need("focal_y")?),
    };
    let zero = |k: &str| get(k).map(|v| v.unwrap_or(0.0));
    let lens = OpenCv {
        k1: zero("k1")?,
        k2: zero("k2")?,
        k3: zero("k3")?,
        p1: zero("p1")?,
        p2: zero("p2")?,
        ..OpenCv::default()
    };
    let [cx0, cy0] = size.centre();
    let k = [
        fx * s,
        fy * s,
        cx0 + zero("c_x")? * s,
        cy0 + zero("c_y")? * s,
        0.0,
    ];
    src.camera(k, lens, size)
}

pub(crate) fn write(camera: &Camera, src: &Src) -> Result<String, IoError> {
    src.refuse_skew(camera)?;
    let lens = src.lens(camera)?;
    src.refuse_others(&lens, &["k1", "k2", "p1", "p2", "k3"])?;
    let (w, h) = (camera.size.width, camera.size.height);
    let s = w.max(h) as f64;
    let k = &camera.intrinsics;
    let [cx0, cy0] = camera.size.centre();
    let perspective = k.fx == k.fy
        && k.cx == cx0
        && k.cy == cy0
        && [lens.p1, lens.p2, lens.k3].iter().all(|v| *v == 0.0);
    let mut fields: Vec<(&str, String)> = vec![];
    if perspective {
        fields.push(("projection_type", "\"perspective\"".into()));
        fields.push(("focal", num(k.fx / s)));
        fields.extend([("k1", num(lens.k1)), ("k2", num(lens.k2))]);
    } else {
        fields.push(("projection_type", "\"brown\"".into()));
        fields.extend([
            ("focal_x", num(k.fx / s)),
            ("focal_y", num(k.fy / s)),
            ("c_x", num((k.cx - cx0) / s)),
            ("c_y", num((k.cy - cy0) / s)),
            ("k1", num(lens.k1)),
            ("k2", num(lens.k2)),
            ("k3", num(lens.k3)),
            ("p1", num(lens.p1)),
            ("p2", num(lens.p2)),
        ]);
    }
    fields.insert(1, ("width", w.to_string()));
    fields.insert(2, ("height", h.to_string()));
    let kind = fields[0].1.trim_matches('"').to_string();
    let body: Vec<String> = fields
        .iter()
        .map(|(k, v)| format!("        \"{k}\": {v}"))
        .collect();
    Ok(format!(
        "{{\n    \"v2 aerorect camera {w} {h} {kind}\": {{\n{}\n    }}\n}}\n",
        body.join(",\n")
    ))
}
