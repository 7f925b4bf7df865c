//! What travels between processes: JSON that gives back every float to the bit, and a
//! flight's progress (orientation, rounds) in that form.

use super::*;

/// JSON that gives back every finite float to the bit (each written as `"f64:"` and its bits
/// in hex; a NaN or infinity becomes null, which reading refuses): a round's matches and
/// orientation go from worker to worker so.
pub fn exact_json<T: Serialize>(value: &T) -> Result<String, Error> {
    let mut v = serde_json::to_value(value).map_err(Error::from)?;
    map_numbers(&mut v, &|v| {
        if let serde_json::Value::Number(n) = v
            && n.is_f64()
            && let Some(x) = n.as_f64()
        {
            *v = serde_json::Value::String(format!("f64:{:016x}", x.to_bits()));
        }
    });
    serde_json::to_string(&v).map_err(Error::from)
}

/// The value [`exact_json`] wrote.
pub fn from_exact_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, Error> {
    let mut v: serde_json::Value =
        serde_json::from_str(text).map_err(Error::context("exact JSON"))?;
    map_numbers(&mut v, &|v| {
        if let serde_json::Value::String(s) = v
            && let Some(bits) = s.strip_prefix("f64:")
            && let Ok(b) = u64::from_str_radix(bits, 16)
        {
            *v = serde_json::Number::from_f64(f64::from_bits(b))
                .map_or(serde_json::Value::Null, serde_json::Value::Number);
        }
    });
    serde_json::from_value(v).map_err(Error::context("exact JSON"))
}

pub(super) fn map_numbers(v: &mut serde_json::Value, f: &dyn Fn(&mut serde_json::Value)) {
    match v {
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| map_numbers(x, f)),
        serde_json::Value::Object(o) => o.values_mut().for_each(|x| map_numbers(x, f)),
        _ => f(v),
    }
}

/// A pose's file form: the centre and `world_from_camera` row by row.
pub(super) type PoseFile = ([f64; 3], [[f64; 3]; 3]);

/// [`FlightProgress`]'s file form.
#[derive(Serialize, Deserialize)]
pub(super) struct ProgressFile {
    pub(super) poses: Option<Vec<PoseFile>>,
    pub(super) cameras: Option<Vec<CameraFile>>,
    pub(super) rounds: Vec<RoundSummary>,
    pub(super) done: bool,
    /// The last round's corrections as the solver holds them (the next solve's start).
    #[serde(default)]
    pub(super) start: Option<Vec<f64>>,
    /// The tie surface, once the rounds are done (when they made one).
    #[serde(default)]
    pub(super) surface: Option<SurfaceFile>,
}

/// A [`TieSurface`]'s file form: its report (extent, size, cell), heights row by row and the
/// CRS's WKT.
#[derive(Serialize, Deserialize)]
pub(super) struct SurfaceFile {
    pub(super) report: SurfaceReport,
    pub(super) values: Vec<f32>,
    pub(super) crs_wkt: String,
}

impl SurfaceFile {
    fn from_surface(s: &TieSurface) -> Result<Self, Error> {
        Ok(Self {
            report: s.report.clone(),
            values: s.dem.values.clone(),
            crs_wkt: s.dem.crs.to_wkt()?,
        })
    }

    fn into_surface(self) -> Result<TieSurface, Error> {
        let r = &self.report;
        let dem = aerorect_geo::Dem {
            name: SURFACE_NAME.into(),
            values: self.values,
            width: r.size[0],
            height: r.size[1],
            top_left: [r.extent[0], r.extent[3]],
            cell_size: [r.cell_m, r.cell_m],
            crs: Crs::from_wkt(self.crs_wkt)?,
        };
        dem.validate()?;
        Ok(TieSurface {
            dem: std::sync::Arc::new(dem),
            report: self.report,
        })
    }
}

#[derive(Serialize, Deserialize)]
pub(super) struct CameraFile {
    pub(super) intrinsics: aerorect_core::Intrinsics,
    pub(super) distortion: Option<aerorect_core::distortion::Distortion>,
    pub(super) size: ImageSize,
}

impl FlightProgress {
    /// As [`exact_json`]: every float to the bit.
    pub fn to_json(&self) -> Result<String, Error> {
        let o = self.orientation.as_ref();
        let file = ProgressFile {
            poses: o.map(|o| {
                o.poses
                    .iter()
                    .map(|p| {
                        let m = p.world_from_camera();
                        let row = |r: usize| [m[(r, 0)], m[(r, 1)], m[(r, 2)]];
                        (p.centre, [row(0), row(1), row(2)])
                    })
                    .collect()
            }),
            cameras: o.map(|o| {
                o.cameras
                    .iter()
                    .map(|c| CameraFile {
                        intrinsics: c.intrinsics,
                        distortion: c.distortion.clone(),
                        size: c.size,
                    })
                    .collect()
            }),
            rounds: self.rounds.clone(),
            done: self.done,
            start: self.start.as_ref().map(|c| c.to_values()),
            surface: self
                .surface
                .as_ref()
                .map(SurfaceFile::from_surface)
                .transpose()?,
        };
        exact_json(&file)
    }

    pub fn from_json(text: &str) -> Result<Self, Error> {
        let f: ProgressFile = from_exact_json(text)?;
        let orientation = match (f.poses, f.cameras) {
            (Some(p), Some(c)) => Some(Orientation {
                poses: p
                    .into_iter()
                    .map(|(centre, [a, b, c])| {
                        let m = aerorect_core::Mat3::new(
                            a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2],
                        );
                        Pose::new(centre, &m)
                    })
                    .collect(),
                cameras: c
                    .into_iter()
                    .map(|c| Camera::new(c.intrinsics, c.distortion, c.size))
                    .collect(),
            }),
            _ => None,
        };
        let start = match (&orientation, f.start) {
            (Some(o), Some(v)) => {
                let cameras = Corrections::camera_count(v.len(), o.poses.len());
                cameras.and_then(|c| Corrections::from_values(o.poses.len(), c, &v))
            }
            _ => None,
        };
        Ok(Self {
            orientation,
            rounds: f.rounds,
            done: f.done,
            since: None,
            start,
            surface: f.surface.map(SurfaceFile::into_surface).transpose()?,
            sampled: None,
        })
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    #[test]
    fn exact_json_gives_back_every_float_to_the_bit() {
        // Floats whose shortest decimal form a best-effort parser may miss by an ulp.
        let awkward = [
            0.1 + 0.2,
            -0.0,
            f64::MIN_POSITIVE / 3.0,
            f64::MAX,
            1.0 - f64::EPSILON / 2.0,
            2.0f64.sqrt() * 1e-300,
            123456.789_012_345_67,
        ];
        let tie = |w: &[f64]| PairTie {
            ground: [w[0], w[1], -w[0]],
            pixel_a: [w[1], w[0]],
            pixel_b: [w[0] * 0.5, w[1] / 7.0],
            weight: w[0],
        };
        // The spare ties (those the final solve adds) travel to the bit too.
        let m = PairMatch {
            a: 2,
            b: 7,
            patches: 40,
            inliers: 9,
            ties: awkward.windows(2).map(tie).collect(),
            spare: awkward.windows(2).rev().map(tie).collect(),
            features: true,
        };
        let back: PairMatch = from_exact_json(&exact_json(&m).unwrap()).unwrap();
        let bits = |m: &PairMatch| -> Vec<u64> {
            m.solve_ties(true)
                .flat_map(|t| {
                    let mut v = t.ground.to_vec();
                    v.extend(t.pixel_a);
                    v.extend(t.pixel_b);
                    v.push(t.weight);
                    v
                })
                .map(f64::to_bits)
                .collect()
        };
        assert_eq!(bits(&back), bits(&m));
        assert_eq!(back.spare.len(), m.spare.len());
        assert_eq!((back.a, back.b, back.patches, back.inliers), (2, 7, 40, 9));
    }

    #[test]
    fn progress_gives_back_poses_and_cameras_to_the_bit() {
        let r = aerorect_core::CameraRotation::omega_phi_kappa(0.1 + 0.2, -1.3e-3, 271.7).unwrap();
        let pose = Pose::new(
            [512_345.678_9, 5_974_321.012_3, 0.1 + 0.2],
            r.ground_from_camera(),
        );
        let k = aerorect_core::Intrinsics::new(3666.6667, 3666.6666, 2735.7, 1823.3).unwrap();
        let camera = Camera::new(k, None, ImageSize::new(5472, 3648));
        let p = FlightProgress {
            orientation: Some(Orientation {
                poses: vec![pose],
                cameras: vec![camera],
            }),
            rounds: vec![],
            done: true,
            since: None,
            start: Corrections::from_values(1, 1, &vec![0.125; Corrections::value_count(1, 1)]),
            surface: None,
            sampled: None,
        };
        assert!(p.start.is_some());
        let back = FlightProgress::from_json(&p.to_json().unwrap()).unwrap();
        assert_eq!(back.orientation, p.orientation);
        assert_eq!(back.start, p.start);
        assert!(back.done);
        assert!(back.surface.is_none());
    }

    /// A 4 x 3 tie surface whose heights and extent need every bit of their floats, and its
    /// heights.
    pub(in crate::flight) fn bit_surface() -> (TieSurface, Vec<f32>) {
        let crs = Crs::from_epsg(32633).unwrap();
        let values: Vec<f32> = (0..12).map(|k| 160.0 + 0.1 * k as f32 / 3.0).collect();
        let report = SurfaceReport {
            tie_points: 60,
            rejected: 3,
            cell_m: 2.0,
            extent: [0.1 + 0.2, -8.0, 8.0 + 0.1 + 0.2, 0.0],
            size: [4, 3],
            heights_m: [160.0, 160.4],
            spread_m: 0.1 + 0.2,
        };
        let dem = aerorect_geo::Dem {
            name: SURFACE_NAME.into(),
            values: values.clone(),
            width: 4,
            height: 3,
            top_left: [report.extent[0], report.extent[3]],
            cell_size: [2.0, 2.0],
            crs,
        };
        let surface = TieSurface {
            dem: std::sync::Arc::new(dem),
            report,
        };
        (surface, values)
    }

    /// `back` is `surface` (of [`bit_surface`], whose heights are `values`) to the bit.
    pub(in crate::flight) fn assert_same_surface(
        back: &TieSurface,
        (surface, values): &(TieSurface, Vec<f32>),
    ) {
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.dem.values), bits(values));
        assert_eq!(back.report, surface.report);
        let e = surface.report.extent;
        assert_eq!(back.dem.top_left, [e[0], e[3]]);
        assert!(back.dem.crs.same_as(&Crs::from_epsg(32633).unwrap()));
    }

    #[test]
    fn progress_gives_back_its_tie_surface_to_the_bit() {
        let sample = bit_surface();
        let p = FlightProgress {
            done: true,
            surface: Some(sample.0.clone()),
            ..FlightProgress::default()
        };
        let back = FlightProgress::from_json(&p.to_json().unwrap()).unwrap();
        assert_same_surface(&back.surface.unwrap(), &sample);
    }
}
