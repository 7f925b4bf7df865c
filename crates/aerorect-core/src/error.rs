use thiserror::Error;

/// Errors of the pure geometry: each names the quantity and its value.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeometryError {
    /// A parameter is NaN, infinite, or outside its physical range.
    #[error("{field} = {} is invalid: {reason}", Num(*value))]
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
    /// An image size outside the sane range (each side 1 ..= `MAX_IMAGE_SIDE_PX`, at most
    /// `MAX_IMAGE_PX` in all).
    #[error("image size {width} x {height} px is invalid: {reason}")]
    InvalidImageSize {
        width: u64,
        height: u64,
        reason: String,
    },
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

/// Checks that `value` is finite with `min <= |value| <= max` (`min` 0 allows zero);
/// `reason` says the range.
pub fn require_magnitude(
    field: &'static str,
    value: f64,
    (min, max): (f64, f64),
    reason: &'static str,
) -> Result<f64, GeometryError> {
    let v = require_finite(field, value)?;
    if (min..=max).contains(&v.abs()) || (min == 0.0 && v == 0.0) {
        Ok(v)
    } else {
        Err(GeometryError::InvalidParameter {
            field,
            value,
            reason,
        })
    }
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

/// A number for messages: as Rust writes it when that is short, in scientific notation when it
/// is huge or tiny (1e300 is `1e300`, not 301 digits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if !self.0.is_finite() || a == 0.0 || (1e-4..1e9).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_are_compact() {
        let shown = |v: f64| Num(v).to_string();
        assert_eq!(shown(1e300), "1e300");
        assert_eq!(shown(-1.5e308), "-1.5e308");
        assert_eq!(shown(2.5e-7), "2.5e-7");
        assert_eq!(shown(123456.5), "123456.5");
        assert_eq!(shown(0.001), "0.001");
        assert_eq!(shown(0.0), "0");
        assert_eq!(shown(f64::NAN), "NaN");
        assert_eq!(shown(f64::NEG_INFINITY), "-inf");
        let e = require_positive("gsd_m", 1e300).map(|_| ()).err();
        assert_eq!(e, None);
        let e = require_finite("k1", f64::INFINITY).unwrap_err().to_string();
        assert_eq!(e, "k1 = inf is invalid: not a finite number");
        let e = require_positive("f", -1e300).unwrap_err().to_string();
        assert_eq!(e, "f = -1e300 is invalid: must be > 0");
    }
}
