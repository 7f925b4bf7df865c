//! Marking help: where each surveyed point falls in each photo by the current orientation
//! (recorded metadata, a pose table or an external-orientation file), so a user marks only
//! where it is needed.

use super::*;

/// A surveyed point's predicted position in one photo.
#[derive(Debug, Clone, Serialize)]
pub struct MarkPrediction {
    pub point: String,
    pub image: String,
    /// The photo's index among the inputs.
    pub frame: usize,
    /// Pixel centres at integers (ours; ODM's too).
    pub pixel: [f64; 2],
    /// The point's coordinates as the file gives them (its CRS and heights).
    pub file_xyz: [f64; 3],
    /// Whether it is marked there already (a mark in the file for this point and photo).
    pub marked: bool,
}

/// The predictions of the photos that see each point: the pixel inside the photo.
impl FlightPlan {
    pub fn predict_control(&self) -> Result<Vec<MarkPrediction>, Error> {
        let (Some(control), Some(co)) = (&self.control, &self.fo.control) else {
            return Err(Error::Invalid(
                "predicting marks needs ground control points".into(),
            ));
        };
        let mut out = Vec::new();
        for (p, sp) in control.points.iter().zip(&co.file.points) {
            for (k, f) in self.frames.iter().enumerate() {
                let camera = &self.rec.cameras[self.rec.camera_of[k]];
                let Some(px) = control::predict(&self.rec.poses[k], camera, p.ground) else {
                    continue;
                };
                let (w, h) = (camera.size.width as f64, camera.size.height as f64);
                if !(px[0] >= -0.5 && px[0] < w - 0.5 && px[1] >= -0.5 && px[1] < h - 0.5) {
                    continue;
                }
                out.push(MarkPrediction {
                    point: p.name.clone(),
                    image: f
                        .input
                        .file_name()
                        .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                    frame: k,
                    pixel: px,
                    file_xyz: sp.xyz,
                    marked: p.marks.iter().any(|m| m.frame == k),
                });
            }
        }
        Ok(out)
    }

    /// The predictions as ODM's `gcp_list.txt` (the file's CRS line, then
    /// `geo_x geo_y geo_z im_x im_y image_name gcp_name`), for a user to correct and use.
    pub fn predictions_gcp_list(&self, predictions: &[MarkPrediction]) -> String {
        let crs = self
            .fo
            .control
            .as_ref()
            .and_then(|c| c.file.crs.as_ref())
            .unwrap_or(&self.crs);
        let mut out = format!("{}\n", crs.definition());
        for p in predictions {
            out += &format!(
                "{} {} {} {:.2} {:.2} {} {}\n",
                p.file_xyz[0],
                p.file_xyz[1],
                p.file_xyz[2],
                p.pixel[0],
                p.pixel[1],
                p.image,
                p.point
            );
        }
        out
    }
}

/// A `side` x `side` chip of `photo` centred on the pixel nearest `pixel` (the predicted
/// point at (side / 2, side / 2)); beyond the photo's edge the chip is 0.
pub fn chip(photo: &AnyRaster, pixel: [f64; 2], side: usize) -> Result<AnyRaster, Error> {
    fn cut<T: aerorect_raster::Sample>(
        r: &Raster<T>,
        origin: (i64, i64),
        side: usize,
    ) -> Result<Raster<T>, Error> {
        let planes = (0..r.bands())
            .map(|b| {
                let mut out = vec![T::default(); side * side];
                for y in 0..side {
                    for x in 0..side {
                        let (sx, sy) = (origin.0 + x as i64, origin.1 + y as i64);
                        if sx >= 0
                            && sy >= 0
                            && let Some(v) = r.get(b, sx as usize, sy as usize)
                        {
                            out[y * side + x] = v;
                        }
                    }
                }
                out
            })
            .collect();
        Ok(Raster::from_planes(ImageSize::new(side, side), planes)?)
    }
    let half = (side / 2) as i64;
    let origin = (
        pixel[0].round() as i64 - half,
        pixel[1].round() as i64 - half,
    );
    Ok(match photo {
        AnyRaster::U8(r) => AnyRaster::U8(cut(r, origin, side)?),
        AnyRaster::U16(r) => AnyRaster::U16(cut(r, origin, side)?),
        AnyRaster::F32(r) => AnyRaster::F32(cut(r, origin, side)?),
    })
}
