//! Arguments and helpers that several subcommands share: rectify's arguments (its
//! georeferenced path is in `drone_cmds`), the georeferencing options of `rectify` and `batch`,
//! warp options checked against the image, and an image written together with its report.

use aerorect::core::rectify::DEFAULT_MAX_OUTPUT_PX;
use aerorect::io::StagedOutputs;
use aerorect::photo_source::SenseflyRoll;
use aerorect::raster::{AnyRaster, Coordinates, Interp, WarpOptions};
use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct RectifyArgs {
    /// The oblique frame (PNG, JPEG or TIFF).
    pub(crate) input: PathBuf,
    /// The rectified image (.tif or .png; keeps the input's bit depth).
    pub(crate) output: PathBuf,
    /// Camera file (TOML); default: from the photo's metadata.
    #[arg(long)]
    pub(crate) camera: Option<PathBuf>,
    /// Attitude: a TOML file, or azimuth=..,elevation=..,image_rotation=..,pitch=..,roll=..,yaw=..
    /// (degrees). Without it the photo's metadata is used (DJI gimbal angles, GPS, height) and the
    /// output is georeferenced: a GeoTIFF in the UTM zone, or a PNG with a world file.
    #[arg(long)]
    pub(crate) attitude: Option<String>,
    /// Resampling: nearest, bilinear, bicubic, or average (the area-weighted mean of the source
    /// pixels under each output pixel, GDAL's -r average, OpenCV's INTER_AREA).
    #[arg(long, default_value = "bilinear")]
    pub(crate) interp: Interp,
    /// Bilinear and bicubic: keep the plain kernel where the output is more than twice coarser
    /// than the source (by default such regions read a 2 x 2 box-reduced level, which stops aliasing).
    #[arg(long)]
    pub(crate) no_prefilter: bool,
    /// Evaluate every source position in f64 (by default a homography's positions are f32
    /// offsets from each 256-pixel block's first one, within 5e-4 px of exact).
    #[arg(long)]
    pub(crate) exact_coordinates: bool,
    /// Ground sample distance of the georeferenced output, metres (default: the frame's own at nadir).
    #[arg(long, conflicts_with = "attitude")]
    pub(crate) gsd_m: Option<f64>,
    /// Ground elevation (m above sea level) against the photo's AbsoluteAltitude; default: the
    /// height above the take-off point (RelativeAltitude).
    #[arg(long, conflicts_with = "attitude")]
    pub(crate) ground_height_m: Option<f64>,
    /// Flying height of this frame, for altitude normalisation (eq. 14); needs --base-altitude-m.
    #[arg(long)]
    pub(crate) altitude_m: Option<f64>,
    /// Base altitude all frames are scaled to.
    #[arg(long)]
    pub(crate) base_altitude_m: Option<f64>,
    /// Value of output pixels with no source.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) nodata: f64,
    /// Add an alpha band (opaque where the frame has data).
    #[arg(long)]
    pub(crate) alpha: bool,
    /// Largest output in pixels; a footprint reaching the horizon is clipped to it.
    #[arg(long, default_value_t = DEFAULT_MAX_OUTPUT_PX)]
    pub(crate) max_output_px: u64,
    /// Write a JSON report (homography, output grid, timing, inputs).
    #[arg(long)]
    pub(crate) report: Option<PathBuf>,
    /// Exterior orientation x,y,z,omega,phi,kappa (world CRS of --crs; degrees, PATB
    /// omega-phi-kappa about the CRS's axes) instead of the photo's metadata; needs --dem or
    /// --ground-height-m.
    #[arg(long, conflicts_with = "attitude", allow_hyphen_values = true)]
    pub(crate) pose: Option<String>,
    #[command(flatten)]
    pub(crate) geo: GeoArgs,
    /// Write a cloud-optimised GeoTIFF (tiled, Deflate, internal overviews; an --alpha band
    /// becomes its internal mask) instead of the strip GeoTIFF; georeferenced output only.
    #[arg(long, conflicts_with = "attitude")]
    pub(crate) cog: bool,
}

/// Writes the image and the JSON report when one is asked for, together: both land or neither
/// does (the report is serialised by the caller first).
pub(crate) fn write_image_and_report(
    output: &Path,
    image: &AnyRaster,
    report: Option<&Path>,
    json: &str,
) -> Result<()> {
    let mut staged = StagedOutputs::new();
    staged.image(output, image, None)?;
    if let Some(r) = report {
        staged.text(r, json)?;
    }
    staged.commit()?;
    Ok(())
}

/// The `Coordinates` that `--exact-coordinates` asks for.
pub(crate) fn coordinates(exact: bool) -> Coordinates {
    match exact {
        true => Coordinates::Exact,
        false => Coordinates::Fast,
    }
}

/// Warp options whose nodata value is checked against the image's sample type.
pub(crate) fn warp_options(
    interp: Interp,
    prefilter: bool,
    nodata: f64,
    alpha: bool,
    image: &AnyRaster,
) -> Result<WarpOptions> {
    let warp = WarpOptions {
        interp,
        nodata,
        alpha,
        prefilter,
        ..WarpOptions::default()
    };
    warp.nodata_as_for(image)
        .with_context(|| format!("--nodata {nodata}"))?;
    Ok(warp)
}

/// Georeferencing options shared by `rectify` (without --attitude) and `batch`.
#[derive(Args, Clone, Debug, Default)]
pub struct GeoArgs {
    /// DEM or DSM GeoTIFF (any CRS, float or integer, nodata honoured): each output pixel is
    /// projected at its terrain height; the camera's height is AbsoluteAltitude (or EXIF
    /// GPSAltitude, or the pose's z) + --vertical-offset-m, in the DEM's vertical datum.
    #[arg(long)]
    pub dem: Option<PathBuf>,
    /// Added to the camera's altitude to bring it to the DEM's vertical datum (e.g. minus the
    /// geoid undulation for ellipsoidal GNSS heights over an EGM96/EGM2008 DEM).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub vertical_offset_m: f64,
    /// DEM holes or a DEM that does not cover the frame are errors (default: a warning and the
    /// level fallback).
    #[arg(long)]
    pub strict: bool,
    /// With --dem: leave ground hidden behind nearer terrain empty (nodata) instead of filling
    /// it with the terrain in front.
    #[arg(long, requires = "dem")]
    pub occlusion: bool,
    /// Output CRS: EPSG:code, a PROJ string or WKT (default: the position's UTM zone; required
    /// with poses, or read from the pose table's .prj).
    #[arg(long, allow_hyphen_values = true)]
    pub crs: Option<String>,
    /// Boresight: fixed rotation of the camera in its mount, three angles about the camera's
    /// x, y, z axes in degrees (Rx Ry Rz), applied after the recorded attitude.
    #[arg(long, value_name = "RX,RY,RZ", allow_hyphen_values = true)]
    pub boresight_deg: Option<String>,
    /// Lever arm: the camera's projection centre from the GNSS antenna, metres, in the
    /// aircraft body frame (x forward, y right, z down; DJI Flight angles) or the pose's camera
    /// frame.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub lever_arm_m: Option<String>,
    /// External orientation of the photos, the format found from the content: ODM's geo.txt
    /// (a CRS line, then `name x y [z] [yaw pitch roll [horz_acc vert_acc]]`), Pix4D's
    /// geolocation CSV (image,latitude,longitude,altitude[,yaw,pitch,roll[,acc_h,acc_v]]),
    /// senseFly's geoinfo.txt, or the pose CSV of --poses. Listed photos take their position,
    /// height and angles from it; a photo it does not list is an error.
    #[arg(long = "geo", value_name = "FILE")]
    pub geo_file: Option<PathBuf>,
    /// How senseFly's roll is read: as recorded (Pix4D's convention; OpenSfM, Orthority),
    /// flipped (ODM), or auto: a flight's first round is adjusted under both and the reading
    /// its ties turn the frames less from is kept (the report's `sensefly_roll` says how it
    /// went); a photo on its own is read as recorded (CONVENTIONS.md, "senseFly roll").
    #[arg(long, value_enum, default_value_t = RollReading::Auto)]
    pub sensefly_roll: RollReading,
}

/// `--sensefly-roll`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RollReading {
    #[default]
    Auto,
    AsRecorded,
    Flipped,
}

impl From<RollReading> for SenseflyRoll {
    fn from(r: RollReading) -> Self {
        match r {
            RollReading::Auto => SenseflyRoll::Auto,
            RollReading::AsRecorded => SenseflyRoll::AsRecorded,
            RollReading::Flipped => SenseflyRoll::Flipped,
        }
    }
}
