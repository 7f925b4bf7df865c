//! A rendered flight over its DEM (aerorect's `examples/simulate_flight.rs`: 5 x 4 nadir
//! frames 130 m over hills) given only GPS positions that drift as a consumer receiver's
//! can: up 80 m over the flight in frame order, 11 m east and 7 m south with it, and N(0,
//! 3 m) of noise, with one fix 40 m further off. The DEM fixes the ground, so the images
//! contradict the drifting fixes; `batch --adjust` solves the drift (reported), and the one
//! fix still contradicted beyond it is down-weighted (its weight in the report): the images
//! win. Taken quadratically, the fixes bent the block 0.90 deg median from the truth; taken
//! robustly without the drift, 0.40 deg (both measured on the drift alone); with the drift,
//! 0.058 deg, and 0.080 deg since the ground, not the fixes, places a drifting block in height
//! (on the 100-frame fixed wing over its DEM, 110 m of drift: 0.102 deg before, 0.022 after).
//! Without a DEM, strips flown both ways decide a drift; strips all flown one way cannot, and a
//! flight they tilt is reported against its recorded attitudes, and one with GPS alone is
//! warned that nothing but the GPS heights level it.
#![allow(clippy::unwrap_used)]

#[path = "../../aerorect/examples/simulate_flight.rs"]
#[allow(dead_code)]
mod simulate_flight;

mod common;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// The ODM geo.txt of `flown` (file name, true pose, in the order flown: the names') as a drifting GPS
/// records it: up [`DRIFT_UP_M`] over the flight, 0.136 of it east and 0.091 south, with
/// N(0, 3 m) of noise.
fn drifting_geo<'a>(flown: impl ExactSizeIterator<Item = (&'a str, &'a Vec<f64>)>) -> String {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 3.0).unwrap();
    let mut geo = String::from("EPSG:32633\n");
    let last = flown.len() - 1;
    for (k, (name, t)) in flown.enumerate() {
        let up = DRIFT_UP_M * k as f64 / last as f64;
        let mut n = || noise.sample(&mut rng);
        let (x, y, z) = (
            t[0] + up * 0.136 + n(),
            t[1] - up * 0.091 + n(),
            t[2] + up + n(),
        );
        geo.push_str(&format!("{name} {x:.3} {y:.3} {z:.3}\n"));
    }
    geo
}

/// The GPS's climb over the flight (m).
const DRIFT_UP_M: f64 = 80.0;

/// The median and worst angles (degrees) between `adjusted` and `truth`, by file name.
fn errors_deg(
    truth: &std::collections::BTreeMap<String, Vec<f64>>,
    adjusted: &std::collections::BTreeMap<String, Vec<f64>>,
) -> (f64, f64) {
    let mut errors: Vec<f64> = truth
        .iter()
        .map(|(n, t)| common::angle_opk_deg(&adjusted[n][3..6], &t[3..6]))
        .collect();
    assert_eq!(errors.len(), adjusted.len());
    errors.sort_by(f64::total_cmp);
    (errors[errors.len() / 2], errors[errors.len() - 1])
}

#[test]
fn drifting_gps_is_solved_as_a_drift_and_a_wild_fix_is_down_weighted() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(5, 4, &sim, 1.0, false);
    let truth = common::pose_table(&sim.join("truth.csv"));
    let mut geo = drifting_geo(truth.iter().map(|(n, t)| (n.as_str(), t)));
    // One fix 40 m east of its drift.
    let wild = "f_002_002.png";
    geo = geo
        .lines()
        .map(|l| match l.strip_prefix(wild) {
            Some(rest) => {
                let v: Vec<f64> = rest
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                format!("{wild} {:.3} {:.3} {:.3}\n", v[0] + 40.0, v[1], v[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(sim.join("geo.txt"), geo).unwrap();
    let frames: Vec<_> = truth.keys().map(|n| sim.join("frames").join(n)).collect();
    let out = tmp.path().join("out");
    let r = common::batch_adjust_rendered(&frames, &sim, ["--geo", "geo.txt"], &out);
    let drift = &r["adjustment"]["datum"]["drift"];
    let got: Vec<f64> = (0..3)
        .map(|k| drift["over_flight_m"][k].as_f64().unwrap())
        .collect();
    let adjusted = common::pose_table(&out.join("adjusted_poses.csv"));
    let (median, worst) = errors_deg(&truth, &adjusted);
    let gps = r["gps"].as_array().unwrap();
    let weight = |g: &serde_json::Value| g["weight"].as_f64().unwrap();
    let wild_fix = gps
        .iter()
        .find(|g| g["frame"].as_str().unwrap().ends_with(wild))
        .unwrap();
    eprintln!(
        "drift {got:?} m (sigma {}); the wild fix: {wild_fix}; attitude error median {median:.3} max {worst:.3} deg",
        drift["sigma_m"]
    );
    // A recorded position belongs `drift t` back: the solved drift is the recorded one's
    // opposite, to within the fixes' noise.
    let want = [-0.136 * DRIFT_UP_M, 0.091 * DRIFT_UP_M, -DRIFT_UP_M];
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 6.0, "{got:?} vs {want:?}");
    }
    let warned = |start: &str| {
        r["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().starts_with(start))
    };
    assert!(
        warned("the GPS drifted over the flight"),
        "{:?}",
        r["warnings"]
    );
    // Beyond the drift, the images contradict the wild fix alone, and it is down-weighted.
    assert!(
        warned("the images contradict the GPS positions"),
        "{:?}",
        r["warnings"]
    );
    assert!(
        wild_fix["contradicted"] == true && weight(wild_fix) < 0.5,
        "{wild_fix}"
    );
    let others = gps.iter().filter(|g| g["contradicted"] == true).count() - 1;
    assert!(others <= 1, "{gps:?}");
    assert!(median < 0.2, "{median}");
}

/// The pose table `pert_gps.csv` (`filename,x,y,z,omega,phi,kappa`, in the order flown: the
/// names') with its positions drifting as [`drifting_geo`]'s, without its noise.
fn drifting_pose_table(text: &str) -> String {
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    let rows: Vec<&str> = lines.collect();
    let last = rows.len() - 1;
    for (k, row) in rows.iter().enumerate() {
        let up = DRIFT_UP_M * k as f64 / last as f64;
        let mut v: Vec<String> = row.split(',').map(str::to_string).collect();
        for (i, d) in [(1, up * 0.136), (2, -up * 0.091), (3, up)] {
            v[i] = format!("{:.3}", v[i].parse::<f64>().unwrap() + d);
        }
        out.push_str(&format!("{}\n", v.join(",")));
    }
    out
}

/// With ground control and no DEM, the same drift lands the check points where they belong:
/// the GCPs fix the block, and the drift of a strip-by-strip flight is mostly a tilt and a
/// shift of its GPS, which the control's similarity takes (no drift is solved with control).
/// The block's ties must be free of the level ground for that: held to it, as a block whose
/// GPS cannot decide its tilt was, they pulled this 20-frame block 7 m down against the GCPs
/// (check points 0.31 / 6.87 m XY / Z, 0.31 / 6.67 m without the drift; 0.09 / 0.28 m now).
/// The 100-frame simulation (`bench/sim_flight.py 10 10 DIR gcp`, `SIM_FLIGHT_NO_DEM=25`,
/// `SIM_FLIGHT_GPS_DRIFT=110`), whose GPS decided its tilt already: 0.078 / 0.116 m without
/// the drift, 0.075 / 0.151 m with it.
#[test]
fn with_ground_control_a_drifting_gps_still_lands_the_check_points() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(5, 4, &sim, 1.0, false);
    let table = std::fs::read_to_string(sim.join("pert_gps.csv")).unwrap();
    std::fs::write(sim.join("drifting.csv"), drifting_pose_table(&table)).unwrap();
    std::fs::copy(sim.join("pert_gps.prj"), sim.join("drifting.prj")).unwrap();
    let frames = common::rendered_frames(&sim);
    let (acc, _) =
        common::batch_adjust_controlled(&frames, &sim, "drifting.csv", &tmp.path().join("out"));
    let rmse = |what: &str, axis: &str| acc[what][axis].as_f64().unwrap();
    eprintln!(
        "check points XY / Z: recorded {:.3} / {:.3} m, adjusted {:.3} / {:.3} m",
        rmse("check_before", "xy_m"),
        rmse("check_before", "z_m"),
        rmse("check", "xy_m"),
        rmse("check", "z_m")
    );
    assert!(rmse("check_before", "z_m") > 20.0, "{acc}");
    // Within a GSD (0.25 m) across and two along the vertical.
    assert!(rmse("check", "xy_m") < 0.25, "{acc}");
    assert!(rmse("check", "z_m") < 0.5, "{acc}");
}

/// Without a DEM, a fixed wing's strips flown east and west in turn decide a drift in height
/// apart from the block's tilt (`drift::drift_tilt_sigma_rad`), and the level ground the
/// freed ties average to places the block in height: the 8 x 8 fixed wing, GPS only (nadir
/// along the track to start), its fixes climbing 80 m over the flight (N(0, 3 m) of noise).
/// Before the drift was solved without a DEM, the drift tilted the block with no warning:
/// 13.0 deg median from the truth (14.9 worst), its cameras 45 m off in height; now 1.1 deg
/// (1.4), 1.5 m, and the drift is found to within its sigma (73 +- 12 m).
#[test]
fn without_a_dem_alternating_strips_decide_a_drifting_gps() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    simulate_flight::simulate(8, 8, &sim, 5.0, true);
    let truth = common::pose_table(&sim.join("truth.csv"));
    let geo = drifting_geo(truth.iter().map(|(n, t)| (n.as_str(), t)));
    std::fs::write(sim.join("geo.txt"), geo).unwrap();
    let out = tmp.path().join("out");
    let frames = common::rendered_frames(&sim);
    let ground = ["--ground-height-m".as_ref(), "25".as_ref()];
    let r = common::batch_adjust_over(&frames, &sim, ["--geo", "geo.txt"], &ground, &[], &out);
    let adjusted = common::pose_table(&out.join("adjusted_poses.csv"));
    let (median, worst) = errors_deg(&truth, &adjusted);
    let mut heights: Vec<f64> = truth
        .iter()
        .map(|(n, t)| (adjusted[n][2] - t[2]).abs())
        .collect();
    heights.sort_by(f64::total_cmp);
    let height = heights[heights.len() / 2];
    let drift = &r["adjustment"]["datum"]["drift"];
    eprintln!(
        "attitude error median {median:.3} max {worst:.3} deg, height error median {height:.2} m, drift {drift}, warnings {}",
        r["warnings"]
    );
    let up = drift["over_flight_m"][2].as_f64().unwrap();
    let sigma = drift["sigma_m"][2].as_f64().unwrap();
    assert!(
        (up + DRIFT_UP_M).abs() < 3.0 * sigma && sigma < 20.0,
        "{drift}"
    );
    assert!(median < 2.0 && worst < 3.0, "{median} {worst}");
    assert!(height < 5.0, "{heights:?}");
    // The strips decide the drift: no word that the GPS alone levels the flight.
    assert!(!unseen_drift_warned(&r), "{}", r["warnings"]);
}

/// The 8 x 8 fixed wing's frames (rendered once under `tmp/sim`) in `tmp/<tag>/frames`, its
/// strips taken as all flown one way: the odd strips' frames renamed in reverse, so that the
/// names' order runs west to east along every strip. The folder, and the truth and the
/// recorded (5 deg off) poses by the new names.
fn one_way_frames(tmp: &std::path::Path, tag: &str) -> (std::path::PathBuf, PoseTable, PoseTable) {
    let sim = tmp.join("sim");
    if !sim.exists() {
        simulate_flight::simulate(8, 8, &sim, 5.0, true);
    }
    let one_way = |name: &str| -> String {
        let (strip, k): (usize, usize) = (name[2..5].parse().unwrap(), name[6..9].parse().unwrap());
        let k = if strip % 2 == 1 { 7 - k } else { k };
        format!("f_{strip:03}_{k:03}.png")
    };
    let dir = tmp.join(tag);
    std::fs::create_dir_all(dir.join("frames")).unwrap();
    for f in common::rendered_frames(&sim) {
        let name = f.file_name().unwrap().to_str().unwrap();
        std::fs::copy(&f, dir.join("frames").join(one_way(name))).unwrap();
    }
    std::fs::copy(sim.join("cam.toml"), dir.join("cam.toml")).unwrap();
    let rename = |t: PoseTable| t.into_iter().map(|(n, v)| (one_way(&n), v)).collect();
    let truth = rename(common::pose_table(&sim.join("truth.csv")));
    let pert = rename(common::pose_table(&sim.join("pert.csv")));
    std::fs::copy(sim.join("pert.prj"), dir.join("poses.prj")).unwrap();
    (dir, truth, pert)
}

/// The one-way 8 x 8 fixed wing ([`one_way_frames`]) with its recorded attitudes (5 deg off)
/// and GPS positions, and no DEM. Fixes climbing `up_m` over the names' order rise with the
/// strips, as a tilted block's would: nothing but the attitudes' priors can tell. Its poses
/// and the report of `batch --adjust`.
fn one_way_flight(tmp: &std::path::Path, up_m: f64) -> OneWay {
    let (dir, truth, pert) = one_way_frames(tmp, &format!("one_way_{up_m}"));
    let mut recorded = PoseTable::new();
    let mut table = String::from("filename,x,y,z,omega,phi,kappa\n");
    let last = pert.len() - 1;
    for (k, (name, p)) in pert.iter().enumerate() {
        let up = up_m * k as f64 / last as f64;
        let v = vec![p[0], p[1], p[2] + up, p[3], p[4], p[5]];
        let cells: Vec<String> = v.iter().map(|x| format!("{x:.6}")).collect();
        table.push_str(&format!("{name},{}\n", cells.join(",")));
        recorded.insert(name.clone(), v);
    }
    std::fs::write(dir.join("poses.csv"), table).unwrap();
    let out = dir.join("out");
    let ground = ["--ground-height-m".as_ref(), "25".as_ref()];
    let extra = ["--attitude-sigma-deg", "5", "--adjust-positions-m", "3"];
    let frames = common::rendered_frames(&dir);
    let r = common::batch_adjust_over(
        &frames,
        &dir,
        ["--poses", "poses.csv"],
        &ground,
        &extra,
        &out,
    );
    let adjusted = common::pose_table(&out.join("adjusted_poses.csv"));
    OneWay {
        truth,
        recorded,
        adjusted,
        report: r,
    }
}

type PoseTable = std::collections::BTreeMap<String, Vec<f64>>;

/// A one-way flight's poses (by the renamed frames) and the adjustment's report.
struct OneWay {
    truth: PoseTable,
    /// As given to the adjustment (drift included).
    recorded: PoseTable,
    adjusted: PoseTable,
    report: serde_json::Value,
}

/// The horizontal part (deg) of the mean turn, in world axes, from the `recorded` attitudes
/// to the `adjusted` ones (omega-phi-kappa tables): the whole flight's common tilt.
fn common_tilt_deg(recorded: &PoseTable, adjusted: &PoseTable) -> f64 {
    let r = |o: &[f64]| {
        aerorect::core::CameraRotation::omega_phi_kappa(o[0], o[1], o[2])
            .unwrap()
            .ground_from_camera()
            .to_owned()
    };
    let mut sum = [0.0; 2];
    for (name, a) in adjusted {
        let t = r(&a[3..6]) * r(&recorded[name][3..6]).transpose();
        // The turn's rotation vector: its axis (from the skew part) times its angle.
        let angle = ((t.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
        // angle / (2 sin angle), 1/2 in the limit of no turn.
        let scale = match angle > 1e-12 {
            true => angle / (2.0 * angle.sin()),
            false => 0.5,
        };
        let v = [
            (t[(2, 1)] - t[(1, 2)]) * scale,
            (t[(0, 2)] - t[(2, 0)]) * scale,
        ];
        sum = [sum[0] + v[0], sum[1] + v[1]];
    }
    let n = adjusted.len() as f64;
    (sum[0] / n).hypot(sum[1] / n).to_degrees()
}

#[test]
fn strips_flown_one_way_tilted_by_a_drifting_gps_say_so() {
    let tmp = tempfile::tempdir().unwrap();
    let warned = |r| warning_with(r, "tilt the whole flight").map(str::to_string);
    // Without a drift the fixes and the attitudes agree: no warning, the frames near the truth.
    let still = one_way_flight(tmp.path(), 0.0);
    let (median, _) = errors_deg(&still.truth, &still.adjusted);
    let w = warned(&still.report);
    eprintln!("no drift: {median:.3} deg, {w:?}");
    assert!(median < 1.0 && w.is_none(), "{median} {w:?}");
    // Without a DEM the features round weighs its sources between the rays: here its
    // features agree better than correlation's on the sampled pairs (0.020 against 0.035 m
    // when measured), and end the rounds (0.29 deg from the truth after correlation rounds).
    let rounds = still.report["rounds"].as_array().unwrap();
    let sources = &rounds[0]["sources"];
    assert!(
        rounds.len() == 1
            && rounds[0]["held_by_features"] == true
            && sources["sampled_pairs"].as_u64() > Some(0)
            && sources["feature_gap_m"].as_f64() <= sources["correlation_gap_m"].as_f64(),
        "{rounds:?}"
    );
    // Recorded attitudes level it as well as the GPS.
    assert!(
        !unseen_drift_warned(&still.report),
        "{}",
        still.report["warnings"]
    );
    // Climbing 30 m along the one-way order, the fixes tilt the block degrees off the truth;
    // the warning says by how much against the recorded attitudes, as the pose tables do.
    let up = one_way_flight(tmp.path(), 30.0);
    let (median, _) = errors_deg(&up.truth, &up.adjusted);
    let w = warned(&up.report).unwrap_or_default();
    eprintln!("30 m of drift: {median:.3} deg, {w}");
    assert!(median > 2.0, "{median}");
    let said: f64 = w
        .split("tilt the whole flight by ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or(f64::NAN);
    let tilt = common_tilt_deg(&up.recorded, &up.adjusted);
    assert!((said - tilt).abs() < 0.15, "{said} {tilt}: {w}");
    assert!(w.contains("--dem or --gcps"), "{w}");
}

/// The warning of an adjustment's report `r` that says `phrase`, if any.
fn warning_with<'a>(r: &'a serde_json::Value, phrase: &str) -> Option<&'a str> {
    r["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|w| w.as_str())
        .find(|w| w.contains(phrase))
}

/// Whether `r` carries the warning that nothing but the GPS heights level the flight.
fn unseen_drift_warned(r: &serde_json::Value) -> bool {
    warning_with(r, "nothing but the GPS heights levels this flight").is_some()
}

/// The one-way 8 x 8 fixed wing ([`one_way_frames`]) given GPS alone (nadir along the track
/// to start), its fixes climbing [`DRIFT_UP_M`] over the names' order, and no DEM: nothing
/// tells the drift from a tilt, and the block ends degrees off the truth. That cannot be
/// measured, but it can be said: the flight could be tilted unseen.
#[test]
fn gps_only_strips_flown_one_way_say_the_gps_alone_levels_them() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, truth, _) = one_way_frames(tmp.path(), "one_way_gps");
    let geo = drifting_geo(truth.iter().map(|(n, t)| (n.as_str(), t)));
    std::fs::write(dir.join("geo.txt"), geo).unwrap();
    let out = dir.join("out");
    let ground = ["--ground-height-m".as_ref(), "25".as_ref()];
    let frames = common::rendered_frames(&dir);
    let r = common::batch_adjust_over(&frames, &dir, ["--geo", "geo.txt"], &ground, &[], &out);
    let adjusted = common::pose_table(&out.join("adjusted_poses.csv"));
    let (median, worst) = errors_deg(&truth, &adjusted);
    eprintln!(
        "one way, GPS only: {median:.3} / {worst:.3} deg, warnings {}",
        r["warnings"]
    );
    assert!(median > 2.0, "{median}");
    assert!(unseen_drift_warned(&r), "{}", r["warnings"]);
}
