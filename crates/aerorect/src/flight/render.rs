//! The adjusted flight rendered: each frame with its adjusted pose and camera onto the output
//! grid (written staged), the mosaic's frames, and the overview.

use super::*;

/// The flight after adjustment: every frame's corrected pose and camera.
pub struct AdjustedFlight {
    pub(super) frames: Vec<Frame>,
    /// Every frame as rendered for the last matching round.
    pub(super) rendered: Vec<Rendered>,
    /// The last round's tie points, with their gaps before and after.
    pub ties: Vec<TieVector>,
    pub poses: Vec<Pose>,
    pub cameras: Vec<Camera>,
    pub report: FlightReport,
    pub(super) crs: Crs,
    /// The ground the tie points describe, when the frames are rendered over it (see
    /// [`FlightOptions::tie_surface`]; `None`: the level ground, or the DEM of `opts`).
    pub surface: Option<std::sync::Arc<aerorect_geo::Dem>>,
    /// The photos the rounds decoded.
    pub(super) decoded: std::sync::Arc<decoded::Decoded>,
}

/// A frame with a pose and camera, and the flight's CRS.
pub(super) struct Oriented<'a> {
    pub(super) frame: &'a Frame,
    pub(super) pose: Pose,
    pub(super) camera: &'a Camera,
    pub(super) crs: &'a Crs,
    /// The tie surface, the ground when `opts` has no DEM.
    pub(super) surface: Option<&'a std::sync::Arc<aerorect_geo::Dem>>,
    /// The flight's decoded photos, and the frame's index among them.
    pub(super) decoded: (&'a decoded::Decoded, usize),
}

impl Oriented<'_> {
    /// The frame's ortho plan on the output grid (`opts`'s GSD, else the frame's own at nadir).
    pub(super) fn plan(&self, opts: &DroneOptions) -> Result<OrthoPlan, Error> {
        let f = self.frame;
        let file = f.input.display().to_string();
        let ground = frame_ground(f, opts, self.surface);
        // `info.gsd_m` is the matching grid's; the frame's own is its height over fx.
        let own_gsd = f.info.height_m / f.info.camera.camera.intrinsics.fx;
        let req = OrthoRequest {
            camera: self.camera,
            pose: self.pose,
            world: self.crs,
            ground: &ground,
            gsd_m: opts.gsd_m.unwrap_or(own_gsd),
            limits: opts.limits,
            occlusion: opts.occlusion,
        };
        plan_ortho(&req, opts.warp).map_err(Error::context(&file))
    }

    /// Rectifies the frame onto the output grid, its output staged.
    pub(super) fn write_staged(
        &self,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let t = std::time::Instant::now();
        let mut lap_t = t;
        let f = self.frame;
        let image = self.decoded.0.get(self.decoded.1, &f.input)?;
        let read = crate::drone::lap(&mut lap_t);
        let plan = self.plan(opts)?;
        let plan_s = crate::drone::lap(&mut lap_t);
        let out = plan.run(&image)?;
        let warp = crate::drone::lap(&mut lap_t);
        let mut info = f.info.clone();
        info.pose = self.pose;
        info.geo = georeference(self.crs.clone(), &plan, &opts.warp);
        info.gsd_m = plan.grid.gsd;
        info.warnings.extend(plan.warnings.iter().cloned());
        crate::drone::stage_output(staged, output, &out, &info.geo, opts.cog.as_ref())?;
        let stage_seconds = crate::drone::StageSeconds {
            read,
            plan: plan_s,
            warp,
            write: crate::drone::lap(&mut lap_t),
        };
        Ok(crate::drone::PhotoResult {
            input: f.input.display().to_string(),
            output: output.display().to_string(),
            input_size: [image.size().width, image.size().height],
            output_size: [plan.grid.size.width, plan.grid.size.height],
            footprint_en: plan.footprint.clone(),
            info,
            seconds: t.elapsed().as_secs_f64(),
            stage_seconds,
            thumbnails: None,
        })
    }
}

impl AdjustedFlight {
    pub(super) fn oriented(&self, k: usize) -> Oriented<'_> {
        Oriented {
            frame: &self.frames[k],
            pose: self.poses[k],
            camera: &self.cameras[k],
            crs: &self.crs,
            surface: self.surface.as_ref(),
            decoded: (&self.decoded, k),
        }
    }

    /// Frame `k`'s ortho plan with its adjusted pose and camera on the output grid (`opts`'s
    /// GSD, else the frame's own at nadir).
    pub fn plan(&self, k: usize, opts: &DroneOptions) -> Result<OrthoPlan, Error> {
        self.oriented(k).plan(opts)
    }

    /// The photo at `path`: kept from the matching rounds when it fit their memory budget,
    /// else decoded (the same raster either way).
    pub fn photo(&self, path: &Path) -> Result<std::sync::Arc<AnyRaster>, Error> {
        match self.frames.iter().position(|f| f.input == path) {
            Some(k) => self.decoded.get(k, path),
            None => Ok(std::sync::Arc::new(aerorect_io::read_image(path)?)),
        }
    }

    /// The output CRS of every frame.
    pub fn crs(&self) -> &Crs {
        &self.crs
    }

    /// Every frame planned for a mosaic with its adjusted pose and camera, all at one GSD:
    /// `opts`'s, else the finest frame's own (to the millimetre, as
    /// [`crate::mosaic::frames_from_photos`] chooses it).
    pub fn mosaic_frames(
        &self,
        opts: &DroneOptions,
    ) -> Result<Vec<crate::mosaic::MosaicFrame>, Error> {
        let mut o = opts.clone();
        if o.gsd_m.is_none() {
            let finest = self
                .frames
                .iter()
                .map(|f| f.info.height_m / f.info.camera.camera.intrinsics.fx)
                .fold(f64::INFINITY, f64::min);
            o.gsd_m = Some(((finest * 1000.0).round() / 1000.0).max(0.001));
        }
        (0..self.frames.len())
            .map(|k| {
                let c = self.poses[k].centre;
                Ok(crate::mosaic::MosaicFrame {
                    path: self.frames[k].input.clone(),
                    plan: self.plan(k, &o)?,
                    nadir_xy: [c[0], c[1]],
                    height_m: c[2] - level_ground(&self.frames[k]),
                })
            })
            .collect()
    }

    /// Rectifies frame `k` with its adjusted pose and camera onto the output grid and writes
    /// `output` (GeoTIFF, COG with `opts.cog`, or PNG + world file) atomically.
    pub fn write_frame(
        &self,
        k: usize,
        output: &Path,
        opts: &DroneOptions,
    ) -> Result<crate::drone::PhotoResult, Error> {
        let mut staged = aerorect_io::StagedOutputs::new();
        let r = self.write_frame_staged(k, output, opts, &mut staged)?;
        staged.commit()?;
        Ok(r)
    }

    /// [`Self::write_frame`] with the output staged, to land with the caller's other outputs.
    pub fn write_frame_staged(
        &self,
        k: usize,
        output: &Path,
        opts: &DroneOptions,
        staged: &mut aerorect_io::StagedOutputs,
    ) -> Result<crate::drone::PhotoResult, Error> {
        self.oriented(k).write_staged(output, opts, staged)
    }

    /// A gray overview of the flight on the matching grid, each cell the mean of the frames
    /// that see it (as rendered for the last matching round), stretched to 8 bits between its
    /// 1st and 99th percentiles; cells no frame sees are black. An error for a flight adjusted
    /// without it ([`super::adjust_flight_for`]).
    pub fn overview(&self) -> Result<Raster<u8>, Error> {
        let grids: Vec<_> = self.rendered.iter().map(|f| f.coarse_plan.grid).collect();
        let Some(g0) = grids.first() else {
            return Err(Error::Invalid(
                "the flight's overview: the flight was adjusted without rendering its frames for it"
                    .into(),
            ));
        };
        let gsd = g0.gsd;
        let left = grids
            .iter()
            .map(|g| g.top_left[0])
            .fold(f64::INFINITY, f64::min);
        let top = grids
            .iter()
            .map(|g| g.top_left[1])
            .fold(f64::NEG_INFINITY, f64::max);
        let at = |g: &aerorect_geo::OrthoGrid| {
            (
                ((g.top_left[0] - left) / gsd).round() as usize,
                ((top - g.top_left[1]) / gsd).round() as usize,
            )
        };
        let (w, h) = grids.iter().fold((0, 0), |(w, h), g| {
            let (c, r) = at(g);
            (w.max(c + g.size.width), h.max(r + g.size.height))
        });
        if w * h > 64_000_000 {
            return Err(Error::Invalid(format!(
                "the flight's overview would be {w} x {h} px"
            )));
        }
        let (mut sum, mut n) = (vec![0f64; w * h], vec![0u32; w * h]);
        for (f, g) in self.rendered.iter().zip(&grids) {
            let (c0, r0) = at(g);
            for (i, v) in f.coarse.plane(0).iter().enumerate() {
                if v.is_finite() {
                    let j = (r0 + i / g.size.width) * w + c0 + i % g.size.width;
                    sum[j] += *v as f64;
                    n[j] += 1;
                }
            }
        }
        let mean: Vec<Option<f64>> = sum
            .iter()
            .zip(&n)
            .map(|(s, &k)| (k > 0).then(|| s / k as f64))
            .collect();
        let mut seen: Vec<f64> = mean.iter().flatten().copied().collect();
        seen.sort_by(f64::total_cmp);
        let q = |p: f64| {
            seen.get((p * (seen.len().max(1) - 1) as f64) as usize)
                .copied()
        };
        let (lo, hi) = (q(0.01).unwrap_or(0.0), q(0.99).unwrap_or(1.0));
        let px = mean
            .iter()
            .map(|m| {
                m.map_or(0, |v| {
                    (1.0 + 254.0 * ((v - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0)) as u8
                })
            })
            .collect();
        Ok(Raster::from_planes(ImageSize::new(w, h), vec![px])?)
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}
