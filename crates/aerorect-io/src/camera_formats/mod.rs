//! Camera files of other tools, read into and written from [`Camera`]: OpenCV's FileStorage
//! (YAML and XML), COLMAP's `cameras.txt`, OpenSfM/ODM `cameras.json`, Agisoft Metashape's
//! calibration XML, DJI's DewarpData string and Orthority's interior-parameter YAML, beside our
//! own TOML. Each format's conventions (pixel origin, normalisation, the order of p1 and p2)
//! are in its file and in CONVENTIONS.md. A term a format cannot carry is an error naming it,
//! never dropped; a lens model other than OpenCV's (Tsai, Brown, the paper's) is written only
//! as TOML.

mod colmap;
mod dewarp;
mod metashape;
mod opencv_storage;
mod opensfm;
mod orthority;
mod yaml_guard;

use crate::IoError;
use crate::camera::{CameraFile, camera_toml};
use aerorect_core::distortion::{Distortion, OpenCv, OpenCvTerms};
use aerorect_core::spelling::Spelling;
use aerorect_core::{Camera, ImageSize, Intrinsics};
use std::path::Path;

/// A camera file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraFormat {
    /// aerorect's camera TOML.
    Toml,
    /// OpenCV FileStorage YAML (`calibrateCamera`'s sample layout).
    OpenCvYaml,
    /// OpenCV FileStorage XML.
    OpenCvXml,
    /// COLMAP `cameras.txt`.
    Colmap,
    /// OpenSfM / OpenDroneMap `cameras.json`.
    OpenSfm,
    /// Agisoft Metashape calibration XML.
    Metashape,
    /// DJI's XMP DewarpData string (needs the image size).
    DjiDewarp,
    /// Orthority's interior-parameter YAML.
    Orthority,
}

impl CameraFormat {
    pub const ALL: [CameraFormat; 8] = [
        CameraFormat::Toml,
        CameraFormat::OpenCvYaml,
        CameraFormat::OpenCvXml,
        CameraFormat::Colmap,
        CameraFormat::OpenSfm,
        CameraFormat::Metashape,
        CameraFormat::DjiDewarp,
        CameraFormat::Orthority,
    ];

    pub fn name(self) -> &'static str {
        match self {
            CameraFormat::Toml => "toml",
            CameraFormat::OpenCvYaml => "opencv-yaml",
            CameraFormat::OpenCvXml => "opencv-xml",
            CameraFormat::Colmap => "colmap",
            CameraFormat::OpenSfm => "opensfm",
            CameraFormat::Metashape => "metashape",
            CameraFormat::DjiDewarp => "dji-dewarp",
            CameraFormat::Orthority => "orthority",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The format of `path` from its content (when given) and extension: `.toml`; `.yml` and
    /// `.yaml` are OpenCV's when the text has `%YAML:1.0`, `opencv-matrix` or `camera_matrix`,
    /// Orthority's otherwise (with no text: `.yml` OpenCV, `.yaml` Orthority); `.xml` by its
    /// root element (`opencv_storage` or `calibration`); `.json` OpenSfM; `cameras.txt` or a
    /// text whose first data line names a COLMAP model is COLMAP's, a `.txt` holding one line
    /// of nine numbers (after an optional `date;`) DJI's. `None` when it cannot tell.
    pub fn detect(path: &Path, text: Option<&str>) -> Option<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let file = path.file_name().and_then(|f| f.to_str()).unwrap_or("");
        match (ext.as_deref(), text) {
            (Some("toml"), _) => Some(CameraFormat::Toml),
            (Some("json"), _) => Some(CameraFormat::OpenSfm),
            (Some("yml" | "yaml"), Some(t)) => Some(
                if t.contains("%YAML:1")
                    || t.contains("opencv-matrix")
                    || t.contains("camera_matrix")
                {
                    CameraFormat::OpenCvYaml
                } else {
                    CameraFormat::Orthority
                },
            ),
            (Some("yml"), None) => Some(CameraFormat::OpenCvYaml),
            (Some("yaml"), None) => Some(CameraFormat::Orthority),
            (Some("xml"), Some(t)) if t.contains("<opencv_storage") => {
                Some(CameraFormat::OpenCvXml)
            }
            (Some("xml"), Some(t)) if t.contains("<calibration") => Some(CameraFormat::Metashape),
            (Some("txt"), _) if file == "cameras.txt" => Some(CameraFormat::Colmap),
            (Some("txt") | None, Some(t)) if colmap::looks_like(t) => Some(CameraFormat::Colmap),
            (Some("txt") | None, Some(t)) if dewarp::looks_like(t) => Some(CameraFormat::DjiDewarp),
            _ => None,
        }
    }
}

/// The readers of [`CameraFile`] that reach every format: the file in whatever format it is,
/// and a DewarpData text held until the image size is known.
impl CameraFile {
    /// Reads a camera file of any format [`CameraFormat::detect`] tells (as `camera convert`
    /// does); a file it cannot tell is read as TOML.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let text = crate::bounded::read_text(path)?;
        let name = path.display().to_string();
        match CameraFormat::detect(path, Some(&text)) {
            None | Some(CameraFormat::Toml) => Self::parse(&text, &name),
            Some(CameraFormat::DjiDewarp) => Ok(CameraFile {
                source_name: name,
                dewarp_text: Some(text),
                ..CameraFile::default()
            }),
            Some(format) => Ok(Self::from_camera(
                &camera_from_text(&text, format, None, &name)?,
                &name,
            )),
        }
    }

    /// The camera for an image of `image` pixels (or, without one, of the file's
    /// `image_size_px`). A file that states `image_size_px` is carried to an image of another
    /// size with the same aspect ratio by [`Camera::resized`]; another aspect ratio is refused.
    pub fn camera(&self, image: Option<ImageSize>) -> Result<Camera, IoError> {
        if let Some(text) = &self.dewarp_text {
            return camera_from_text(text, CameraFormat::DjiDewarp, image, &self.source_name);
        }
        self.camera_from_fields(image)
    }
}

/// Reads the camera in `path` (format `format`, else detected). `size`: the image size for a
/// format that does not state one (DJI's DewarpData, a TOML without `image_size_px`), or the
/// size to carry a file's camera to (same aspect ratio).
pub fn read_camera_file(
    path: &Path,
    format: Option<CameraFormat>,
    size: Option<ImageSize>,
) -> Result<(Camera, CameraFormat), IoError> {
    let text = crate::bounded::read_text(path)?;
    let name = path.display().to_string();
    let format = match format.or_else(|| CameraFormat::detect(path, Some(&text))) {
        Some(f) => f,
        None => {
            return Err(IoError::field(
                &name,
                "cannot tell the camera format from the name or content: give it (one of toml, \
                 opencv-yaml, opencv-xml, colmap, opensfm, metashape, dji-dewarp, orthority)",
            ));
        }
    };
    Ok((camera_from_text(&text, format, size, &name)?, format))
}

/// The camera in `text` of format `format` (`source` names it in messages).
pub fn camera_from_text(
    text: &str,
    format: CameraFormat,
    size: Option<ImageSize>,
    source: &str,
) -> Result<Camera, IoError> {
    let src = Src { format, source };
    let camera = match format {
        CameraFormat::Toml => return CameraFile::parse(text, source)?.camera(size),
        CameraFormat::OpenCvYaml => opencv_storage::read_yaml(text, &src),
        CameraFormat::OpenCvXml => opencv_storage::read_xml(text, &src),
        CameraFormat::Colmap => colmap::read(text, &src),
        CameraFormat::OpenSfm => opensfm::read(text, &src),
        CameraFormat::Metashape => metashape::read(text, &src),
        CameraFormat::DjiDewarp => {
            let size = size.ok_or_else(|| {
                src.err(Spelling::current().keys_in(
                    "DewarpData does not state the image size: give it (`image_size` WxH)",
                ))
            })?;
            dewarp::read(text, size, &src)
        }
        CameraFormat::Orthority => orthority::read(text, &src),
    }?;
    camera.validate().map_err(|e| src.err(e))?;
    match size {
        Some(s) if s != camera.size => camera
            .resized(s)
            .map_err(|e| src.err(format!("to the image size {} x {}: {e}", s.width, s.height))),
        _ => Ok(camera),
    }
}

/// `camera` as a file of `format` (`target` names it in messages).
pub fn text_from_camera(
    camera: &Camera,
    format: CameraFormat,
    target: &str,
) -> Result<String, IoError> {
    let src = Src {
        format,
        source: target,
    };
    match format {
        CameraFormat::Toml => camera_toml(camera),
        CameraFormat::OpenCvYaml => opencv_storage::write_yaml(camera, &src),
        CameraFormat::OpenCvXml => opencv_storage::write_xml(camera, &src),
        CameraFormat::Colmap => colmap::write(camera, &src),
        CameraFormat::OpenSfm => opensfm::write(camera, &src),
        CameraFormat::Metashape => metashape::write(camera, &src),
        CameraFormat::DjiDewarp => dewarp::write(camera, &src),
        CameraFormat::Orthority => orthority::write(camera, &src),
    }
}

/// Where a camera is read from or written to, for messages.
pub(crate) struct Src<'a> {
    pub format: CameraFormat,
    pub source: &'a str,
}

impl Src<'_> {
    pub fn err(&self, message: impl std::fmt::Display) -> IoError {
        IoError::field(self.source, format!("{}: {message}", self.format.name()))
    }

    /// A number's text, or an error naming the field and the text.
    pub fn number(&self, field: &str, text: &str) -> Result<f64, IoError> {
        match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(self.err(format!(
                "{field} = '{}' is not a finite number",
                text.trim()
            ))),
        }
    }

    /// A positive whole number of pixels.
    pub fn pixels(&self, field: &str, v: f64) -> Result<usize, IoError> {
        if v >= 1.0 && v.fract() == 0.0 && v < 1e9 {
            Ok(v as usize)
        } else {
            Err(self.err(format!(
                "{field} = {v} is not a positive whole number of pixels"
            )))
        }
    }

    /// OpenCV's coefficients of `camera`'s lens (zero without one); another model is an error.
    pub fn lens(&self, camera: &Camera) -> Result<OpenCv, IoError> {
        match &camera.distortion {
            None => Ok(OpenCv::default()),
            Some(Distortion::OpenCv(m)) => Ok(*m),
            Some(other) => Err(self.err(format!(
                "the {} lens model cannot be written in this format (it carries OpenCV's model \
                 only); write it as toml",
                other.kind()
            ))),
        }
    }

    /// An error naming the first non-zero coefficient of `lens` outside `carried`.
    pub fn refuse_others(&self, lens: &OpenCv, carried: &[&str]) -> Result<(), IoError> {
        let names = OpenCvTerms::RationalThinPrism.names();
        match names
            .iter()
            .zip(lens.coefficients())
            .find(|(n, v)| *v != 0.0 && !carried.contains(n))
        {
            Some((n, v)) => Err(self.err(format!(
                "the lens term {n} = {v} cannot be written: this format has no {n}"
            ))),
            None => Ok(()),
        }
    }

    /// An error when the skew is not zero (formats without one).
    pub fn refuse_skew(&self, camera: &Camera) -> Result<(), IoError> {
        match camera.intrinsics.skew {
            0.0 => Ok(()),
            s => Err(self.err(format!(
                "the skew {s} px cannot be written: this format has no skew"
            ))),
        }
    }

    /// The camera of these intrinsics and OpenCV coefficients (no lens when all are zero).
    pub fn camera(&self, k: [f64; 5], lens: OpenCv, size: ImageSize) -> Result<Camera, IoError> {
        let [fx, fy, cx, cy, skew] = k;
        let mut intr = Intrinsics::new(fx, fy, cx, cy).map_err(|e| self.err(e))?;
        intr.skew = aerorect_core::error::require_finite("skew", skew).map_err(|e| self.err(e))?;
        if let Some((n, v)) = OpenCvTerms::RationalThinPrism
            .names()
            .iter()
            .zip(lens.coefficients())
            .find(|(_, v)| !v.is_finite())
        {
            return Err(self.err(format!("{n} = {v} is not a finite number")));
        }
        let any = lens.coefficients().iter().any(|v| *v != 0.0);
        let mut lens = lens;
        lens.terms = lens.effective_terms();
        Ok(Camera::new(
            intr,
            any.then_some(Distortion::OpenCv(lens)),
            size,
        ))
    }
}

/// Shortest text that reads back to the same f64.
pub(crate) fn num(v: f64) -> String {
    format!("{v:?}")
}

/// A float PyYAML (YAML 1.1) reads as a float: a dot and a signed exponent.
pub(crate) fn yaml_float(v: f64) -> String {
    let s = num(v);
    match s.split_once('e') {
        None => s,
        Some((m, e)) => {
            let m = if m.contains('.') {
                m.to_string()
            } else {
                format!("{m}.0")
            };
            let e = if e.starts_with('-') {
                e.to_string()
            } else {
                format!("+{e}")
            };
            format!("{m}e{e}")
        }
    }
}
