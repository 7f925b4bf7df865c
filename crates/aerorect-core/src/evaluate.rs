//! Check-point accuracy, eq. (19)-(20).

use crate::homography::Homography;
use serde::{Deserialize, Serialize};

/// One check point: where it is seen in the oblique frame and where it belongs in the standard frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CheckPoint {
    pub u_oblique: f64,
    pub v_oblique: f64,
    pub u_standard: f64,
    pub v_standard: f64,
}

/// The paper's accuracy figures, in oblique-frame pixels. Key names are the report's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CheckPointStats {
    pub n: usize,
    pub du_max: f64,
    pub dv_max: f64,
    pub urms: f64,
    pub vrms: f64,
    pub rmse: f64,
}

/// Residuals `du = u_p - u_b'`, `dv = v_p - v_b'` of every check point, where (u_b', v_b') is the
/// standard point mapped by `oblique_from_standard` (G). `None` for a point beyond the horizon.
pub fn residuals(
    points: &[CheckPoint],
    oblique_from_standard: &Homography,
) -> Vec<Option<[f64; 2]>> {
    points
        .iter()
        .map(|p| {
            oblique_from_standard
                .map(p.u_standard, p.v_standard)
                .map(|q| [p.u_oblique - q[0], p.v_oblique - q[1]])
        })
        .collect()
}

/// Summary of residuals: du_max and dv_max are the largest magnitudes, RMSE^2 = URMS^2 + VRMS^2.
/// `None` when there are no residuals.
pub fn stats(residuals: &[[f64; 2]]) -> Option<CheckPointStats> {
    if residuals.is_empty() {
        return None;
    }
    let n = residuals.len() as f64;
    let du_max = residuals.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
    let dv_max = residuals.iter().map(|r| r[1].abs()).fold(0.0, f64::max);
    let urms = (residuals.iter().map(|r| r[0] * r[0]).sum::<f64>() / n).sqrt();
    let vrms = (residuals.iter().map(|r| r[1] * r[1]).sum::<f64>() / n).sqrt();
    Some(CheckPointStats {
        n: residuals.len(),
        du_max,
        dv_max,
        urms,
        vrms,
        rmse: urms.hypot(vrms),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn stats_match_eq19_and_eq20() {
        let r = [[1.0, -2.0], [-3.0, 0.5], [0.0, 1.0]];
        let s = stats(&r).expect("non-empty");
        assert_eq!(s.du_max, 3.0);
        assert_eq!(s.dv_max, 2.0);
        assert_relative_eq!(s.urms, (10.0f64 / 3.0).sqrt());
        assert_relative_eq!(s.vrms, (5.25f64 / 3.0).sqrt());
        // eq. 19 directly: sqrt(1/n (sum du^2 + sum dv^2))
        assert_relative_eq!(s.rmse, ((10.0 + 5.25) / 3.0f64).sqrt(), epsilon = 1e-15);
        assert!(stats(&[]).is_none());
    }

    #[test]
    fn residual_sign_is_observed_minus_mapped() {
        let g = Homography::translation(1.0, 2.0);
        let p = CheckPoint {
            u_oblique: 10.0,
            v_oblique: 10.0,
            u_standard: 8.5,
            v_standard: 9.0,
        };
        let r = residuals(&[p], &g);
        assert_eq!(r, vec![Some([0.5, -1.0])]);
    }
}
