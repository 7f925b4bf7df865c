use thiserror::Error;

/// Errors of buffers and pixel loops.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RasterError {
    #[error("{width} x {height} x {bands} bands of {sample} would need {bytes} bytes: too large")]
    TooLarge {
        width: usize,
        height: usize,
        bands: usize,
        sample: &'static str,
        bytes: u128,
    },
    #[error("buffer holds {got} samples, {want} expected for {width} x {height} x {bands}")]
    LengthMismatch {
        got: usize,
        want: usize,
        width: usize,
        height: usize,
        bands: usize,
    },
    #[error("destination has {got} bands, {want} expected")]
    BandMismatch { got: usize, want: usize },
    #[error("an image needs at least one band and one pixel")]
    Empty,
    #[error("nodata value {value} cannot be stored in {sample} samples")]
    InvalidNodata { value: f64, sample: &'static str },
}
