//! Rectifying one photo from its metadata: read, plan, warp and stage the output, with the
//! wall seconds of each stage.

use super::{DroneOptions, DronePlanInfo, plan_from_metadata, plan_from_pose, pose_for};
use crate::Error;
use aerorect_io::GeoReference;
use serde::Serialize;

/// Stages a frame's output: a COG when `cog` is set, else as its extension says.
pub(crate) fn stage_output(
    staged: &mut aerorect_io::StagedOutputs,
    output: &std::path::Path,
    image: &aerorect_raster::AnyRaster,
    geo: &GeoReference,
    cog: Option<&aerorect_io::CogOptions>,
) -> Result<(), Error> {
    match cog {
        Some(c) => staged.cog(output, image, Some(geo), c)?,
        None => staged.image(output, image, Some(geo))?,
    }
    Ok(())
}

/// What rectifying one photo produced.
#[derive(Debug, Clone, Serialize)]
pub struct PhotoResult {
    pub input: String,
    pub output: String,
    pub info: DronePlanInfo,
    pub input_size: [usize; 2],
    pub output_size: [usize; 2],
    /// The ground the frame covers (easting, northing).
    pub footprint_en: Vec<[f64; 2]>,
    pub seconds: f64,
    /// Where `seconds` went.
    pub stage_seconds: StageSeconds,
    /// PNG thumbnails of the input and of the output, when asked for.
    #[serde(skip)]
    pub thumbnails: Option<(Vec<u8>, Vec<u8>)>,
}

/// Wall seconds of the stages of one frame's ortho (the report's `stage_seconds`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StageSeconds {
    /// Metadata and image decoding.
    pub read: f64,
    /// The grid, the map and the footprint.
    pub plan: f64,
    /// Resampling onto the grid.
    pub warp: f64,
    /// Encoding and writing the output (staged, before its rename).
    pub write: f64,
}

/// Seconds since `t`, and `t` reset to now.
pub(crate) fn lap(t: &mut std::time::Instant) -> f64 {
    let now = std::time::Instant::now();
    let s = (now - *t).as_secs_f64();
    *t = now;
    s
}

/// Reads a photo, rectifies it from its metadata onto its georeferenced grid, and writes
/// `output` (GeoTIFF, or PNG + world file) atomically.
pub fn rectify_photo(
    input: &std::path::Path,
    output: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
) -> Result<PhotoResult, Error> {
    let mut staged = aerorect_io::StagedOutputs::new();
    let r = rectify_photo_staged(input, output, opts, thumbnail_side, &mut staged)?;
    staged.commit()?;
    Ok(r)
}

/// [`rectify_photo`] with the output (and its sidecars) staged, to land with the caller's
/// other outputs when it commits them.
pub fn rectify_photo_staged(
    input: &std::path::Path,
    output: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
    staged: &mut aerorect_io::StagedOutputs,
) -> Result<PhotoResult, Error> {
    let t = std::time::Instant::now();
    let (out, mut r) = ortho_photo(input, opts, thumbnail_side)?;
    let mut w = std::time::Instant::now();
    stage_output(staged, output, &out, &r.info.geo, opts.cog.as_ref())?;
    r.stage_seconds.write = lap(&mut w);
    r.output = output.display().to_string();
    r.seconds = t.elapsed().as_secs_f64();
    Ok(r)
}

/// The ortho [`rectify_photo`] writes, in memory: the image (bands on the output grid) and
/// what was found (`info.geo` is its georeference; `output` is empty). Nothing is written.
pub fn ortho_photo(
    input: &std::path::Path,
    opts: &DroneOptions,
    thumbnail_side: Option<u32>,
) -> Result<(aerorect_raster::AnyRaster, PhotoResult), Error> {
    let t = std::time::Instant::now();
    let mut lap_t = t;
    let mut stages = StageSeconds::default();
    let file = input.display().to_string();
    let meta = aerorect_io::read_photo_metadata(input)?;
    let image = aerorect_io::read_image(input)?;
    opts.warp
        .nodata_as_for(&image)
        .map_err(|e| crate::options::OptionError::value("nodata", opts.warp.nodata, e))?;
    let size = image.size();
    stages.read = lap(&mut lap_t);
    let posed = opts.poses.as_deref().map(|p| pose_for(p, input));
    let (plan, info) = match posed {
        Some(Some(pose)) => plan_from_pose(pose, &meta, size, opts, &file)?,
        Some(None) => {
            return Err(Error::Invalid(format!("{file}: not in the pose table")));
        }
        None => plan_from_metadata(&meta, size, opts, &file)?,
    };
    stages.plan = lap(&mut lap_t);
    let out = plan.run(&image)?;
    stages.warp = lap(&mut lap_t);
    let thumbnails = match thumbnail_side {
        Some(s) => Some((
            aerorect_io::thumbnail_png(&image, s, &file)?,
            aerorect_io::thumbnail_png(&out, s, &format!("{file} (its ortho)"))?,
        )),
        None => None,
    };
    let r = PhotoResult {
        input: file,
        output: String::new(),
        input_size: [size.width, size.height],
        output_size: [plan.grid.size.width, plan.grid.size.height],
        footprint_en: plan.footprint.clone(),
        info,
        seconds: t.elapsed().as_secs_f64(),
        stage_seconds: stages,
        thumbnails,
    };
    Ok((out, r))
}
