//! Feature tie points between photos: each frame decoded, reduced to about
//! [`TieOptions::long_side_px`] on its long side and described by SIFT; candidate pairs from
//! the frames' positions (or all pairs); descriptors matched (ratio test, mutual check) and
//! verified by RANSAC. Tie points come back in each frame's full-resolution pixel coordinates,
//! with an inlier flag per match, ready to become the first round's tie points of a flight
//! adjustment (no attitude needed).

use crate::Error;
use aerorect_core::ImageSize;
use aerorect_raster::AnyRaster;
use aerorect_raster::features::{
    DESCRIPTOR_LEN, FeatureOptions, Features, full_from_reduced, gray_reduced, sift,
};
use aerorect_solve::fundamental::ransac_fundamental;
use aerorect_solve::matching::{
    Match, MatchOptions, Window, bytes_of_whole, match_bytes_within, match_float,
    match_float_within,
};
use aerorect_solve::pairs::{PairOptions, candidate_pairs};
use aerorect_solve::ransac::{RansacOptions, ransac_homography};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Which model the matches must agree with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verification {
    /// A homography: flat ground, or a camera turning about its centre.
    Homography,
    /// A fundamental matrix (Sampson distance): any scene, relief included.
    Fundamental,
}

/// Settings of [`tie_photos`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TieOptions {
    /// Frames are reduced by the smallest integer factor that brings their long side to at
    /// most this (4608 x 3456 photos: factor 4 at 1152).
    pub long_side_px: usize,
    pub features: FeatureOptions,
    pub matching: MatchOptions,
    /// RANSAC; the threshold is in pixels of the reduced frames.
    pub ransac: RansacOptions,
    pub verification: Verification,
    /// Candidate pairs when frame positions are given.
    pub pairs: PairOptions,
    /// A pair with fewer matches than this is not verified (none of its matches is an
    /// inlier): RANSAC on the dozen chance matches of two frames that share nothing ran all
    /// its iterations, most of the verification's time in a flight. 0 verifies every pair.
    pub min_matches: usize,
}

impl Default for TieOptions {
    fn default() -> Self {
        Self {
            long_side_px: 1152,
            features: FeatureOptions::default(),
            matching: MatchOptions::default(),
            ransac: RansacOptions {
                threshold: 1.0,
                max_iterations: 4000,
                ..RansacOptions::default()
            },
            verification: Verification::Fundamental,
            pairs: PairOptions::default(),
            min_matches: 0,
        }
    }
}

/// One frame's features, positions in the reduced frame.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct FrameFeatures {
    pub path: PathBuf,
    /// The decoded (full-resolution) size.
    pub size: ImageSize,
    /// The reduction factor: reduced position x is full `factor (x + 0.5) - 0.5`.
    pub factor: usize,
    pub features: Features,
    /// Seconds to reduce and describe the frame (decoding not counted).
    pub seconds: f64,
    /// In a flight, each keypoint on the ground by the frame's recorded orientation (none
    /// where its ray misses), to guide matching; empty otherwise.
    #[serde(default)]
    pub ground: Vec<Option<[f64; 3]>>,
    /// The descriptors as bytes, where every value is a whole number in 0..=255 (SIFT's are),
    /// made on first use by guided matching ([`FrameFeatures::descriptor_bytes`]): once per
    /// frame, not once per pair. Not serialised: features read back make them again.
    #[serde(skip)]
    pub(crate) bytes: std::sync::OnceLock<Option<Vec<u8>>>,
}

impl FrameFeatures {
    /// [`FrameFeatures::bytes`], made on the first call. The descriptors are not to change
    /// after it (nothing changes them once described).
    pub fn descriptor_bytes(&self) -> Option<&[u8]> {
        let bytes = || bytes_of_whole(&self.features.descriptors);
        self.bytes.get_or_init(bytes).as_deref()
    }
}

/// The matches of one pair, in full-resolution pixels of each frame, with RANSAC's verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct PairTies {
    pub first: usize,
    pub second: usize,
    pub first_px: Vec<[f64; 2]>,
    pub second_px: Vec<[f64; 2]>,
    pub inliers: Vec<bool>,
}

impl PairTies {
    pub fn inlier_count(&self) -> usize {
        self.inliers.iter().filter(|&&b| b).count()
    }
}

/// Every frame's features and the verified ties of every candidate pair.
#[derive(Debug, Clone)]
pub struct Ties {
    pub frames: Vec<FrameFeatures>,
    pub pairs: Vec<PairTies>,
}

/// The reduction factor for a frame of `size` (at least 1).
pub fn reduction_factor(size: ImageSize, long_side_px: usize) -> usize {
    size.width
        .max(size.height)
        .div_ceil(long_side_px.max(1))
        .max(1)
}

/// Features of a decoded frame.
pub fn raster_features(
    path: &Path,
    image: &AnyRaster,
    opts: &TieOptions,
) -> Result<FrameFeatures, Error> {
    let start = Instant::now();
    let factor = reduction_factor(image.size(), opts.long_side_px);
    let mut gray = gray_reduced(image, factor)?;
    let describe = |g: &_| sift(g, &opts.features).map_err(Error::context(path.display()));
    if contrast_gain(gray.plane(0)) >= DULL_GAIN {
        // A dull frame: stretched before its one description (described as it was, it gave
        // a tenth of the keypoints and was described again stretched: twice the time).
        stretch_contrast(gray.plane_mut(0));
        let features = describe(&gray)?;
        return Ok(frame_features_of(path, image, factor, features, start));
    }
    let mut features = describe(&gray)?;
    if features.len() < FEW_KEYPOINTS {
        // Few keypoints: described again with its contrast stretched.
        stretch_contrast(gray.plane_mut(0));
        let stretched = describe(&gray)?;
        if stretched.len() > features.len() {
            features = stretched;
        }
    }
    Ok(frame_features_of(path, image, factor, features, start))
}

fn frame_features_of(
    path: &Path,
    image: &AnyRaster,
    factor: usize,
    features: Features,
    start: Instant,
) -> FrameFeatures {
    FrameFeatures {
        path: path.to_path_buf(),
        size: image.size(),
        factor,
        features,
        seconds: start.elapsed().as_secs_f64(),
        ground: Vec::new(),
        bytes: Default::default(),
    }
}

/// A frame with fewer SIFT keypoints than this is described again with its contrast
/// stretched ([`stretch_contrast`]); frames with more (the snowpeak photos at 1152 px) are
/// described as they are.
pub const FEW_KEYPOINTS: usize = 500;

/// The most a frame's contrast is stretched by [`stretch_contrast`].
pub const MAX_CONTRAST_GAIN: f32 = 8.0;

/// Stretches a gray frame (0..255) so that its 1st to 99th percentile spans the whole range
/// (gain at least 1, at most [`MAX_CONTRAST_GAIN`]; the median stays): SIFT's contrast
/// threshold is absolute, so a dull frame (haze, snow, a uniform field) gave a tenth of the
/// keypoints of the same ground at full contrast: the simulated flight's frames, spanning
/// 80 of 255 levels, gave 30-90 keypoints each and the pairs of its dullest strips too few
/// matches to tie. A frame that already spans the range is left as it is.
pub fn stretch_contrast(gray: &mut [f32]) {
    let Some((mid, gain)) = contrast_stretch(gray) else {
        return;
    };
    if gain > 1.0 {
        gray.iter_mut().for_each(|v| *v = mid + gain * (*v - mid));
    }
}

/// A frame whose contrast [`stretch_contrast`] would raise this many times or more (its 1st
/// to 99th percentile spans at most half of 0..255) is stretched before it is described:
/// SIFT found a tenth of the keypoints on such frames (the simulated flight's, spanning 80
/// levels), fewer than [`FEW_KEYPOINTS`], so describing it as it is first was wasted time.
pub const DULL_GAIN: f32 = 2.0;

/// The gain [`stretch_contrast`] would apply to `gray` (1 when it leaves it as it is).
pub fn contrast_gain(gray: &[f32]) -> f32 {
    contrast_stretch(gray).map_or(1.0, |(_, gain)| gain)
}

/// The median and the gain (1 to [`MAX_CONTRAST_GAIN`]) that bring the 1st to 99th
/// percentile of a sample of `gray` to span 0..255; none for fewer than 100 finite values.
fn contrast_stretch(gray: &[f32]) -> Option<(f32, f32)> {
    let step = (gray.len() / 65_536).max(1);
    let mut sample: Vec<f32> = gray
        .iter()
        .step_by(step)
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    if sample.len() < 100 {
        return None;
    }
    let n = sample.len();
    let mut at = |q: usize| *sample.select_nth_unstable_by(q, f32::total_cmp).1;
    let (lo, mid, hi) = (at(n / 100), at(n / 2), at(n - 1 - n / 100));
    Some((
        mid,
        (255.0 / (hi - lo).max(1e-3)).clamp(1.0, MAX_CONTRAST_GAIN),
    ))
}

/// Decodes the photo at `path` and describes it.
pub fn frame_features(path: &Path, opts: &TieOptions) -> Result<FrameFeatures, Error> {
    let image = crate::flight::timing::time("features: decode", || aerorect_io::read_image(path))?;
    crate::flight::timing::time("features: sift", || raster_features(path, &image, opts))
}

/// Matches two frames and verifies the matches. Fewer matches than the model needs is no
/// error: the pair simply has no inliers.
pub fn match_frames(
    a: &FrameFeatures,
    b: &FrameFeatures,
    pair: (usize, usize),
    opts: &TieOptions,
) -> Result<PairTies, Error> {
    match_frames_within(a, b, pair, opts, None)
}

/// Where each of `a`'s keypoints is predicted in `b` (reduced pixels of `b`), how far from
/// there `b`'s keypoints are compared with it (`radius`: the ratio test's candidates), and
/// how far from there its match may lie (`accept`, at most `radius`).
#[derive(Debug, Clone, Copy)]
pub struct Prediction<'a> {
    pub query_at: &'a [Option<[f64; 2]>],
    pub radius: f64,
    pub accept: f64,
}

/// [`match_frames`], each of `a`'s keypoints compared only with `b`'s around where it is
/// predicted in `b` when `window` is given.
pub fn match_frames_within(
    a: &FrameFeatures,
    b: &FrameFeatures,
    (first, second): (usize, usize),
    opts: &TieOptions,
    window: Option<Prediction<'_>>,
) -> Result<PairTies, Error> {
    let t = Instant::now();
    let (qa, tb) = (&a.features.descriptors, &b.features.descriptors);
    let m = match window {
        None => match_float(qa, tb, DESCRIPTOR_LEN, &opts.matching),
        Some(p) => {
            let train_at = b.features.positions();
            let w = Window {
                query_at: p.query_at,
                train_at: &train_at,
                radius: p.radius,
            };
            // As bytes where both frames' descriptors are (the same matches at the same
            // distances, a quarter of the memory per row).
            let found = match (a.descriptor_bytes(), b.descriptor_bytes()) {
                (Some(qa), Some(tb)) => {
                    match_bytes_within(qa, tb, DESCRIPTOR_LEN, &w, &opts.matching)
                }
                _ => match_float_within(qa, tb, DESCRIPTOR_LEN, &w, &opts.matching),
            };
            found.map(|m| {
                let near = |m: &Match| {
                    p.query_at[m.query].is_some_and(|q| {
                        let t = train_at[m.train];
                        (t[0] - q[0]).hypot(t[1] - q[1]) <= p.accept
                    })
                };
                m.into_iter().filter(near).collect()
            })
        }
    }
    .map_err(Error::context(format!(
        "matching {} with {}",
        a.path.display(),
        b.path.display()
    )))?;
    let stage = match window {
        None => "features: descriptor matching",
        Some(_) => "features: guided matching",
    };
    crate::flight::timing::add(stage, t.elapsed().as_secs_f64());
    let t = Instant::now();
    let pa: Vec<[f64; 2]> = m.iter().map(|m| position(a, m.query)).collect();
    let pb: Vec<[f64; 2]> = m.iter().map(|m| position(b, m.train)).collect();
    let verdict = match opts.verification {
        _ if pa.len() < opts.min_matches => Ok(vec![false; pa.len()]),
        Verification::Homography => ransac_homography(&pa, &pb, &opts.ransac).map(|f| f.inliers),
        Verification::Fundamental => ransac_fundamental(&pa, &pb, &opts.ransac).map(|f| f.inliers),
    };
    let inliers = verdict.unwrap_or_else(|_| vec![false; pa.len()]);
    crate::flight::timing::add("features: F-RANSAC", t.elapsed().as_secs_f64());
    Ok(PairTies {
        first,
        second,
        first_px: pa.iter().map(|&p| full_from_reduced(a.factor, p)).collect(),
        second_px: pb.iter().map(|&p| full_from_reduced(b.factor, p)).collect(),
        inliers,
    })
}

fn position(f: &FrameFeatures, k: usize) -> [f64; 2] {
    let kp = &f.features.keypoints[k];
    [kp.x, kp.y]
}

/// Features of every photo (in parallel), then the verified ties of each candidate pair: from
/// `centres` (one ground position per photo, any planar unit) when given, else every pair.
pub fn tie_photos(
    paths: &[PathBuf],
    centres: Option<&[[f64; 2]]>,
    opts: &TieOptions,
) -> Result<Ties, Error> {
    opts.features.validate().map_err(Error::from)?;
    let frames: Vec<FrameFeatures> = paths
        .par_iter()
        .map(|p| frame_features(p, opts))
        .collect::<Result<_, _>>()?;
    let pairs = match centres {
        Some(c) if c.len() != paths.len() => {
            return Err(Error::Invalid(format!(
                "{} frame positions given for {} photos",
                c.len(),
                paths.len()
            )));
        }
        Some(c) => {
            candidate_pairs(c, None, &opts.pairs).map_err(Error::context("candidate pairs"))?
        }
        None => (0..paths.len())
            .flat_map(|i| (i + 1..paths.len()).map(move |j| (i, j)))
            .collect(),
    };
    let ties = pairs
        .par_iter()
        .map(|&(i, j)| match_frames(&frames[i], &frames[j], (i, j), opts))
        .collect::<Result<_, _>>()?;
    Ok(Ties {
        frames,
        pairs: ties,
    })
}
