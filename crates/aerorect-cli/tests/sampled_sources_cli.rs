//! A rendered flight over its DEM (aerorect's `examples/simulate_flight.rs`: 5 x 4 nadir
//! frames 130 m over hills, every attitude recorded N(0, 1 deg) off): `batch --adjust` over
//! the DEM weighs the two tie sources in the features round, on a correlated sample of its
//! pairs. SIFT's ties on these frames agree better than correlation's on the rendered grid,
//! so the rounds end with the features round, no correlation round is run, and the last
//! solve takes the features' spare ties; the frames end near the truth.
#![allow(clippy::unwrap_used)]

#[path = "../../aerorect/examples/simulate_flight.rs"]
#[allow(dead_code)]
mod simulate_flight;

mod common;

#[test]
fn features_that_agree_better_than_a_correlated_sample_end_the_rounds() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(5, 4, &sim, 1.0, false);
    let frames = common::rendered_frames(&sim);
    let out = tmp.path().join("out");
    let r = common::batch_adjust_rendered(&frames, &sim, ["--poses", "pert.csv"], &out);
    let rounds = r["rounds"].as_array().unwrap();
    let first = &rounds[0];
    eprintln!("{} round(s); the first: {first}", rounds.len());
    let sources = &first["sources"];
    let (sampled, weight) = (
        sources["sampled_pairs"].as_u64().unwrap(),
        sources["feature_weight"].as_f64().unwrap(),
    );
    // The weight is the squared ratio of the sample's two median gaps.
    let (fg, cg) = (
        sources["feature_gap_m"].as_f64().unwrap(),
        sources["correlation_gap_m"].as_f64().unwrap(),
    );
    assert!(
        ((cg / fg).powi(2) - weight).abs() < 1e-9 * weight,
        "{sources}"
    );
    assert!(sampled >= 1 && weight >= 1.0, "{sources}");
    assert_eq!(first["held_by_features"], true);
    assert_eq!(rounds.len(), 1, "a correlation round was run: {rounds:?}");
    assert!(
        first["final_solve"]["tie_points"].as_u64().unwrap()
            > first["tie_points"].as_u64().unwrap()
    );
    assert_eq!(r["settled"], true);
    // Against the truth: every frame recorded about 1.7 deg off (three axes of 1 deg) ends
    // within a twentieth of a degree.
    let truth = common::pose_table(&sim.join("truth.csv"));
    let adjusted = common::pose_table(&out.join("adjusted_poses.csv"));
    let recorded = common::pose_table(&sim.join("pert.csv"));
    let mut errors: Vec<f64> = Vec::new();
    for (name, t) in &truth {
        let (a, p) = (&adjusted[name], &recorded[name]);
        errors.push(common::angle_opk_deg(&a[3..6], &t[3..6]));
        assert!(
            common::angle_opk_deg(&p[3..6], &t[3..6]) > 0.1,
            "{name}: recorded too close to the truth"
        );
    }
    errors.sort_by(f64::total_cmp);
    eprintln!(
        "attitude error median {:.4} max {:.4} deg",
        errors[errors.len() / 2],
        errors[errors.len() - 1]
    );
    assert_eq!(errors.len(), 20);
    assert!(errors[errors.len() - 1] < 0.05, "{errors:?}");
}
