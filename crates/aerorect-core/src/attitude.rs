//! The six-attitude-angle chain of Zhou et al. (2015), eq. (2)-(5), exactly as the paper writes it.
//!
//! `R = M_air M_cam`, with `M_cam = Rz'(A) Rx(alpha) Rz(kappa_v)` (camera -> aircraft) and
//! `M_air = Ry'(phi) Rx(omega) Rz(kappa)` (aircraft -> ground-parallel). `Rz'` and `Ry'` are the
//! transposes of the usual right-handed rotations: the paper's signs are kept on purpose.

use crate::Mat3;
use crate::error::{GeometryError, require_finite};
use serde::{Deserialize, Serialize};

/// The six angles, in radians. Build from degrees with [`SixAngleAttitude::from_degrees`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SixAngleAttitude {
    /// A: camera azimuth about the aircraft Z axis.
    pub azimuth: f64,
    /// alpha: camera elevation/tilt; 0 looks straight down.
    pub elevation: f64,
    /// kappa_v: image rotation about the optical axis.
    pub image_rotation: f64,
    /// phi: aircraft pitch.
    pub pitch: f64,
    /// omega: aircraft roll.
    pub roll: f64,
    /// kappa: aircraft yaw (heading).
    pub yaw: f64,
}

/// The six angles in degrees, as they appear in files, on the command line and in reports.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SixAngleDegrees {
    pub azimuth: f64,
    pub elevation: f64,
    pub image_rotation: f64,
    pub pitch: f64,
    pub roll: f64,
    pub yaw: f64,
}

impl SixAngleDegrees {
    /// The field names in the order of the paper: A, alpha, kappa_v, phi, omega, kappa.
    pub const FIELDS: [&'static str; 6] = [
        "azimuth",
        "elevation",
        "image_rotation",
        "pitch",
        "roll",
        "yaw",
    ];

    /// The values in the order of [`Self::FIELDS`].
    pub fn values(&self) -> [f64; 6] {
        [
            self.azimuth,
            self.elevation,
            self.image_rotation,
            self.pitch,
            self.roll,
            self.yaw,
        ]
    }
}

impl SixAngleAttitude {
    /// Converts degrees to the radian model, refusing NaN, infinities and impossible angles:
    /// every angle within [-360, 360] degrees; elevation, pitch and roll within [-90, 90].
    pub fn from_degrees(d: &SixAngleDegrees) -> Result<Self, GeometryError> {
        for (field, value) in SixAngleDegrees::FIELDS.iter().zip(d.values()) {
            require_finite(field, value)?;
            let limit = match *field {
                "elevation" | "pitch" | "roll" => 90.0,
                _ => 360.0,
            };
            if value.abs() > limit {
                let reason = if limit == 90.0 {
                    "must lie within [-90, 90] degrees"
                } else {
                    "must lie within [-360, 360] degrees"
                };
                return Err(GeometryError::InvalidParameter {
                    field,
                    value,
                    reason,
                });
            }
        }
        Ok(Self {
            azimuth: d.azimuth.to_radians(),
            elevation: d.elevation.to_radians(),
            image_rotation: d.image_rotation.to_radians(),
            pitch: d.pitch.to_radians(),
            roll: d.roll.to_radians(),
            yaw: d.yaw.to_radians(),
        })
    }

    /// Back to degrees, for reports.
    pub fn to_degrees(&self) -> SixAngleDegrees {
        SixAngleDegrees {
            azimuth: self.azimuth.to_degrees(),
            elevation: self.elevation.to_degrees(),
            image_rotation: self.image_rotation.to_degrees(),
            pitch: self.pitch.to_degrees(),
            roll: self.roll.to_degrees(),
            yaw: self.yaw.to_degrees(),
        }
    }

    /// `M_cam = Rz'(A) Rx(alpha) Rz(kappa_v)`: camera frame -> aircraft frame (eq. 2-3, a1..c3).
    pub fn aircraft_from_camera(&self) -> Mat3 {
        rz_prime(self.azimuth) * rx(self.elevation) * rz(self.image_rotation)
    }

    /// `M_air = Ry'(phi) Rx(omega) Rz(kappa)`: aircraft frame -> ground-parallel frame (eq. 4-5, d1..f3).
    pub fn ground_from_aircraft(&self) -> Mat3 {
        ry_prime(self.pitch) * rx(self.roll) * rz(self.yaw)
    }

    /// `R = M_air M_cam`: camera frame -> ground-parallel (image-space auxiliary) frame.
    pub fn ground_from_camera(&self) -> Mat3 {
        self.ground_from_aircraft() * self.aircraft_from_camera()
    }
}

/// `Rz'(t) = [c s 0; -s c 0; 0 0 1]` (the transpose of the usual rotation about Z).
pub fn rz_prime(t: f64) -> Mat3 {
    let (s, c) = t.sin_cos();
    Mat3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0)
}

/// `Rx(t) = [1 0 0; 0 c -s; 0 s c]`.
pub fn rx(t: f64) -> Mat3 {
    let (s, c) = t.sin_cos();
    Mat3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// `Rz(t) = [c -s 0; s c 0; 0 0 1]`.
pub fn rz(t: f64) -> Mat3 {
    let (s, c) = t.sin_cos();
    Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// `Ry'(t) = [c 0 -s; 0 1 0; s 0 c]` (the transpose of the usual rotation about Y).
pub fn ry_prime(t: f64) -> Mat3 {
    let (s, c) = t.sin_cos();
    Mat3::new(c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    /// Eq. (3) of the paper, element by element, written from the printed formulas.
    fn paper_eq3(a: f64, al: f64, kv: f64) -> Mat3 {
        let (sa, ca) = a.sin_cos();
        let (sl, cl) = al.sin_cos();
        let (sk, ck) = kv.sin_cos();
        Mat3::new(
            ca * ck + sa * cl * sk,
            -ca * sk + sa * cl * ck,
            -sa * sl,
            -sa * ck + ca * cl * sk,
            sa * sk + ca * cl * ck,
            -ca * sl,
            sl * sk,
            sl * ck,
            cl,
        )
    }

    /// Eq. (5) of the paper, element by element.
    fn paper_eq5(p: f64, o: f64, k: f64) -> Mat3 {
        let (sp, cp) = p.sin_cos();
        let (so, co) = o.sin_cos();
        let (sk, ck) = k.sin_cos();
        Mat3::new(
            cp * ck - sp * so * sk,
            -cp * sk - sp * so * ck,
            -sp * co,
            co * sk,
            co * ck,
            -so,
            sp * ck + cp * so * sk,
            -sp * sk + cp * so * ck,
            cp * co,
        )
    }

    fn angle() -> impl Strategy<Value = f64> {
        -3.2f64..3.2
    }

    proptest! {
        #[test]
        fn camera_chain_matches_eq3(a in angle(), al in angle(), kv in angle()) {
            let att = SixAngleAttitude { azimuth: a, elevation: al, image_rotation: kv, ..Default::default() };
            let m = att.aircraft_from_camera();
            let p = paper_eq3(a, al, kv);
            for i in 0..9 { prop_assert!((m[i] - p[i]).abs() < 1e-14, "element {i}: {} vs {}", m[i], p[i]); }
        }

        #[test]
        fn aircraft_chain_matches_eq5(p in angle(), o in angle(), k in angle()) {
            let att = SixAngleAttitude { pitch: p, roll: o, yaw: k, ..Default::default() };
            let m = att.ground_from_aircraft();
            let e = paper_eq5(p, o, k);
            for i in 0..9 { prop_assert!((m[i] - e[i]).abs() < 1e-14, "element {i}: {} vs {}", m[i], e[i]); }
        }

        #[test]
        fn r_is_a_rotation(a in angle(), al in angle(), kv in angle(), p in angle(), o in angle(), k in angle()) {
            let r = SixAngleAttitude { azimuth: a, elevation: al, image_rotation: kv, pitch: p, roll: o, yaw: k }
                .ground_from_camera();
            prop_assert!((r.transpose() * r - Mat3::identity()).abs().max() < 1e-13);
            prop_assert!((r.determinant() - 1.0).abs() < 1e-13);
        }
    }

    #[test]
    fn r_is_product_air_times_cam() {
        let att = SixAngleAttitude::from_degrees(&SixAngleDegrees {
            azimuth: 10.0,
            elevation: 30.0,
            image_rotation: -5.0,
            pitch: 2.0,
            roll: -3.0,
            yaw: 40.0,
        })
        .expect("valid angles");
        let want = paper_eq5(att.pitch, att.roll, att.yaw)
            * paper_eq3(att.azimuth, att.elevation, att.image_rotation);
        assert_relative_eq!(att.ground_from_camera(), want, epsilon = 1e-14);
    }

    #[test]
    fn degrees_round_trip_and_validation() {
        let d = SixAngleDegrees {
            azimuth: 12.5,
            elevation: -30.0,
            image_rotation: 1.0,
            pitch: 2.0,
            roll: 3.0,
            yaw: 359.0,
        };
        let back = SixAngleAttitude::from_degrees(&d)
            .expect("valid")
            .to_degrees();
        for (x, y) in d.values().iter().zip(back.values()) {
            assert_relative_eq!(*x, y, epsilon = 1e-12);
        }
        let bad = SixAngleDegrees {
            pitch: f64::NAN,
            ..d
        };
        assert!(matches!(
            SixAngleAttitude::from_degrees(&bad),
            Err(GeometryError::InvalidParameter { field: "pitch", .. })
        ));
        let bad = SixAngleDegrees { roll: 91.0, ..d };
        assert!(matches!(
            SixAngleAttitude::from_degrees(&bad),
            Err(GeometryError::InvalidParameter { field: "roll", .. })
        ));
    }
}
