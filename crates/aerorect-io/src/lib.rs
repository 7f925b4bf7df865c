//! File adapters: images (PNG, JPEG, TIFF), camera and attitude files, check-point tables, GCP files.
//!
//! Every error names the file (or the command-line argument), the field and the value.
//! Outputs are written to a temporary file beside the target and renamed into place, so a
//! failed write leaves nothing half-written.

pub mod attitude;
pub mod bounded;
pub mod camera;
pub mod camera_formats;
pub mod checkpoints;
pub mod cog;
pub mod dem;
pub mod duplicates;
pub mod eo;
pub mod error;
pub mod gcp_file;
mod geokeys;
pub mod geotiff;
pub mod image_file;
mod image_limits;
pub mod metadata;
pub mod sensors;
pub mod staged;
mod strip_tiff;
pub mod table_error;
mod temp_names;
mod tiff_file;
pub mod tiled_tiff;
pub mod whole;

pub use attitude::read_attitude;
pub use bounded::{MAX_TEXT_BYTES, read_text};
pub use camera::{CameraFile, camera_toml};
pub use camera_formats::{CameraFormat, camera_from_text, read_camera_file, text_from_camera};
pub use checkpoints::{
    ControlPoint, Gcp, PoseRecord, read_checkpoints, read_control_points, read_gcps, read_poses,
    write_checkpoints, write_csv,
};
pub use cog::{CogCompression, CogMask, CogOptions, write_cog, write_image_cog};
pub use dem::read_dem;
pub use duplicates::{first_duplicate, refuse_duplicate_photos};
pub use eo::{EoFormat, EoRecord, EoTable, read_eo_file};
pub use error::IoError;
pub use gcp_file::{
    GcpFile, GcpFormat, ImageMark, SurveyPoint, gcp_from_text, read_gcp_file, read_gcp_files,
};
pub use geokeys::GeoKeyError;
pub use geotiff::{GeoReference, read_georeference, write_world_file};
pub use image_file::{
    DEFAULT_MAX_IMAGE_PIXELS, decode_image_bytes, image_files, max_image_pixels, read_image,
    read_image_size, resolved_path, same_file, set_max_image_pixels, thumbnail_png,
    write_atomically, write_image, write_image_geo,
};
pub use metadata::{BodyAngles, BodySchema, PhotoMetadata, read_photo_metadata};
pub use sensors::{SensorMatch, sensor_count, sensor_key, sensor_width_mm};
pub use staged::{Abandoned, StagedOutputs, remove_pending};
pub use table_error::TableError;
pub use tiled_tiff::{tiles_per_batch, write_tiled_tiff, write_tiled_tiff_parallel};
pub use whole::check_image_whole;
