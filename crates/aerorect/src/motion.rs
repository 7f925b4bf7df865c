//! Image-motion measurement: the paper's shift experiment (`motion-sim`), the streaming
//! tracker (`track`), and gray conversion of input frames.

use crate::Error;
use aerorect_core::ImageSize;
use aerorect_raster::shift::sim::{add_noise, crlb_rms, shifted_fourier, shifted_linear};
use aerorect_raster::shift::{
    JointTransformCorrelator, JtcOptions, PhaseCorrelator, PhaseOptions, ShiftEstimate,
    ShiftEstimator, SubPixel,
};
use aerorect_raster::{AnyRaster, Raster, ReducedLevels};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::time::Instant;

/// A named estimator configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Method {
    Jtc(JtcOptions),
    Phase(PhaseOptions),
}

impl Method {
    /// The names the CLI accepts.
    pub const NAMES: [&'static str; 7] = [
        "jtc",
        "jtc-centroid",
        "jtc-parabola",
        "jtc-linear",
        "jtc-plain",
        "phase",
        "xcorr",
    ];

    /// `jtc` (the paper's: Laplacian, [-1 2 -1] filter, binarised; Gaussian peak fit),
    /// `jtc-centroid` and `jtc-parabola` (the same with the paper's 3 x 3 centroid or a parabola),
    /// `jtc-linear` (Laplacian and filter, not binarised: the JTC's cross-spectrum form, about
    /// a third of the paper form's time), `jtc-plain` (none of the three refinements, Gaussian
    /// fit), `phase` (phase
    /// correlation, Hann window, Newton peak), `xcorr` (cross-correlation, Hann window, Newton peak).
    pub fn parse(name: &str) -> Result<Self, Error> {
        Ok(match name {
            "jtc" => Method::Jtc(JtcOptions::default()),
            "jtc-centroid" => Method::Jtc(JtcOptions {
                subpixel: SubPixel::Centroid,
                ..JtcOptions::default()
            }),
            "jtc-linear" => Method::Jtc(JtcOptions {
                binarize: false,
                ..JtcOptions::default()
            }),
            "jtc-plain" => Method::Jtc(JtcOptions {
                laplacian: false,
                spectral_filter: false,
                binarize: false,
                ..JtcOptions::default()
            }),
            "jtc-parabola" => Method::Jtc(JtcOptions {
                subpixel: SubPixel::Parabola,
                ..JtcOptions::default()
            }),
            "phase" => Method::Phase(PhaseOptions::phase()),
            "xcorr" => Method::Phase(PhaseOptions::xcorr()),
            other => {
                return Err(Error::Invalid(format!(
                    "unknown method '{other}': expected one of {}",
                    Self::NAMES.join(", ")
                )));
            }
        })
    }

    /// An estimator planned for `size`.
    pub fn plan(&self, size: ImageSize) -> Result<Box<dyn ShiftEstimator + Send>, Error> {
        let err = Error::Shift;
        Ok(match *self {
            Method::Jtc(o) => {
                Box::new(JointTransformCorrelator::new(size.width, size.height, o).map_err(err)?)
            }
            Method::Phase(o) => {
                Box::new(PhaseCorrelator::new(size.width, size.height, o).map_err(err)?)
            }
        })
    }
}

/// The gray frame of an image: the single band, or Rec. 601 luma of RGB(A); as f32.
pub fn gray(img: &AnyRaster) -> Result<Raster<f32>, Error> {
    let size = img.size();
    let mut plane = vec![0f32; size.pixels()];
    // One pass over the three planes, no f32 copy of each (a 4608 x 3456 photo made four
    // 64-MB planes; 123 ms of each matching round's render per photo).
    Gray::of(img)?.rows(0..size.height, &mut plane);
    Ok(Raster::from_planes(size, vec![plane])?)
}

/// The reduced levels of [`gray`]'s frame (as a prefiltered warp reads them), made two rows
/// at a time: the gray frame itself is never whole.
pub fn gray_levels(img: &AnyRaster) -> Result<ReducedLevels<f32>, Error> {
    let gray = Gray::of(img)?;
    Ok(ReducedLevels::from_rows(img.size(), |r, out| {
        gray.rows(r..r + 1, out);
    })?)
}

/// An image whose gray frame can be made: one or two bands, or three or four.
struct Gray<'a> {
    img: &'a AnyRaster,
    luma: bool,
}

impl<'a> Gray<'a> {
    fn of(img: &'a AnyRaster) -> Result<Self, Error> {
        match img.bands() {
            1 | 2 => Ok(Self { img, luma: false }),
            3 | 4 => Ok(Self { img, luma: true }),
            n => Err(Error::Invalid(format!(
                "cannot make a gray frame of {n} bands"
            ))),
        }
    }

    /// Rows `rows` of the gray frame into `out` (their samples, row after row).
    fn rows(&self, rows: std::ops::Range<usize>, out: &mut [f32]) {
        let w = self.img.size().width;
        let span = rows.start * w..rows.end * w;
        match (self.luma, self.img) {
            (false, AnyRaster::U8(r)) => to_f32(&r.plane(0)[span], out),
            (false, AnyRaster::U16(r)) => to_f32(&r.plane(0)[span], out),
            (false, AnyRaster::F32(r)) => out.copy_from_slice(&r.plane(0)[span]),
            (true, AnyRaster::U8(r)) => luma(r, span, out),
            (true, AnyRaster::U16(r)) => luma(r, span, out),
            (true, AnyRaster::F32(r)) => luma(r, span, out),
        }
    }
}

fn to_f32<T: aerorect_raster::Sample>(src: &[T], out: &mut [f32]) {
    for (o, v) in out.iter_mut().zip(src) {
        *o = v.to_f32();
    }
}

/// Rec. 601 luma of the first three bands over `span` (sample indices), each sample as f32.
fn luma<T: aerorect_raster::Sample>(
    img: &Raster<T>,
    span: std::ops::Range<usize>,
    out: &mut [f32],
) {
    let (r, g, b) = (
        &img.plane(0)[span.clone()],
        &img.plane(1)[span.clone()],
        &img.plane(2)[span],
    );
    for (o, ((r, g), b)) in out.iter_mut().zip(r.iter().zip(g).zip(b)) {
        *o = 0.299 * r.to_f32() + 0.587 * g.to_f32() + 0.114 * b.to_f32();
    }
}

/// How the displaced copy is made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Displacement {
    Linear,
    Fourier,
}

/// The experiment's set-up.
#[derive(Debug, Clone)]
pub struct MotionSimConfig {
    pub size: usize,
    pub snr_db: Vec<f64>,
    pub trials: usize,
    /// Shifts are uniform in [-max_shift, max_shift] on both axes.
    pub max_shift: f64,
    pub displacement: Displacement,
    pub methods: Vec<(String, Method)>,
    pub seed: u64,
    /// Write every noisy pair (f32 TIFF) and a manifest with the truth and each method's
    /// estimate and time here, for side-by-side runs of other tools on the very same frames.
    pub dump_dir: Option<std::path::PathBuf>,
}

impl MotionSimConfig {
    /// Refuses no trials, and frames no scene holds with their shift margin (before any
    /// estimator is planned: a frame size the scenes cannot hold would be planned in vain,
    /// and a huge one would exhaust memory).
    fn check(&self, scenes: &[(String, Raster<f32>)]) -> Result<(), Error> {
        if self.trials == 0 {
            let why = Error::Invalid("at least one trial per cell".into());
            return Err(crate::options::OptionError::value("trials", 0, why).into());
        }
        // Linear shifts read max_shift + 1 px around the window; Fourier shifts a 2n window.
        let need = match self.displacement {
            Displacement::Linear => (self.max_shift.ceil() as usize + 2)
                .saturating_mul(2)
                .saturating_add(self.size),
            Displacement::Fourier => self.size.saturating_mul(2),
        };
        for (name, scene) in scenes {
            if scene.width() < need || scene.height() < need {
                return Err(Error::advice(format!(
                    "{name}: {} x {} is too small for {} x {} frames with their shift margin (needs {need} x {need}); give a smaller `size`",
                    scene.width(),
                    scene.height(),
                    self.size,
                    self.size
                )));
            }
        }
        Ok(())
    }
}

/// One cell of the table.
#[derive(Debug, Clone, Serialize)]
pub struct MotionSimRow {
    pub scene: String,
    pub snr_db: f64,
    pub method: String,
    /// sqrt(mean((dx_hat - dx)^2 + (dy_hat - dy)^2)), pixels.
    pub error_rms_px: f64,
    pub bias_dx_px: f64,
    pub bias_dy_px: f64,
    /// The Cramer-Rao lower bound on that RMS error at this SNR.
    pub crlb_rms_px: f64,
    pub mean_confidence: f64,
    pub median_seconds: f64,
    pub trials: usize,
}

/// Runs every scene x SNR x method; the frames and noise are the same for every method.
pub fn motion_sim(
    scenes: &[(String, Raster<f32>)],
    cfg: &MotionSimConfig,
) -> Result<Vec<MotionSimRow>, Error> {
    cfg.check(scenes)?;
    let size = ImageSize::new(cfg.size, cfg.size);
    let mut estimators = cfg
        .methods
        .iter()
        .map(|(_, m)| m.plan(size))
        .collect::<Result<Vec<_>, _>>()?;
    let mut rows = vec![];
    for (name, scene) in scenes {
        let (x0, y0) = (
            (scene.width() - cfg.size) / 2,
            (scene.height() - cfg.size) / 2,
        );
        let clean_ref = shifted_linear(scene, x0 as f64, y0 as f64, size, 0.0, 0.0);
        for &snr in &cfg.snr_db {
            let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed ^ (snr * 1000.0) as u64);
            let mut acc: Vec<Acc> = vec![Acc::default(); cfg.methods.len()];
            let mut noise_var = 0.0;
            for _ in 0..cfg.trials {
                let (dx, dy) = (
                    rng.random_range(-cfg.max_shift..=cfg.max_shift),
                    rng.random_range(-cfg.max_shift..=cfg.max_shift),
                );
                let mut cur = match cfg.displacement {
                    Displacement::Linear => {
                        shifted_linear(scene, x0 as f64, y0 as f64, size, dx, dy)
                    }
                    Displacement::Fourier => shifted_fourier(scene, x0, y0, size, dx, dy),
                };
                let mut r = clean_ref.clone();
                noise_var = add_noise(&mut r, snr, &mut rng);
                add_noise(&mut cur, snr, &mut rng);
                let mut line = format!("{name},{snr},{},{dx},{dy}", acc[0].n);
                for (est, a) in estimators.iter_mut().zip(acc.iter_mut()) {
                    let t = Instant::now();
                    let e = est.estimate(&r, &cur).map_err(Error::context(&name))?;
                    let secs = t.elapsed().as_secs_f64();
                    a.add(&e, dx, dy, secs);
                    line += &format!(",{},{},{secs}", e.dx, e.dy);
                }
                if let Some(dir) = &cfg.dump_dir {
                    dump_pair(dir, &line, size, &r, &cur)?;
                }
            }
            let crlb = crlb_rms(&clean_ref, size, noise_var);
            for ((method, _), a) in cfg.methods.iter().zip(acc.iter_mut()) {
                rows.push(a.row(name, snr, method, crlb));
            }
        }
    }
    Ok(rows)
}

/// Writes `<scene>_<snr>_<trial>_{ref,cur}.tif` and appends `line` to `manifest.csv`.
fn dump_pair(
    dir: &std::path::Path,
    line: &str,
    size: ImageSize,
    r: &[f32],
    cur: &[f32],
) -> Result<(), Error> {
    use std::io::Write;
    let key: Vec<&str> = line.splitn(4, ',').take(3).collect();
    let stem = key.join("_");
    for (suffix, data) in [("ref", r), ("cur", cur)] {
        let img = AnyRaster::F32(Raster::from_planes(size, vec![data.to_vec()])?);
        aerorect_io::write_image(&dir.join(format!("{stem}_{suffix}.tif")), &img)?;
    }
    let path = dir.join("manifest.csv");
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(&path)
        .map_err(Error::file(&path))?;
    writeln!(f, "{line}").map_err(Error::file(path))
}

/// One line of `track`.
#[derive(Debug, Clone, Serialize)]
pub struct TrackStep {
    pub estimate: ShiftEstimate,
    pub seconds: f64,
}

/// The streaming mode: each frame against the previous one (the paper's ping-pong pair).
pub struct Tracker {
    estimator: Box<dyn ShiftEstimator + Send>,
    size: ImageSize,
    previous: Option<Vec<f32>>,
}

impl Tracker {
    pub fn new(method: Method, size: ImageSize) -> Result<Self, Error> {
        Ok(Self {
            estimator: method.plan(size)?,
            size,
            previous: None,
        })
    }

    /// Feeds the next frame; `None` for the first one (nothing to compare with yet).
    pub fn push(&mut self, frame: Vec<f32>) -> Result<Option<TrackStep>, Error> {
        if frame.len() != self.size.pixels() {
            return Err(Error::Invalid(format!(
                "a frame of {} samples in a track of {} x {} frames",
                frame.len(),
                self.size.width,
                self.size.height
            )));
        }
        let step = match &self.previous {
            None => None,
            Some(prev) => {
                let t = Instant::now();
                let estimate = self.estimator.estimate(prev, &frame).map_err(Error::from)?;
                Some(TrackStep {
                    estimate,
                    seconds: t.elapsed().as_secs_f64(),
                })
            }
        };
        self.previous = Some(frame);
        Ok(step)
    }
}

#[derive(Debug, Clone, Default)]
struct Acc {
    n: usize,
    se: f64,
    ex: f64,
    ey: f64,
    conf: f64,
    times: Vec<f64>,
}

impl Acc {
    fn add(&mut self, e: &ShiftEstimate, dx: f64, dy: f64, secs: f64) {
        let (ex, ey) = (e.dx - dx, e.dy - dy);
        self.n += 1;
        self.se += ex * ex + ey * ey;
        self.ex += ex;
        self.ey += ey;
        self.conf += e.confidence;
        self.times.push(secs);
    }

    fn row(&mut self, scene: &str, snr_db: f64, method: &str, crlb: f64) -> MotionSimRow {
        let n = self.n.max(1) as f64;
        self.times.sort_by(f64::total_cmp);
        MotionSimRow {
            scene: scene.to_string(),
            snr_db,
            method: method.to_string(),
            error_rms_px: (self.se / n).sqrt(),
            bias_dx_px: self.ex / n,
            bias_dy_px: self.ey / n,
            crlb_rms_px: crlb,
            mean_confidence: self.conf / n,
            median_seconds: self.times.get(self.times.len() / 2).copied().unwrap_or(0.0),
            trials: self.n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gray is the band itself, or Rec. 601 luma of the samples as f32, for every sample type.
    #[test]
    fn gray_is_the_rec601_luma_of_the_samples() {
        let size = aerorect_core::ImageSize::new(5, 3);
        let band =
            |k: usize| -> Vec<f64> { (0..15).map(|i| ((i * 37 + k * 91) % 251) as f64).collect() };
        let want: Vec<f32> = (0..15)
            .map(|i| {
                let v = |k: usize| band(k)[i] as f32;
                0.299 * v(0) + 0.587 * v(1) + 0.114 * v(2)
            })
            .collect();
        let u8s: Vec<Vec<u8>> = (0..4)
            .map(|k| band(k).iter().map(|&v| v as u8).collect())
            .collect();
        let u16s: Vec<Vec<u16>> = (0..3)
            .map(|k| band(k).iter().map(|&v| v as u16 * 3).collect())
            .collect();
        let f32s: Vec<Vec<f32>> = (0..3)
            .map(|k| band(k).iter().map(|&v| v as f32).collect())
            .collect();
        let rgba = AnyRaster::U8(Raster::from_planes(size, u8s.clone()).unwrap());
        assert_eq!(gray(&rgba).unwrap().plane(0), &want[..]);
        let rgb = AnyRaster::F32(Raster::from_planes(size, f32s).unwrap());
        assert_eq!(gray(&rgb).unwrap().plane(0), &want[..]);
        let want16: Vec<f32> = (0..15)
            .map(|i| {
                0.299 * (u16s[0][i] as f32)
                    + 0.587 * (u16s[1][i] as f32)
                    + 0.114 * (u16s[2][i] as f32)
            })
            .collect();
        let rgb16 = AnyRaster::U16(Raster::from_planes(size, u16s).unwrap());
        assert_eq!(gray(&rgb16).unwrap().plane(0), &want16[..]);
        let one = AnyRaster::U8(Raster::from_planes(size, vec![u8s[1].clone()]).unwrap());
        let ones: Vec<f32> = u8s[1].iter().map(|&v| v as f32).collect();
        assert_eq!(gray(&one).unwrap().plane(0), &ones[..]);
    }

    /// A track of noisy shifted frames: every step of one Tracker (which hands each frame back
    /// as the next reference, so its spectrum is reused) equals a fresh estimator on that pair.
    #[test]
    fn a_tracker_step_equals_a_fresh_estimate_of_the_pair() {
        let size = ImageSize::new(64, 64);
        let scene = aerorect_testkit::textured_scene::<f32>(ImageSize::new(200, 200), 1, 1.0, 3);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let frames: Vec<Vec<f32>> = [(0.0, 0.0), (1.2, -0.4), (2.3, -1.1), (2.9, 0.5)]
            .iter()
            .map(|&(dx, dy)| {
                let mut f = shifted_linear(&scene, 60.0, 60.0, size, dx, dy);
                add_noise(&mut f, 10.0, &mut rng);
                f
            })
            .collect();
        for name in ["jtc", "jtc-linear", "xcorr", "phase"] {
            let method = Method::parse(name).unwrap();
            let mut tracker = Tracker::new(method, size).unwrap();
            assert!(tracker.push(frames[0].clone()).unwrap().is_none());
            for pair in frames.windows(2) {
                let step = tracker.push(pair[1].clone()).unwrap().unwrap();
                let fresh = method
                    .plan(size)
                    .unwrap()
                    .estimate(&pair[0], &pair[1])
                    .unwrap();
                assert_eq!(step.estimate, fresh, "{name}");
            }
        }
    }
}
