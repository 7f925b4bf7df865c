//! Ground control in the flight: the points of a GCP file (any CRS, reprojected to the
//! flight's) with their marks on the flight's photos, as tie points held to their surveyed
//! positions (`aerorect_solve::adjust::Control`); check points kept out of the solve.

use super::*;
use aerorect_io::GcpFile;
use aerorect_solve::adjust::{Control, Datum};

/// Ground control as the flight takes it.
#[derive(Debug, Clone)]
pub struct ControlOptions {
    pub file: GcpFile,
    /// Points kept out of the solve and reported as check points, besides those the file marks.
    pub checkpoints: Vec<String>,
    /// An image mark's standard deviation, px.
    pub mark_sigma_px: f64,
    /// A surveyed point's standard deviation where the file gives none: horizontal, vertical (m).
    pub survey_sigma_m: [f64; 2],
    /// Added to the file's heights to bring them to the flight's vertical datum (the ground's:
    /// the DEM's, or `ground_height_m`'s), as `vertical_offset_m` does for the cameras.
    pub vertical_offset_m: f64,
}

/// The default mark and survey standard deviations: 1 px; 2 cm horizontal, 5 cm vertical.
pub const MARK_SIGMA_PX: f64 = 1.0;
pub const SURVEY_SIGMA_M: [f64; 2] = [0.02, 0.05];

impl ControlOptions {
    /// The file's points with the default standard deviations and no further check points.
    pub fn new(file: GcpFile) -> Self {
        Self {
            file,
            checkpoints: Vec::new(),
            mark_sigma_px: MARK_SIGMA_PX,
            survey_sigma_m: SURVEY_SIGMA_M,
            vertical_offset_m: 0.0,
        }
    }

    /// The points of a GCP file (or of a Pix4D coordinates file and its marks file), with
    /// the defaults.
    pub fn read(paths: &[PathBuf]) -> Result<Self, Error> {
        let file = match paths {
            [one] => aerorect_io::read_gcp_file(one)?,
            many => aerorect_io::read_gcp_files(many)?,
        };
        Ok(Self::new(file))
    }

    /// Refuses standard deviations that are not finite and positive, and an absurd offset.
    pub fn validate(&self) -> Result<(), Error> {
        let bad = |what: &str, v: f64| {
            Error::Invalid(format!(
                "{what} {}: must be a finite number > 0",
                aerorect_core::error::Num(v)
            ))
        };
        if !(self.mark_sigma_px.is_finite() && self.mark_sigma_px > 0.0) {
            return Err(bad("GCP mark standard deviation (px)", self.mark_sigma_px));
        }
        for s in self.survey_sigma_m {
            if !(s.is_finite() && s > 0.0) {
                return Err(bad("GCP survey standard deviation (m)", s));
            }
        }
        crate::sane::check_height_m("GCP vertical offset", self.vertical_offset_m).map(|_| ())
    }
}

/// Whether a surveyed point holds the solve or checks it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Control,
    Check,
}

/// A mark of a point on one of the flight's frames (pixel centres at integers, ours).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Mark {
    pub(super) frame: usize,
    pub(super) pixel: [f64; 2],
    pub(super) line: usize,
}

/// A surveyed point in the flight's CRS, with its marks.
#[derive(Debug, Clone)]
pub(super) struct ControlPoint {
    pub(super) name: String,
    pub(super) role: Role,
    pub(super) ground: [f64; 3],
    pub(super) sigma_m: [f64; 3],
    pub(super) marks: Vec<Mark>,
}

/// The flight's ground control: its points and what resolving them found.
#[derive(Debug, Clone, Default)]
pub(super) struct Resolved {
    pub(super) file: String,
    pub(super) points: Vec<ControlPoint>,
    pub(super) warnings: Vec<String>,
}

impl Resolved {
    fn controls(&self) -> impl Iterator<Item = &ControlPoint> {
        self.points.iter().filter(|p| p.role == Role::Control)
    }

    /// The datum the control can fix: a similarity from three points, else a shift.
    pub(super) fn datum(&self) -> Datum {
        match self.controls().count() {
            0 => Datum::Recorded,
            1 | 2 => Datum::Shift,
            _ => Datum::Similarity,
        }
    }

    /// The control points as the adjustment takes them (marks weighted against the tie
    /// points' `pixel_sigma`).
    pub(super) fn tie_points(&self, mark_sigma_px: f64, pixel_sigma: f64) -> Vec<TiePoint> {
        let weight = (pixel_sigma / mark_sigma_px).powi(2);
        self.controls()
            .filter(|p| !p.marks.is_empty())
            .map(|p| TiePoint {
                ground: p.ground,
                observations: p
                    .marks
                    .iter()
                    .map(|m| Observation {
                        frame: m.frame,
                        pixel: m.pixel,
                        weight,
                    })
                    .collect(),
                control: Some(Control {
                    ground: p.ground,
                    sigma_m: p.sigma_m,
                }),
            })
            .collect()
    }
}

/// How far outside its photo (in photo sizes) a mark's predicted position may fall before the
/// mark is taken for a wrong photo: the recorded orientation can be metres and degrees off.
const MARK_SLACK: f64 = 0.5;

/// A check point this close to a control point (m) is the same point under two names: it
/// would check the solve with itself.
const SAME_POINT_M: f64 = 0.01;

/// The file's points in the flight's CRS, with their marks on the flight's frames.
pub(super) fn resolve(
    co: &ControlOptions,
    frames: &[Frame],
    rec: &Recorded,
    world: &Crs,
) -> Result<Resolved, Error> {
    co.validate()?;
    let file = co.file.path.display().to_string();
    let mut out = Resolved {
        file: file.clone(),
        ..Resolved::default()
    };
    for name in &co.checkpoints {
        if !co.file.points.iter().any(|p| &p.name == name) {
            return Err(Error::Invalid(format!(
                "check point '{name}' is not a point of {file}"
            )));
        }
    }
    for p in &co.file.points {
        let [x, y] = match &co.file.crs {
            Some(f) if !f.same_definition(world) => f
                .transform(world, p.xyz[0], p.xyz[1])
                .map_err(Error::context(format!(
                    "{file} line {}: point '{}'",
                    p.line, p.name
                )))?,
            _ => [p.xyz[0], p.xyz[1]],
        };
        // A file's zero sigma (a point taken as exact) is held to a millimetre.
        let [h, v] = p.sigma_m.unwrap_or(co.survey_sigma_m).map(|s| s.max(0.001));
        let role = match p.check || co.checkpoints.contains(&p.name) {
            true => Role::Check,
            false => Role::Control,
        };
        out.points.push(ControlPoint {
            name: p.name.clone(),
            role,
            ground: [x, y, p.xyz[2] + co.vertical_offset_m],
            sigma_m: [h, h, v],
            marks: Vec::new(),
        });
    }
    refuse_checks_on_controls(&out, &file)?;
    attach_marks(co, frames, rec, &mut out);
    if out.controls().count() > 0 && out.datum() == Datum::Shift {
        out.warnings.push(format!(
            "{file}: {} ground control point(s), fewer than 3: the datum of the recorded positions is solved as a shift only (no rotation or scale)",
            out.controls().count()
        ));
    }
    Ok(out)
}

fn refuse_checks_on_controls(r: &Resolved, file: &str) -> Result<(), Error> {
    for c in r.points.iter().filter(|p| p.role == Role::Check) {
        if let Some(g) = r.controls().find(|g| {
            let d: f64 = (0..3).map(|k| (g.ground[k] - c.ground[k]).powi(2)).sum();
            d.sqrt() < SAME_POINT_M
        }) {
            return Err(Error::Invalid(format!(
                "{file}: check point '{}' is the ground control point '{}' (the same position within {SAME_POINT_M} m): a check point used as control checks nothing",
                c.name, g.name
            )));
        }
    }
    Ok(())
}

/// The frame a mark's image name is (by file name, then stem, ignoring case).
fn frame_named(frames: &[Frame], image: &str) -> Option<usize> {
    let image = image.to_lowercase();
    let name = |f: &Frame, stem: bool| {
        let n = match stem {
            true => f.input.file_stem(),
            false => f.input.file_name(),
        };
        n.map(|s| s.to_string_lossy().to_lowercase())
    };
    let stem = Path::new(&image)
        .file_stem()
        .map(|s| s.to_string_lossy().to_string());
    frames
        .iter()
        .position(|f| name(f, false).as_deref() == Some(image.as_str()))
        .or_else(|| frames.iter().position(|f| name(f, true) == stem))
}

/// Each mark onto its point and frame: marks on photos outside the flight, and marks where the
/// recorded orientation cannot put the point (a wrong photo), are left out with a warning.
fn attach_marks(co: &ControlOptions, frames: &[Frame], rec: &Recorded, out: &mut Resolved) {
    let file = out.file.clone();
    let mut elsewhere = Vec::new();
    for m in &co.file.marks {
        let Some(frame) = frame_named(frames, &m.image) else {
            elsewhere.push(format!("line {} ({})", m.line, m.image));
            continue;
        };
        let Some(point) = out.points.iter_mut().find(|p| p.name == m.point) else {
            continue;
        };
        let pixel = m.pixel;
        let camera = &rec.cameras[rec.camera_of[frame]];
        let predicted = predict(&rec.poses[frame], camera, point.ground);
        let size = camera.size;
        let (w, h) = (size.width as f64, size.height as f64);
        let fits = predicted.is_some_and(|p| {
            p[0] > -MARK_SLACK * w
                && p[0] < (1.0 + MARK_SLACK) * w
                && p[1] > -MARK_SLACK * h
                && p[1] < (1.0 + MARK_SLACK) * h
        });
        if !fits {
            out.warnings.push(format!(
                "{file} line {}: '{}' is marked in {} at ({:.1}, {:.1}) px, but the recorded orientation puts it {}: the mark is left out (a wrong photo?)",
                m.line,
                m.point,
                m.image,
                pixel[0],
                pixel[1],
                match predicted {
                    Some(p) => format!(
                        "at ({:.0}, {:.0}) px, {:.0} px away, outside the photo",
                        p[0],
                        p[1],
                        (p[0] - pixel[0]).hypot(p[1] - pixel[1])
                    ),
                    None => "behind the camera".into(),
                }
            ));
            continue;
        }
        point.marks.push(Mark {
            frame,
            pixel,
            line: m.line,
        });
    }
    if !elsewhere.is_empty() {
        out.warnings.push(format!(
            "{file}: {} marks name photos that are not in this flight, left out: {}",
            elsewhere.len(),
            elsewhere
                .iter()
                .take(5)
                .cloned()
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
}

/// Where `pose` and `camera` put ground point `x` (px).
pub(super) fn predict(pose: &Pose, camera: &Camera, x: [f64; 3]) -> Option<[f64; 2]> {
    let d = pose.world_from_camera().transpose()
        * (aerorect_core::Vec3::from(x) - aerorect_core::Vec3::from(pose.centre));
    camera.pixel_from_camera_point(d)
}
