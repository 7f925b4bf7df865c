use thiserror::Error;

/// Errors of the pure geometry: each names the quantity and its value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    /// A parameter is NaN, infinite, or outside its physical range.
    #[error("{field} = {value} is invalid: {reason}")]
    InvalidParameter {
        field: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// Every corner of the frame looks at or above the horizon.
    #[error("the frame sees no ground: every corner ray points at or above the horizon")]
    NoGround,
    /// The output would exceed the configured pixel limit even after clipping the far field.
    #[error(
        "output of {width} x {height} = {pixels} px exceeds the limit of {limit} px \
         even with the far field clipped to a quarter of the frame's ground area"
    )]
    OutputTooLarge {
        width: u64,
        height: u64,
        pixels: u64,
        limit: u64,
    },
    /// An image resized to another aspect ratio (cropped, not scaled).
    #[error(
        "the calibration is for a {}x{} image but the image is {}x{}: not the same aspect ratio (cropped?)",
        from[0], from[1], to[0], to[1]
    )]
    AspectMismatch { from: [usize; 2], to: [usize; 2] },
    /// A homography matrix is singular.
    #[error("the homography is singular")]
    Singular,
}

/// Checks that `value` is finite and strictly positive.
pub fn require_positive(field: &'static str, value: f64) -> Result<f64, GeometryError> {
    if !value.is_finite() {
        return Err(GeometryError::InvalidParameter {
            field,
            value,
            reason: "not a finite number",
        });
    }
    if value <= 0.0 {
        return Err(GeometryError::InvalidParameter {
            field,
            value,
            reason: "must be > 0",
        });
    }
    Ok(value)
}

/// Checks that `value` is finite.
pub fn require_finite(field: &'static str, value: f64) -> Result<f64, GeometryError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(GeometryError::InvalidParameter {
            field,
            value,
            reason: "not a finite number",
        })
    }
}
