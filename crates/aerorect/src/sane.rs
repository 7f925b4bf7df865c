//! Sane ranges of the values a user gives for georeferencing (CONVENTIONS.md, "sane ranges"):
//! an absurd value is refused where it is read, naming the value, instead of breaking the work
//! later with a message about something else ("the homography is singular").
//!
//! Messages name the quantity and its value ("GSD 1e308 m"); the CLI adds its flag.

use crate::Error;
use aerorect_core::error::Num;

/// The coarsest ground sample distance, metres.
pub const MAX_GSD_M: f64 = 1e4;
/// The largest |height| (camera altitude, ground height, vertical offset), metres.
pub const MAX_HEIGHT_M: f64 = 1e5;
/// The largest |component| of a lever arm, metres.
pub const MAX_LEVER_ARM_M: f64 = 1e3;

/// A ground sample distance: finite, > 0 and at most [`MAX_GSD_M`].
pub fn check_gsd_m(g: f64) -> Result<f64, Error> {
    if g.is_finite() && g > 0.0 && g <= MAX_GSD_M {
        return Ok(g);
    }
    Err(Error::Invalid(format!(
        "GSD {} m must be a positive number of metres, at most {MAX_GSD_M} m",
        Num(g)
    )))
}

/// A height or height offset (`what` names it): finite with |h| <= [`MAX_HEIGHT_M`].
pub fn check_height_m(what: &str, h: f64) -> Result<f64, Error> {
    if h.is_finite() && h.abs() <= MAX_HEIGHT_M {
        return Ok(h);
    }
    Err(Error::Invalid(format!(
        "{what} {} m is outside the sane range |h| <= {MAX_HEIGHT_M} m",
        Num(h)
    )))
}

/// A lever arm: three finite components, each |x| <= [`MAX_LEVER_ARM_M`].
pub fn check_lever_arm_m(arm: [f64; 3]) -> Result<[f64; 3], Error> {
    if arm
        .iter()
        .all(|x| x.is_finite() && x.abs() <= MAX_LEVER_ARM_M)
    {
        return Ok(arm);
    }
    let [x, y, z] = arm.map(Num);
    Err(Error::Invalid(format!(
        "lever arm ({x}, {y}, {z}) m: each component must be a finite number within +-{MAX_LEVER_ARM_M} m"
    )))
}

/// A boresight (the camera's mounting rotation, degrees about its x, y, z): each component
/// within +-180 degrees (beyond is the same rotation written another way, or a typo).
pub fn check_boresight_deg(b: [f64; 3]) -> Result<[f64; 3], Error> {
    if b.iter().all(|x| x.is_finite() && x.abs() <= 180.0) {
        return Ok(b);
    }
    let [x, y, z] = b.map(Num);
    Err(Error::Invalid(format!(
        "boresight ({x}, {y}, {z}) deg: each angle must be a finite number within +-180 deg"
    )))
}

/// The error for a camera that is not above the ground it is planned over, when the GSD
/// would have come from its height: names the photo, the camera's height and where it came
/// from (which names the DEM file for a DEM), and the ground's height.
pub(crate) fn camera_below_ground(file: &str, camera_z: f64, source: &str, ground_z: f64) -> Error {
    Error::Invalid(format!(
        "{file}: the camera is not above the ground: its height {} m ({source}) is {} m above \
         the ground at {} m, so no GSD follows from it (check the altitude tags, \
         the ground height or the DEM, or give a GSD)",
        Num(camera_z),
        Num(camera_z - ground_z),
        Num(ground_z)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_outside_the_sane_ranges_are_refused_naming_them() {
        assert_eq!(check_gsd_m(0.05).ok(), Some(0.05));
        for g in [-6.87, 0.0, 1e308, f64::NAN, 2e4] {
            let e = check_gsd_m(g).unwrap_err().full_message();
            assert!(e.contains(&format!("GSD {} m", Num(g))), "{e}");
        }
        assert!(check_height_m("ground height", -430.0).is_ok());
        let e = check_height_m("vertical offset", 1e308).unwrap_err();
        assert!(e.to_string().contains("vertical offset 1e308 m"), "{e}");
        assert!(check_lever_arm_m([0.1, -0.2, 0.3]).is_ok());
        let e = check_lever_arm_m([0.0, 1e308, 0.0]).unwrap_err();
        assert!(e.to_string().contains("(0, 1e308, 0) m"), "{e}");
    }
}
