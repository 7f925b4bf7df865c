//! Georeferencing and orthos: a photo's metadata (or a pose table, an external-orientation
//! file) turned into a camera, a pose and the ground ([`drone`], [`photo_source`]); the one
//! planner every georeferenced ortho goes through ([`georef`]); `batch` over many photos
//! ([`batch`]) with its HTML report ([`report_html`]); the misalignment of two orthos
//! ([`overlap`]).

pub mod batch;
pub mod drone;
pub(crate) mod drone_options;
pub mod georef;
pub mod overlap;
pub mod photo_source;
pub mod report_html;
