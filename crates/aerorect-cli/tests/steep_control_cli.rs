//! A 5 x 4 nadir block (aerorect's `examples/simulate_flight.rs`) over hills on a 12-degree
//! ramp, with five GCPs and ten check points and no DEM. Its ground control decides its tilt,
//! so its ties leave the level ground; their plane is steeper than the 8 degrees a survey
//! block's ground is taken to be at most (`MAX_BLOCK_SLOPE_DEG`). Without control that slope
//! would be the GPS's drift; here the control holds the block, and the slope is the ground's.
//! (Its own process: the ramp is set for the whole test binary.)
#![allow(clippy::unwrap_used)]

#[path = "../../aerorect/examples/simulate_flight.rs"]
#[allow(dead_code)]
mod simulate_flight;

mod common;

#[test]
fn a_block_held_by_control_keeps_its_steep_ground() {
    simulate_flight::set_ramp_deg(12.0);
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(5, 4, &sim, 1.0, false);
    let frames = common::rendered_frames(&sim);
    assert_eq!(frames.len(), 20);
    let (acc, report) =
        common::batch_adjust_controlled(&frames, &sim, "pert_gps.csv", &tmp.path().join("out"));
    let rmse = |what: &str, axis: &str| acc[what][axis].as_f64().unwrap();
    eprintln!(
        "check points XY / Z: recorded {:.3} / {:.3} m, adjusted {:.3} / {:.3} m; warnings {}",
        rmse("check_before", "xy_m"),
        rmse("check_before", "z_m"),
        rmse("check", "xy_m"),
        rmse("check", "z_m"),
        report["warnings"]
    );
    let levelled = report["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().starts_with("the GPS tilts the ground"));
    assert!(!levelled, "{}", report["warnings"]);
    assert!(rmse("check", "xy_m") < 0.25, "{acc}");
    assert!(rmse("check", "z_m") < 0.5, "{acc}");
}
