//! Predicted image-motion velocities of a pendulum-swing aerial camera (Li & Yang 2015,
//! eq. 1-5), their first-order error budgets, and the correction from a measured residual
//! shift (eq. 9-10).
//!
//! Units at this boundary: focal length in mm, height in m, speed in m/s, angles in degrees,
//! angular rates in degrees per second. Image-motion velocities are on the focal plane in mm/s.

use serde::{Deserialize, Serialize};

/// Flight and camera state at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FlightState {
    pub focal_length_mm: f64,
    pub height_m: f64,
    pub speed_mps: f64,
    /// alpha: swing angle of the camera across track.
    pub swing_deg: f64,
    /// alpha_dot: swing rate.
    pub swing_rate_dps: f64,
    /// psi_dot
    pub yaw_rate_dps: f64,
    /// theta_dot
    pub pitch_rate_dps: f64,
    /// phi_dot
    pub roll_rate_dps: f64,
}

/// One-sigma uncertainties of the same quantities (same units).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FlightUncertainty {
    pub focal_length_mm: f64,
    pub height_m: f64,
    pub speed_mps: f64,
    pub swing_deg: f64,
    pub swing_rate_dps: f64,
    pub yaw_rate_dps: f64,
    pub pitch_rate_dps: f64,
    pub roll_rate_dps: f64,
}

/// Predicted image motion.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ImageMotion {
    /// V_F, eq. (1): along the flight, on the focal plane.
    pub v_forward_mm_s: f64,
    /// V_P, eq. (4): along the swing, on the focal plane.
    pub v_swing_mm_s: f64,
    /// beta_dot, eq. (3): the scan-mirror rate, half the image's angular rate.
    pub mirror_rate_dps: f64,
}

/// One term of an error budget: the contribution `partial * sigma` of one input.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BudgetTerm {
    pub input: &'static str,
    /// The partial derivative of the velocity by the input (mm/s per input unit).
    pub partial: f64,
    pub sigma: f64,
    /// partial * sigma, mm/s.
    pub contribution_mm_s: f64,
}

/// The first-order error budget of one velocity (eq. 2 or 5).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ErrorBudget {
    pub terms: Vec<BudgetTerm>,
    /// Root-sum-square of the contributions (independent errors).
    pub rss_mm_s: f64,
    /// Sum of absolute contributions (the paper's worst case, all errors aligned).
    pub worst_case_mm_s: f64,
}

impl ErrorBudget {
    fn new(terms: Vec<BudgetTerm>) -> Self {
        let rss_mm_s = terms
            .iter()
            .map(|t| t.contribution_mm_s.powi(2))
            .sum::<f64>()
            .sqrt();
        let worst_case_mm_s = terms.iter().map(|t| t.contribution_mm_s.abs()).sum();
        Self {
            terms,
            rss_mm_s,
            worst_case_mm_s,
        }
    }
}

fn term(input: &'static str, partial: f64, sigma: f64) -> BudgetTerm {
    BudgetTerm {
        input,
        partial,
        sigma,
        contribution_mm_s: partial * sigma,
    }
}

/// The angular rate of the ground image along the flight, rad/s: V cos a / H + psi' sin a + theta' cos a.
fn forward_rate(s: &FlightState) -> f64 {
    let (sa, ca) = s.swing_deg.to_radians().sin_cos();
    s.speed_mps * ca / s.height_m
        + s.yaw_rate_dps.to_radians() * sa
        + s.pitch_rate_dps.to_radians() * ca
}

/// Eq. (1), (3), (4).
pub fn predict(s: &FlightState) -> ImageMotion {
    let w = forward_rate(s);
    ImageMotion {
        v_forward_mm_s: w * s.focal_length_mm,
        v_swing_mm_s: (s.swing_rate_dps - s.roll_rate_dps).to_radians() * s.focal_length_mm,
        mirror_rate_dps: (w / 2.0).to_degrees(),
    }
}

/// Eq. (2): the terms of dV_F. Angles and rates enter per degree (per degree/s).
pub fn forward_budget(s: &FlightState, u: &FlightUncertainty) -> ErrorBudget {
    let (f, h, v) = (s.focal_length_mm, s.height_m, s.speed_mps);
    let (sa, ca) = s.swing_deg.to_radians().sin_cos();
    let (psi, theta) = (s.yaw_rate_dps.to_radians(), s.pitch_rate_dps.to_radians());
    let per_deg = 1f64.to_radians();
    ErrorBudget::new(vec![
        term("focal_length_mm", forward_rate(s), u.focal_length_mm),
        term("height_m", -f * v * ca / (h * h), u.height_m),
        term("speed_mps", f * ca / h, u.speed_mps),
        term(
            "swing_deg",
            (-f * v * sa / h + f * psi * ca - f * theta * sa) * per_deg,
            u.swing_deg,
        ),
        term("yaw_rate_dps", f * sa * per_deg, u.yaw_rate_dps),
        term("pitch_rate_dps", f * ca * per_deg, u.pitch_rate_dps),
    ])
}

/// Eq. (5): the terms of dV_P.
pub fn swing_budget(s: &FlightState, u: &FlightUncertainty) -> ErrorBudget {
    let per_deg = 1f64.to_radians();
    let f = s.focal_length_mm;
    ErrorBudget::new(vec![
        term(
            "focal_length_mm",
            (s.swing_rate_dps - s.roll_rate_dps) * per_deg,
            u.focal_length_mm,
        ),
        term("swing_rate_dps", f * per_deg, u.swing_rate_dps),
        term("roll_rate_dps", -f * per_deg, u.roll_rate_dps),
    ])
}

/// How the area CCD's pixel axes lie relative to the swing and flight directions: the swing
/// direction is the CCD's +x axis turned by `angle_deg` (counter-clockwise in the x-right,
/// y-down image, i.e. towards +y), and the forward direction is the swing direction turned by
/// +90 degrees, or by -90 degrees when `mirrored`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct CcdAxes {
    pub angle_deg: f64,
    pub mirrored: bool,
}

impl CcdAxes {
    /// (swing, forward) components of an image displacement (dx, dy).
    pub fn swing_forward(&self, dx: f64, dy: f64) -> (f64, f64) {
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let swing = c * dx + s * dy;
        let forward = -s * dx + c * dy;
        (swing, if self.mirrored { -forward } else { forward })
    }
}

/// Eq. (9)-(10): velocities corrected by a displacement `(dx, dy)` in pixels measured between
/// frames `frame_period_s` apart, with `pixel_pitch_um` pixels.
pub fn corrected(
    predicted: &ImageMotion,
    shift_px: (f64, f64),
    pixel_pitch_um: f64,
    frame_period_s: f64,
    axes: &CcdAxes,
) -> (f64, f64) {
    let (p, f) = axes.swing_forward(shift_px.0, shift_px.1);
    let mm = pixel_pitch_um * 1e-3;
    (
        predicted.v_swing_mm_s + p * mm / frame_period_s,
        predicted.v_forward_mm_s + f * mm / frame_period_s,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> FlightState {
        FlightState {
            focal_length_mm: 300.0,
            height_m: 5000.0,
            speed_mps: 200.0,
            swing_deg: 30.0,
            swing_rate_dps: 20.0,
            yaw_rate_dps: 0.5,
            pitch_rate_dps: -0.3,
            roll_rate_dps: 1.0,
        }
    }

    #[test]
    fn level_flight_at_nadir_is_v_over_h_times_f() {
        let s = FlightState {
            focal_length_mm: 100.0,
            height_m: 1000.0,
            speed_mps: 50.0,
            ..Default::default()
        };
        let m = predict(&s);
        assert!((m.v_forward_mm_s - 5.0).abs() < 1e-12); // 50/1000 * 100 mm/s
        assert!((m.mirror_rate_dps - (0.025f64).to_degrees()).abs() < 1e-12);
        assert_eq!(m.v_swing_mm_s, 0.0);
    }

    /// Every partial derivative of eq. (2) and (5) against a central difference of eq. (1), (4).
    #[test]
    fn budget_partials_match_numerical_derivatives() {
        let s = state();
        let ones = FlightUncertainty {
            focal_length_mm: 1.0,
            height_m: 1.0,
            speed_mps: 1.0,
            swing_deg: 1.0,
            swing_rate_dps: 1.0,
            yaw_rate_dps: 1.0,
            pitch_rate_dps: 1.0,
            roll_rate_dps: 1.0,
        };
        let bump = |name: &str, h: f64| {
            let mut t = s;
            match name {
                "focal_length_mm" => t.focal_length_mm += h,
                "height_m" => t.height_m += h,
                "speed_mps" => t.speed_mps += h,
                "swing_deg" => t.swing_deg += h,
                "swing_rate_dps" => t.swing_rate_dps += h,
                "yaw_rate_dps" => t.yaw_rate_dps += h,
                "pitch_rate_dps" => t.pitch_rate_dps += h,
                "roll_rate_dps" => t.roll_rate_dps += h,
                _ => unreachable!(),
            }
            predict(&t)
        };
        for (budget, get) in [
            (
                forward_budget(&s, &ones),
                (|m: ImageMotion| m.v_forward_mm_s) as fn(ImageMotion) -> f64,
            ),
            (swing_budget(&s, &ones), |m: ImageMotion| m.v_swing_mm_s),
        ] {
            for t in &budget.terms {
                let h = 1e-4;
                let numeric = (get(bump(t.input, h)) - get(bump(t.input, -h))) / (2.0 * h);
                assert!(
                    (t.partial - numeric).abs() < 1e-6 * numeric.abs().max(1.0),
                    "{}: {} vs {}",
                    t.input,
                    t.partial,
                    numeric
                );
            }
        }
    }

    #[test]
    fn budget_totals() {
        let u = FlightUncertainty {
            height_m: 10.0,
            speed_mps: 1.0,
            ..Default::default()
        };
        let b = forward_budget(&state(), &u);
        let c: Vec<f64> = b
            .terms
            .iter()
            .map(|t| t.contribution_mm_s)
            .filter(|c| *c != 0.0)
            .collect();
        assert_eq!(c.len(), 2);
        assert!((b.rss_mm_s - c[0].hypot(c[1])).abs() < 1e-12);
        assert!((b.worst_case_mm_s - c[0].abs() - c[1].abs()).abs() < 1e-12);
    }

    #[test]
    fn correction_adds_the_measured_rate_along_each_axis() {
        let m = ImageMotion {
            v_forward_mm_s: 10.0,
            v_swing_mm_s: 20.0,
            mirror_rate_dps: 0.0,
        };
        // x = swing, y = forward: 2 px of 10 um in 0.002 s = 10 mm/s along the swing.
        let (vp, vf) = corrected(&m, (2.0, -1.0), 10.0, 0.002, &CcdAxes::default());
        assert!((vp - 30.0).abs() < 1e-12 && (vf - 5.0).abs() < 1e-12);
        // Swing along +y: the roles swap; mirrored flips the forward sign.
        let axes = CcdAxes {
            angle_deg: 90.0,
            mirrored: true,
        };
        let (p, f) = axes.swing_forward(2.0, -1.0);
        // forward = swing (+y) turned +90 deg = -x, mirrored = +x: component +dx = 2.
        assert!(
            (p + 1.0).abs() < 1e-12 && (f - 2.0).abs() < 1e-12,
            "{p} {f}"
        );
    }
}
