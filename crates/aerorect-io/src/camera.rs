//! The camera file (TOML).
//!
//! Either the paper's physical parameters:
//! `focal_length_mm`, `pixel_pitch_um = [dx, dy]`, optional `principal_point_px = [u0, v0]`;
//! or intrinsics in pixels: `fx_px`, `fy_px`, optional `cx_px`, `cy_px`, `skew_px`.
//! Optional `image_size_px = [W, H]`: the size the pixel values are for; an image resampled to
//! another size of the same aspect ratio gets the camera scaled to it. The principal point
//! defaults to the image centre ((W-1)/2, (H-1)/2). Optional `[distortion]` table: `model`
//! (tsai, brown, improved, opencv, opencv-rational, opencv-thin-prism,
//! opencv-rational-thin-prism) and the coefficients by name (missing ones are zero). Unknown keys are an error.
//!
//! Sane ranges (an absurd value is refused naming its key): each side of `image_size_px`
//! 1 ..= 1,000,000 px and at most 4e9 px in all; focal lengths 0.001 ..= 1e7 px; |principal
//! point| and |skew| <= 1e7 px; every lens coefficient |k| <= 1e4 (normalised coordinates).
//!
//! [`CameraFile::read`] and [`CameraFile::camera`], which reach every other format, are defined
//! with the formats (`camera_formats`).

use crate::error::IoError;
use aerorect_core::camera::MAX_LENS_COEFFICIENT;
use aerorect_core::error::require_magnitude;
use aerorect_core::intrinsics::FOCAL_RANGE_PX;
use aerorect_core::{Camera, GeometryError, ImageSize, Intrinsics};
use serde::Deserialize;

#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    pub focal_length_mm: Option<f64>,
    pub pixel_pitch_um: Option<[f64; 2]>,
    pub principal_point_px: Option<[f64; 2]>,
    pub image_size_px: Option<[u64; 2]>,
    pub fx_px: Option<f64>,
    pub fy_px: Option<f64>,
    pub cx_px: Option<f64>,
    pub cy_px: Option<f64>,
    pub skew_px: Option<f64>,
    /// `[distortion]` with `model` one of `Distortion::NAMES` and named coefficients.
    pub distortion: Option<aerorect_core::distortion::Distortion>,
    /// Where the file came from, for messages.
    #[serde(skip)]
    pub source_name: String,
    /// A DJI DewarpData text, read once the image size is known (it states none).
    #[serde(skip)]
    pub dewarp_text: Option<String>,
}

impl CameraFile {
    /// The file holding `camera` in pixels, with its size (reads back to the same camera).
    pub fn from_camera(camera: &Camera, source_name: &str) -> Self {
        let k = &camera.intrinsics;
        CameraFile {
            image_size_px: Some([camera.size.width as u64, camera.size.height as u64]),
            fx_px: Some(k.fx),
            fy_px: Some(k.fy),
            cx_px: Some(k.cx),
            cy_px: Some(k.cy),
            skew_px: Some(k.skew),
            distortion: camera.distortion.clone(),
            source_name: source_name.to_string(),
            ..CameraFile::default()
        }
    }

    pub fn parse(text: &str, source_name: &str) -> Result<Self, IoError> {
        let mut cam: CameraFile =
            toml::from_str(text).map_err(|e| IoError::field(source_name, e.message()))?;
        cam.source_name = source_name.to_string();
        cam.check_distortion()?;
        cam.check_ranges()?;
        Ok(cam)
    }

    /// Every `[distortion]` coefficient must be finite (a NaN or infinite one maps every pixel
    /// to nowhere) and within +-`MAX_LENS_COEFFICIENT`.
    fn check_distortion(&self) -> Result<(), IoError> {
        let Some(d) = &self.distortion else {
            return Ok(());
        };
        let model = d.model();
        for (name, v) in model.names().iter().zip(model.params()) {
            require_magnitude(
                name,
                v,
                (0.0, MAX_LENS_COEFFICIENT),
                "outside the sane range |value| <= 1e4",
            )
            .map_err(|e| self.err(format!("[distortion] {e}")))?;
        }
        Ok(())
    }

    /// The values the file gives, each within its sane range (`Camera::validate`'s), named by
    /// its key: absurd values are refused where they are read, not where they break the work.
    fn check_ranges(&self) -> Result<(), IoError> {
        self.image_size()?;
        let geo = |e: GeometryError| self.err(e);
        let focal = "outside the sane range 0.001 ..= 1e7 px";
        for (field, v) in [("fx_px", self.fx_px), ("fy_px", self.fy_px)] {
            if let Some(v) = v {
                require_magnitude(field, v, FOCAL_RANGE_PX, focal).map_err(geo)?;
            }
        }
        let pp = self.principal_point_px.unwrap_or([0.0; 2]);
        let offsets = [
            ("cx_px", self.cx_px),
            ("cy_px", self.cy_px),
            ("skew_px", self.skew_px),
            ("principal_point_px[0]", Some(pp[0])),
            ("principal_point_px[1]", Some(pp[1])),
        ];
        for (field, v) in offsets {
            if let Some(v) = v {
                let range = (0.0, FOCAL_RANGE_PX.1);
                require_magnitude(field, v, range, "outside the sane range |value| <= 1e7 px")
                    .map_err(geo)?;
            }
        }
        Ok(())
    }

    fn err(&self, message: impl ToString) -> IoError {
        IoError::field(&self.source_name, message)
    }

    /// [`CameraFile::camera`] from the file's own keys (not a DewarpData text): for an image of
    /// `image` pixels (or, without one, of the file's `image_size_px`). A file that states `image_size_px` is carried to an image of another
    /// size with the same aspect ratio by [`Camera::resized`]; another aspect ratio is refused.
    pub(crate) fn camera_from_fields(&self, image: Option<ImageSize>) -> Result<Camera, IoError> {
        let stated = self.image_size()?;
        let size = stated
            .or(image)
            .ok_or_else(|| self.err("missing key image_size_px (needed to know the frame size)"))?;
        let camera = Camera::new(self.intrinsics(size)?, self.distortion.clone(), size);
        camera.validate().map_err(|e| self.err(e))?;
        match image {
            Some(image) if image != size => camera.resized(image).map_err(|e| match e {
                GeometryError::AspectMismatch { .. } => self.err(format!(
                    "image_size_px = [{}, {}] but the image is {} x {}: not the same aspect ratio",
                    size.width, size.height, image.width, image.height
                )),
                other => self.err(other),
            }),
            _ => Ok(camera),
        }
    }

    /// `image_size_px`, if given (within [`ImageSize::validate_sides`]'s range).
    fn image_size(&self) -> Result<Option<ImageSize>, IoError> {
        match self.image_size_px {
            None => Ok(None),
            Some([w, h]) => match ImageSize::validate_sides(w, h) {
                Ok(()) => Ok(Some(ImageSize::new(w as usize, h as usize))),
                Err(e) => Err(self.err(format!("image_size_px = [{w}, {h}]: {e}"))),
            },
        }
    }

    /// The intrinsics for a frame of `size`.
    fn intrinsics(&self, size: ImageSize) -> Result<Intrinsics, IoError> {
        let geo = |e: GeometryError| self.err(e);
        let pixels = self.fx_px.is_some() || self.fy_px.is_some();
        let physical = self.focal_length_mm.is_some() || self.pixel_pitch_um.is_some();
        if pixels && physical {
            return Err(
                self.err("give either focal_length_mm + pixel_pitch_um or fx_px + fy_px, not both")
            );
        }
        if self.principal_point_px.is_some() && (self.cx_px.is_some() || self.cy_px.is_some()) {
            return Err(self.err("give either principal_point_px or cx_px + cy_px, not both"));
        }
        let [cx0, cy0] = size.centre();
        let pp = self
            .principal_point_px
            .unwrap_or([self.cx_px.unwrap_or(cx0), self.cy_px.unwrap_or(cy0)]);
        let mut intr = if pixels {
            let fx = self.fx_px.ok_or_else(|| self.err("missing key fx_px"))?;
            let fy = self.fy_px.ok_or_else(|| self.err("missing key fy_px"))?;
            Intrinsics::new(fx, fy, pp[0], pp[1]).map_err(geo)?
        } else {
            let f = self
                .focal_length_mm
                .ok_or_else(|| self.err("missing key focal_length_mm"))?;
            let p = self
                .pixel_pitch_um
                .ok_or_else(|| self.err("missing key pixel_pitch_um"))?;
            Intrinsics::from_physical(f, p, pp).map_err(geo)?
        };
        if let Some(s) = self.skew_px {
            intr.skew = aerorect_core::error::require_finite("skew_px", s).map_err(geo)?;
        }
        for (field, v) in [
            ("principal_point_px[0]", pp[0]),
            ("principal_point_px[1]", pp[1]),
        ] {
            aerorect_core::error::require_finite(field, v).map_err(geo)?;
        }
        Ok(intr)
    }
}

/// The camera file of `camera`: intrinsics in pixels, `image_size_px` and the `[distortion]`
/// table; [`CameraFile::camera`] reads it back to the same camera.
pub fn camera_toml(camera: &Camera) -> Result<String, IoError> {
    let k = &camera.intrinsics;
    let mut s = format!(
        "fx_px = {:?}\nfy_px = {:?}\ncx_px = {:?}\ncy_px = {:?}\nskew_px = {:?}\nimage_size_px = [{}, {}]\n",
        k.fx, k.fy, k.cx, k.cy, k.skew, camera.size.width, camera.size.height
    );
    if let Some(d) = &camera.distortion {
        let table = toml::to_string(d).map_err(|e| IoError::field("[distortion]", e))?;
        s += "\n[distortion]\n";
        s += &table;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<CameraFile, IoError> {
        CameraFile::parse(s, "cam.toml")
    }

    #[test]
    fn physical_parameters_give_f_over_pitch() {
        let c = parse(
            "focal_length_mm = 50.0\npixel_pitch_um = [10.0, 12.5]\nimage_size_px = [640, 480]",
        )
        .expect("ok");
        let cam = c.camera(None).expect("camera");
        assert_eq!(cam.size, ImageSize::new(640, 480));
        let k = cam.intrinsics;
        assert_eq!((k.fx, k.fy), (5000.0, 4000.0));
        assert_eq!((k.cx, k.cy), (319.5, 239.5));
    }

    #[test]
    fn pixel_intrinsics_and_principal_point() {
        let c = parse("fx_px = 800.0\nfy_px = 810.0\ncx_px = 300.0\ncy_px = 200.0").expect("ok");
        let k = c.intrinsics(ImageSize::new(640, 480)).expect("intrinsics");
        assert_eq!((k.fx, k.fy, k.cx, k.cy), (800.0, 810.0, 300.0, 200.0));
    }

    #[test]
    fn distortion_table_by_model_and_name() {
        let c = parse("fx_px = 800.0\nfy_px = 800.0\n[distortion]\nmodel = \"opencv\"\nk1 = -0.25\np2 = 0.001\n").expect("ok");
        let d = c.distortion.expect("present");
        assert_eq!(d.kind(), "opencv");
        // `opencv` is OpenCV's default five coefficients (k1, k2, p1, p2, k3).
        assert_eq!(d.model().params(), vec![-0.25, 0.0, 0.0, 0.001, 0.0]);
        let e = parse("fx_px = 800.0\nfy_px = 800.0\n[distortion]\nmodel = \"tsai\"\np1 = 0.1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("cam.toml") && e.contains("p1"), "{e}");
        let e = parse("fx_px = 800.0\nfy_px = 800.0\n[distortion]\nmodel = \"fisheye\"\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("fisheye"), "{e}");
        for (value, shown) in [("nan", "k2 = NaN"), ("-inf", "k2 = -inf")] {
            let text = format!(
                "fx_px = 1.0\nfy_px = 1.0\n[distortion]\nmodel = \"brown\"\nk2 = {value}\n"
            );
            let e = parse(&text).unwrap_err().to_string();
            assert!(e.contains("cam.toml") && e.contains(shown), "{e}");
        }
    }

    #[test]
    fn errors_name_the_file_and_field() {
        let e = parse("focal_length_mm = 50.0\nfocal_lenght = 3")
            .unwrap_err()
            .to_string();
        assert!(e.contains("cam.toml") && e.contains("focal_lenght"), "{e}");
        let e = parse("pixel_pitch_um = [10.0, 10.0]")
            .expect("parses")
            .intrinsics(ImageSize::new(4, 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing key focal_length_mm"), "{e}");
        let e = parse("focal_length_mm = -5.0\npixel_pitch_um = [10.0, 10.0]")
            .expect("parses")
            .intrinsics(ImageSize::new(4, 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("focal_length_mm = -5"), "{e}");
        let e = parse("focal_length_mm = nan\npixel_pitch_um = [10.0, 10.0]")
            .expect("parses")
            .intrinsics(ImageSize::new(4, 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("focal_length_mm = NaN"), "{e}");
        let e = parse("focal_length_mm = 5.0\npixel_pitch_um = [0.0, 10.0]")
            .expect("parses")
            .intrinsics(ImageSize::new(4, 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixel_pitch_um[0] = 0"), "{e}");
        let c = parse("fx_px = 1.0\nfy_px = 1.0\nimage_size_px = [10, 10]").expect("parses");
        let e = c
            .camera(Some(ImageSize::new(10, 20)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cam.toml")
                && e.contains("image_size_px = [10, 10] but the image is 10 x 20"),
            "{e}"
        );
        let e = parse("fx_px = 1.0\nfy_px = 1.0")
            .expect("parses")
            .camera(None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("cam.toml: missing key image_size_px"), "{e}");
    }

    #[test]
    fn a_smaller_image_of_the_same_aspect_gets_the_scaled_camera() {
        let text = "fx_px = 3000.0\nfy_px = 3010.0\ncx_px = 2010.0\ncy_px = 1490.0\n\
                    image_size_px = [4000, 3000]\n[distortion]\nmodel = \"opencv\"\nk1 = -0.2\n";
        let c = parse(text).expect("parses");
        let cam = c.camera(Some(ImageSize::new(1000, 750))).expect("resized");
        assert_eq!(cam.size, ImageSize::new(1000, 750));
        let k = cam.intrinsics;
        // A 4x downsample: the outer pixel edges stay the outer edges, so pixel centre u of the
        // large image is at (u + 0.5) / 4 - 0.5 in the small one; focal lengths scale by 1/4.
        assert_eq!((k.fx, k.fy), (3000.0 / 4.0, 3010.0 / 4.0));
        assert_eq!(
            (k.cx, k.cy),
            ((2010.0 + 0.5) / 4.0 - 0.5, (1490.0 + 0.5) / 4.0 - 0.5)
        );
        assert_eq!(cam.distortion, c.distortion);
        // The size the file states needs no resizing.
        let same = c
            .camera(Some(ImageSize::new(4000, 3000)))
            .expect("same size");
        assert_eq!((same.intrinsics.fx, same.intrinsics.cx), (3000.0, 2010.0));
        let e = c
            .camera(Some(ImageSize::new(1000, 1000)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cam.toml")
                && e.contains("[4000, 3000]")
                && e.contains("1000 x 1000")
                && e.contains("aspect"),
            "{e}"
        );
    }

    #[test]
    fn a_written_camera_reads_back_the_same() {
        let text = "fx_px = 812.25\nfy_px = 809.5\ncx_px = 321.125\ncy_px = 238.75\nskew_px = 0.5\n\
                    image_size_px = [640, 480]\n[distortion]\nmodel = \"brown\"\nk1 = -0.21\np2 = 0.003\n";
        let cam = parse(text).expect("parses").camera(None).expect("camera");
        assert_eq!(cam.intrinsics.skew, 0.5);
        let back = parse(&camera_toml(&cam).expect("written"))
            .expect("parses back")
            .camera(None)
            .expect("camera back");
        assert_eq!(back, cam);
        let pinhole = Camera::new(cam.intrinsics, None, cam.size);
        let text = camera_toml(&pinhole).expect("written");
        assert!(!text.contains("distortion"), "{text}");
        assert_eq!(
            parse(&text).expect("parses").camera(None).expect("camera"),
            pinhole
        );
    }
}
