//! The `velocity` subcommand: image-motion velocities on the focal plane predicted from the
//! flight state, with their error budgets.

use aerorect::core::motion::{
    FlightState, FlightUncertainty, forward_budget, predict, swing_budget,
};
use anyhow::{Result, bail};
use clap::Args;

#[derive(Args)]
pub struct VelocityArgs {
    #[arg(long)]
    focal_length_mm: f64,
    #[arg(long)]
    height_m: f64,
    #[arg(long)]
    speed_mps: f64,
    #[arg(long, allow_negative_numbers = true)]
    swing_deg: f64,
    #[arg(long, allow_negative_numbers = true)]
    swing_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    yaw_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pitch_rate_dps: f64,
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    roll_rate_dps: f64,
    /// One-sigma uncertainties (same units); each becomes a term of the error budgets.
    #[arg(long, default_value_t = 0.0)]
    sigma_focal_length_mm: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_height_m: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_speed_mps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_swing_deg: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_swing_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_yaw_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_pitch_rate_dps: f64,
    #[arg(long, default_value_t = 0.0)]
    sigma_roll_rate_dps: f64,
    #[arg(long)]
    json: bool,
}

fn flight(a: &VelocityArgs) -> Result<(FlightState, FlightUncertainty)> {
    let s = FlightState {
        focal_length_mm: a.focal_length_mm,
        height_m: a.height_m,
        speed_mps: a.speed_mps,
        swing_deg: a.swing_deg,
        swing_rate_dps: a.swing_rate_dps,
        yaw_rate_dps: a.yaw_rate_dps,
        pitch_rate_dps: a.pitch_rate_dps,
        roll_rate_dps: a.roll_rate_dps,
    };
    let u = FlightUncertainty {
        focal_length_mm: a.sigma_focal_length_mm,
        height_m: a.sigma_height_m,
        speed_mps: a.sigma_speed_mps,
        swing_deg: a.sigma_swing_deg,
        swing_rate_dps: a.sigma_swing_rate_dps,
        yaw_rate_dps: a.sigma_yaw_rate_dps,
        pitch_rate_dps: a.sigma_pitch_rate_dps,
        roll_rate_dps: a.sigma_roll_rate_dps,
    };
    check_flight(&s)?;
    for (name, v) in [
        ("--sigma-focal-length-mm", u.focal_length_mm),
        ("--sigma-height-m", u.height_m),
        ("--sigma-speed-mps", u.speed_mps),
        ("--sigma-swing-deg", u.swing_deg),
        ("--sigma-swing-rate-dps", u.swing_rate_dps),
        ("--sigma-yaw-rate-dps", u.yaw_rate_dps),
        ("--sigma-pitch-rate-dps", u.pitch_rate_dps),
        ("--sigma-roll-rate-dps", u.roll_rate_dps),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            bail!("{name} {v}: an uncertainty must be a finite number >= 0");
        }
    }
    Ok((s, u))
}

pub(super) fn check_flight(s: &FlightState) -> Result<()> {
    for (name, v) in [
        ("--focal-length-mm", s.focal_length_mm),
        ("--height-m", s.height_m),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} {v}: must be a finite number > 0");
        }
    }
    for (name, v) in [
        ("--speed-mps", s.speed_mps),
        ("--swing-deg", s.swing_deg),
        ("--swing-rate-dps", s.swing_rate_dps),
        ("--yaw-rate-dps", s.yaw_rate_dps),
        ("--pitch-rate-dps", s.pitch_rate_dps),
        ("--roll-rate-dps", s.roll_rate_dps),
    ] {
        if !v.is_finite() {
            bail!("{name} {v}: must be a finite number");
        }
    }
    if s.swing_deg.abs() >= 90.0 {
        bail!(
            "--swing-deg {}: the swing angle must lie within (-90, 90)",
            s.swing_deg
        );
    }
    Ok(())
}

pub fn velocity(a: VelocityArgs) -> Result<()> {
    let (s, u) = flight(&a)?;
    let m = predict(&s);
    let (fb, sb) = (forward_budget(&s, &u), swing_budget(&s, &u));
    if a.json {
        let v = serde_json::json!({
            "v_forward_mm_s": m.v_forward_mm_s,
            "v_swing_mm_s": m.v_swing_mm_s,
            "mirror_rate_dps": m.mirror_rate_dps,
            "forward_budget": fb,
            "swing_budget": sb,
        });
        outln!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    outln!(
        "V_F (forward)  {:>12.4} mm/s   +- {:.4} (RSS), {:.4} (worst case)",
        m.v_forward_mm_s,
        fb.rss_mm_s,
        fb.worst_case_mm_s
    );
    outln!(
        "V_P (swing)    {:>12.4} mm/s   +- {:.4} (RSS), {:.4} (worst case)",
        m.v_swing_mm_s,
        sb.rss_mm_s,
        sb.worst_case_mm_s
    );
    outln!("mirror rate    {:>12.4} deg/s", m.mirror_rate_dps);
    for (label, b) in [("dV_F", &fb), ("dV_P", &sb)] {
        for t in &b.terms {
            outln!(
                "  {label} from {:<16} {:>12.6} mm/s  (partial {:.6} x sigma {})",
                t.input,
                t.contribution_mm_s,
                t.partial,
                t.sigma
            );
        }
    }
    Ok(())
}
