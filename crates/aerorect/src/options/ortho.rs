//! The options of a georeferenced ortho (`rectify PHOTO`, `batch`, `mosaic`, a flight's
//! frames): what the front end was given, checked, then the files it names read.

use super::OptionError;
use crate::Error;
use crate::drone::DroneOptions;
use crate::georef::load_dem;
use crate::photo_source::SenseflyRoll;
use crate::photo_source::{load_geo_file, prepare_flight};
use crate::sane::{check_boresight_deg, check_gsd_m, check_height_m, check_lever_arm_m};
use aerorect_core::RectifyLimits;
use aerorect_core::error::Num;
use aerorect_geo::{Crs, Mounting};
use aerorect_io::{CameraFile, CogOptions, EoFormat, PoseRecord};
use aerorect_raster::{Interp, WarpOptions};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The georeferencing options as a front end was given them (Python's keyword names).
#[derive(Debug, Clone, Default)]
pub struct PhotoRequest {
    /// Output ground sample distance, metres (default: each frame's own at nadir).
    pub gsd_m: Option<f64>,
    /// Ground elevation against the photos' absolute altitude.
    pub ground_height_m: Option<f64>,
    /// Added to the camera heights (to bring them to the ground's vertical datum).
    pub vertical_offset_m: f64,
    /// DEM holes or gaps are errors instead of a warning and level ground.
    pub strict: bool,
    /// Over a DEM, leave ground hidden behind nearer terrain empty.
    pub occlusion: bool,
    /// Output CRS as EPSG:code, WKT or a PROJ string (default: the pose table's `.prj`, else
    /// the UTM zone of the position).
    pub crs: Option<String>,
    /// A camera file for every frame.
    pub camera: Option<PathBuf>,
    /// A pose table (CSV `filename,x,y,z,omega,phi,kappa`).
    pub poses: Option<PathBuf>,
    /// One photo's pose: x, y, z, omega, phi, kappa (for a request about one photo).
    pub pose: Option<[f64; 6]>,
    /// An external-orientation file (ODM geo.txt, Pix4D CSV, senseFly geoinfo.txt, or a pose
    /// table).
    pub geo: Option<PathBuf>,
    /// A DEM GeoTIFF.
    pub dem: Option<PathBuf>,
    /// The camera's rotation in the body frame, degrees (roll, pitch, yaw).
    pub boresight_deg: Option<[f64; 3]>,
    /// The camera's offset from the GPS antenna in the body frame, metres.
    pub lever_arm_m: Option<[f64; 3]>,
    pub sensefly_roll: SenseflyRoll,
    pub limits: RectifyLimits,
    pub warp: WarpOptions,
    /// Cloud-optimised GeoTIFFs (masked by the alpha band when `warp.alpha`).
    pub cog: bool,
}

/// The interpolation named `name` (nearest, bilinear, bicubic, average).
pub fn parse_interp(name: &str) -> Result<Interp, Error> {
    name.parse::<Interp>().map_err(|why| {
        OptionError::value("interp", format!("'{name}'"), Error::Invalid(why)).into()
    })
}

/// A projected CRS from text (EPSG:code, WKT or PROJ): the one reading of `crs` and of a pose
/// table's `.prj`; the caller names where the text came from.
pub fn projected_crs(text: &str) -> Result<Crs, Error> {
    let c = Crs::parse(text)?;
    if c.is_geographic() {
        return Err(Error::Invalid(
            "a geographic CRS (degrees): orthos need a projected CRS in metres".into(),
        ));
    }
    Ok(c)
}

/// `text` cut to 80 characters for a message.
fn short(text: &str) -> String {
    let mut s: String = text.chars().take(80).collect();
    if s.len() < text.len() {
        s.push_str("...");
    }
    format!("'{s}'")
}

impl PhotoRequest {
    /// Refuses values outside their sane ranges, reading no file.
    pub fn validate(&self) -> Result<(), Error> {
        let at = |key, v: f64, e| OptionError::value(key, Num(v), e);
        if let Some(g) = self.gsd_m {
            check_gsd_m(g).map_err(|e| at("gsd_m", g, e))?;
        }
        if let Some(z) = self.ground_height_m {
            check_height_m("ground height", z).map_err(|e| at("ground_height_m", z, e))?;
        }
        let v = self.vertical_offset_m;
        check_height_m("vertical offset", v).map_err(|e| at("vertical_offset_m", v, e))?;
        let three = |t: [f64; 3]| format!("'{},{},{}'", Num(t[0]), Num(t[1]), Num(t[2]));
        for (key, t) in [
            ("boresight_deg", self.boresight_deg),
            ("lever_arm_m", self.lever_arm_m),
        ] {
            if let Some(t) = t.filter(|t| !t.iter().all(|x| x.is_finite())) {
                let why = Error::Invalid("expected three finite numbers".into());
                return Err(OptionError::value(key, three(t), why).into());
            }
        }
        if let Some(arm) = self.lever_arm_m {
            check_lever_arm_m(arm).map_err(|e| OptionError::value("lever_arm_m", three(arm), e))?;
        }
        if let Some(b) = self.boresight_deg {
            check_boresight_deg(b).map_err(|e| OptionError::value("boresight_deg", three(b), e))?;
        }
        if let Some(bad) = self
            .pose
            .and_then(|p| p.into_iter().find(|x| !x.is_finite()))
        {
            return Err(OptionError::number("pose", bad, "not a finite number").into());
        }
        Ok(())
    }

    /// The options every frame shares: the values checked, then the files named read
    /// (camera, poses, external orientation, DEM, the CRS). `photo`: the one photo a `pose`
    /// is for.
    pub fn resolve(&self, photo: Option<&Path>) -> Result<DroneOptions, Error> {
        self.validate()?;
        let geo_format = self
            .geo
            .as_deref()
            .map(|p| -> Result<_, Error> {
                let text = aerorect_io::read_text(p).map_err(|e| {
                    let read = Error::context("cannot read")(e);
                    OptionError::value("geo", p.display(), read)
                })?;
                Ok(aerorect_io::eo::detect_format(&text))
            })
            .transpose()?;
        let geo_is_poses = geo_format == Some(EoFormat::PoseCsv);
        if geo_is_poses && self.poses.is_some() {
            return Err(Error::advice(
                "`geo` is a pose table and `poses` gives another: give one of them",
            ));
        }
        let poses = if geo_is_poses {
            self.geo.as_deref()
        } else {
            self.poses.as_deref()
        };
        let mounting = Mounting::from_angles(
            self.boresight_deg.unwrap_or([0.0; 3]),
            self.lever_arm_m.unwrap_or([0.0; 3]),
        );
        Ok(DroneOptions {
            gsd_m: self.gsd_m,
            ground_height_m: self.ground_height_m,
            dem: self.dem.as_deref().map(load_dem).transpose()?.map(Arc::new),
            vertical_offset_m: self.vertical_offset_m,
            strict: self.strict,
            occlusion: self.occlusion,
            crs: self.output_crs(poses)?,
            camera: self.camera.as_deref().map(CameraFile::read).transpose()?,
            poses: self.pose_table(poses, photo)?.map(Arc::new),
            mounting,
            geo: match (&self.geo, geo_is_poses) {
                (Some(p), false) => Some(Arc::new(load_geo_file(p)?)),
                _ => None,
            },
            track_headings: None,
            sensefly_roll: self.sensefly_roll,
            limits: self.limits,
            warp: self.warp,
            cog: self
                .cog
                .then(|| CogOptions::masked_by_alpha(self.warp.alpha)),
        })
    }

    /// [`Self::resolve`] for the frames of a flight, with the flight's checks: a photo given
    /// twice, photos the external-orientation file misses, and the GPS-track headings of
    /// photos without attitude. Returns the warnings too.
    pub fn resolve_flight(&self, inputs: &[PathBuf]) -> Result<(DroneOptions, Vec<String>), Error> {
        let mut opts = self.resolve(None)?;
        let warnings = prepare_flight(&mut opts, inputs)?;
        Ok((opts, warnings))
    }

    /// The output CRS: `crs`, else the pose table's `.prj` (an error names the one it came
    /// from and its text).
    fn output_crs(&self, poses: Option<&Path>) -> Result<Option<Crs>, Error> {
        if let Some(text) = &self.crs {
            return projected_crs(text)
                .map(Some)
                .map_err(|e| OptionError::value("crs", short(text), e).into());
        }
        let Some(prj) = poses.map(|p| p.with_extension("prj")) else {
            return Ok(None);
        };
        let Ok(text) = aerorect_io::read_text(&prj) else {
            return Ok(None);
        };
        let text = text.trim();
        let origin = format!("{} (the poses' CRS) {}", prj.display(), short(text));
        projected_crs(text)
            .map(Some)
            .map_err(Error::context(origin))
    }

    /// The pose table `poses` names, or the one row of `pose` for `photo`.
    fn pose_table(
        &self,
        poses: Option<&Path>,
        photo: Option<&Path>,
    ) -> Result<Option<BTreeMap<String, PoseRecord>>, Error> {
        if let Some([x, y, z, omega, phi, kappa]) = self.pose {
            let Some(name) = photo.and_then(|p| p.file_name()).and_then(|n| n.to_str()) else {
                return Err(Error::advice(
                    "`pose` is for one photo; give a flight's poses as a table (`poses`)",
                ));
            };
            let rec = PoseRecord {
                filename: name.to_string(),
                x,
                y,
                z,
                omega,
                phi,
                kappa,
            };
            return Ok(Some([(name.to_string(), rec)].into_iter().collect()));
        }
        let Some(p) = poses else { return Ok(None) };
        let rows = aerorect_io::read_poses(p)?;
        Ok(Some(
            rows.into_iter().map(|r| (r.filename.clone(), r)).collect(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::FLAG;

    fn refused(r: PhotoRequest) -> String {
        let e = r.resolve(None).expect_err("refused");
        e.spelled(&FLAG).full_message()
    }

    #[test]
    fn values_are_refused_naming_the_option_before_any_file_is_read() {
        // The DEM does not exist: the bad GSD is said first, and no file is opened for it.
        let r = PhotoRequest {
            gsd_m: Some(-1.0),
            dem: Some("no/such/dem.tif".into()),
            ..PhotoRequest::default()
        };
        let m = refused(r);
        assert!(m.starts_with("--gsd-m -1: GSD -1 m must be"), "{m}");
        let m = refused(PhotoRequest {
            lever_arm_m: Some([0.0, 2e3, 0.0]),
            ..PhotoRequest::default()
        });
        assert!(m.starts_with("--lever-arm-m '0,2000,0': lever arm"), "{m}");
        let m = refused(PhotoRequest {
            boresight_deg: Some([0.0, 400.0, 0.0]),
            ..PhotoRequest::default()
        });
        assert!(m.starts_with("--boresight-deg '0,400,0': boresight"), "{m}");
        let m = refused(PhotoRequest {
            pose: Some([0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0]),
            ..PhotoRequest::default()
        });
        assert_eq!(m, "--pose NaN: not a finite number");
    }

    #[test]
    fn the_crs_must_be_projected_and_its_text_is_named() {
        let with = |t: &str| PhotoRequest {
            crs: Some(t.into()),
            ..PhotoRequest::default()
        };
        let m = refused(with("EPSG:4326"));
        assert_eq!(
            m,
            "--crs 'EPSG:4326': a geographic CRS (degrees): orthos need a projected CRS in metres"
        );
        assert!(refused(with("EPSG:1")).starts_with("--crs 'EPSG:1': CRS: EPSG:1 is an unknown"));
        // A long text is shortened in the message; a good one is the EPSG table's zone.
        let long = format!("+proj=longlat +datum=WGS84 +no_defs{}", "x".repeat(90));
        assert!(refused(with(&long)).contains("+no_defsxxx"));
        assert!(refused(with(&long)).contains("...'"));
        let utm = "+proj=utm +zone=35 +datum=WGS84 +units=m +no_defs";
        let opts = with(utm).resolve(None).expect("a UTM zone");
        let zone = Crs::from_epsg(32635).expect("in the table");
        assert!(opts.crs.is_some_and(|c| c.same_as(&zone)));
    }
}
