//! OpenCV FileStorage, the layout of OpenCV's calibration sample (`calibrateCamera` written by
//! `cv::FileStorage`): `image_width`, `image_height`, `camera_matrix` (3 x 3, `[fx skew cx; 0 fy
//! cy; 0 0 1]`) and `distortion_coefficients` (n x 1 or 1 x n, n = 4, 5, 8, 12 or 14: k1, k2,
//! p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, tauX, tauY]]]]), each matrix an `opencv-matrix`
//! with `rows`, `cols`, `dt` and `data`. Pixels as ours (centres at integers, OpenCV's
//! convention). Also read: `cameraMatrix`/`K` and `distCoeffs`/`dist_coeffs`/`D`. The tilted
//! sensor (tauX, tauY) has no aerorect term: non-zero is an error. Written: 5 coefficients for
//! `opencv`, 8 for `opencv-rational`, 12 with the thin prism.

use super::{Src, yaml_float};
use crate::IoError;
use aerorect_core::distortion::{OpenCv, OpenCvTerms};
use aerorect_core::{Camera, ImageSize};
use yaml_rust2::Yaml;

const MATRIX_KEYS: [&str; 3] = ["camera_matrix", "cameraMatrix", "K"];
const DIST_KEYS: [&str; 4] = ["distortion_coefficients", "distCoeffs", "dist_coeffs", "D"];

/// What both layouts hold.
struct Storage {
    width: f64,
    height: f64,
    matrix: Vec<f64>,
    dist: Vec<f64>,
}

pub(crate) fn read_yaml(text: &str, src: &Src) -> Result<Camera, IoError> {
    // OpenCV writes the directive as `%YAML:1.0` (YAML wants `%YAML 1.0`) and tags matrices
    // `!!opencv-matrix`: both are dropped before parsing.
    let cleaned: String = text
        .lines()
        .filter(|l| !l.starts_with("%YAML"))
        .map(|l| l.replace("!!opencv-matrix", ""))
        .collect::<Vec<_>>()
        .join("\n");
    let docs = super::yaml_guard::load_yaml(&cleaned, src)?;
    let doc = docs
        .first()
        .ok_or_else(|| src.err("the file holds no YAML document"))?;
    let field = |keys: &[&str]| keys.iter().map(|k| &doc[*k]).find(|v| !v.is_badvalue());
    let scalar = |key: &str| -> Result<f64, IoError> {
        match &doc[key] {
            Yaml::Integer(i) => Ok(*i as f64),
            Yaml::Real(r) => src.number(key, r),
            Yaml::BadValue => Err(src.err(format!("missing key {key}"))),
            other => Err(src.err(format!("{key} = {other:?} is not a number"))),
        }
    };
    let matrix = |keys: &[&str]| -> Result<Vec<f64>, IoError> {
        let m = field(keys).ok_or_else(|| src.err(format!("missing key {}", keys[0])))?;
        yaml_matrix(m, keys[0], src)
    };
    let storage = Storage {
        width: scalar("image_width")?,
        height: scalar("image_height")?,
        matrix: matrix(&MATRIX_KEYS)?,
        dist: match field(&DIST_KEYS) {
            Some(m) => yaml_matrix(m, DIST_KEYS[0], src)?,
            None => vec![],
        },
    };
    camera_of(&storage, src)
}

/// The data of an `opencv-matrix` mapping, checked against rows x cols.
fn yaml_matrix(m: &Yaml, key: &str, src: &Src) -> Result<Vec<f64>, IoError> {
    let int = |k: &str| match &m[k] {
        Yaml::Integer(i) => Ok(*i),
        other => Err(src.err(format!("{key}.{k} = {other:?} is not a whole number"))),
    };
    let (rows, cols) = (int("rows")?, int("cols")?);
    let Yaml::Array(items) = &m["data"] else {
        return Err(src.err(format!("{key}.data is missing or not a list")));
    };
    let data = items
        .iter()
        .map(|v| match v {
            Yaml::Integer(i) => Ok(*i as f64),
            Yaml::Real(r) => src.number(&format!("{key}.data"), r),
            other => Err(src.err(format!("{key}.data holds {other:?}, not a number"))),
        })
        .collect::<Result<Vec<_>, _>>()?;
    check_shape(key, rows, cols, data, src)
}

fn check_shape(
    key: &str,
    rows: i64,
    cols: i64,
    data: Vec<f64>,
    src: &Src,
) -> Result<Vec<f64>, IoError> {
    let fits = rows.checked_mul(cols).and_then(|n| usize::try_from(n).ok()) == Some(data.len());
    if rows < 0 || cols < 0 || !fits {
        return Err(src.err(format!(
            "{key} is {rows} x {cols} but holds {} numbers",
            data.len()
        )));
    }
    Ok(data)
}

pub(crate) fn read_xml(text: &str, src: &Src) -> Result<Camera, IoError> {
    let doc = roxmltree::Document::parse(text).map_err(|e| src.err(e))?;
    let root = doc.root_element();
    if root.tag_name().name() != "opencv_storage" {
        return Err(src.err(format!(
            "root element <{}>, not <opencv_storage>",
            root.tag_name().name()
        )));
    }
    let child = |name: &str| root.children().find(|n| n.has_tag_name(name));
    let text_of = |n: roxmltree::Node| n.text().unwrap_or("").to_string();
    let scalar = |key: &str| -> Result<f64, IoError> {
        let n = child(key).ok_or_else(|| src.err(format!("missing element <{key}>")))?;
        src.number(key, &text_of(n))
    };
    let matrix = |keys: &[&str]| -> Result<Option<Vec<f64>>, IoError> {
        let Some(m) = keys.iter().find_map(|k| child(k)) else {
            return Ok(None);
        };
        let key = m.tag_name().name();
        let part = |p: &str| {
            m.children()
                .find(|n| n.has_tag_name(p))
                .map(text_of)
                .ok_or_else(|| src.err(format!("<{key}> has no <{p}>")))
        };
        let whole = |p: &str| -> Result<i64, IoError> {
            let t = part(p)?;
            t.trim()
                .parse()
                .map_err(|_| src.err(format!("{key}.{p} = '{}' is not a whole number", t.trim())))
        };
        let data = part("data")?
            .split_whitespace()
            .map(|t| src.number(&format!("{key}.data"), t))
            .collect::<Result<Vec<_>, _>>()?;
        check_shape(key, whole("rows")?, whole("cols")?, data, src).map(Some)
    };
    let storage = Storage {
        width: scalar("image_width")?,
        height: scalar("image_height")?,
        matrix: matrix(&MATRIX_KEYS)?
            .ok_or_else(|| src.err(format!("missing element <{}>", MATRIX_KEYS[0])))?,
        dist: matrix(&DIST_KEYS)?.unwrap_or_default(),
    };
    camera_of(&storage, src)
}

fn camera_of(s: &Storage, src: &Src) -> Result<Camera, IoError> {
    let size = ImageSize::new(
        src.pixels("image_width", s.width)?,
        src.pixels("image_height", s.height)?,
    );
    let m = &s.matrix;
    if m.len() != 9 || m[3] != 0.0 || m[6] != 0.0 || m[7] != 0.0 || m[8] != 1.0 {
        return Err(src.err(format!(
            "camera_matrix {m:?} is not a 3 x 3 [fx s cx; 0 fy cy; 0 0 1]"
        )));
    }
    let lens = lens_of(&s.dist, src)?;
    src.camera([m[0], m[4], m[2], m[5], m[1]], lens, size)
}

/// OpenCV's distCoeffs (4, 5, 8, 12 or 14 numbers) as our coefficients.
fn lens_of(d: &[f64], src: &Src) -> Result<OpenCv, IoError> {
    let terms = match d.len() {
        0 | 4 | 5 => OpenCvTerms::Standard,
        8 => OpenCvTerms::Rational,
        12 | 14 => OpenCvTerms::RationalThinPrism,
        n => {
            return Err(src.err(format!(
                "distortion_coefficients has {n} numbers: OpenCV's are 4, 5, 8, 12 or 14"
            )));
        }
    };
    if let Some((name, v)) = ["tauX", "tauY"]
        .iter()
        .zip(d.iter().skip(12))
        .find(|(_, v)| **v != 0.0)
    {
        return Err(src.err(format!(
            "distortion_coefficients {name} = {v}: the tilted sensor has no aerorect term"
        )));
    }
    let mut c = [0.0; 12];
    for (slot, v) in c.iter_mut().zip(d) {
        *slot = *v;
    }
    let mut lens = OpenCv::with_terms(terms);
    lens.set_coefficients(c);
    Ok(lens)
}

/// The distCoeffs OpenCV reads for `lens`: 5, 8 or 12 numbers.
fn dist_of(lens: &OpenCv) -> Vec<f64> {
    let c = lens.coefficients();
    let n = match lens.effective_terms() {
        OpenCvTerms::Standard => 5,
        OpenCvTerms::Rational => 8,
        OpenCvTerms::ThinPrism | OpenCvTerms::RationalThinPrism => 12,
    };
    c[..n].to_vec()
}

fn parts(camera: &Camera, src: &Src) -> Result<(Vec<f64>, Vec<f64>), IoError> {
    let k = &camera.intrinsics;
    let lens = src.lens(camera)?;
    let matrix = vec![k.fx, k.skew, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0];
    Ok((matrix, dist_of(&lens)))
}

fn join(v: &[f64], sep: &str) -> String {
    v.iter()
        .map(|x| yaml_float(*x))
        .collect::<Vec<_>>()
        .join(sep)
}

pub(crate) fn write_yaml(camera: &Camera, src: &Src) -> Result<String, IoError> {
    let (matrix, dist) = parts(camera, src)?;
    let m = |name: &str, rows: usize, cols: usize, data: &[f64]| {
        format!(
            "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
            join(data, ", ")
        )
    };
    Ok(format!(
        "%YAML:1.0\n---\nimage_width: {}\nimage_height: {}\n{}{}",
        camera.size.width,
        camera.size.height,
        m("camera_matrix", 3, 3, &matrix),
        m("distortion_coefficients", dist.len(), 1, &dist)
    ))
}

pub(crate) fn write_xml(camera: &Camera, src: &Src) -> Result<String, IoError> {
    let (matrix, dist) = parts(camera, src)?;
    let m = |name: &str, rows: usize, cols: usize, data: &[f64]| {
        format!(
            "<{name} type_id=\"opencv-matrix\">\n  <rows>{rows}</rows>\n  <cols>{cols}</cols>\n  \
             <dt>d</dt>\n  <data>\n    {}</data></{name}>\n",
            join(data, " ")
        )
    };
    Ok(format!(
        "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>{}</image_width>\n\
         <image_height>{}</image_height>\n{}{}</opencv_storage>\n",
        camera.size.width,
        camera.size.height,
        m("camera_matrix", 3, 3, &matrix),
        m("distortion_coefficients", dist.len(), 1, &dist)
    ))
}
