//! Extended: `batch --adjust --adjust-passes 1000000` on DJI_0010/0012, whose rounds keep
//! turning the frames by tenths of a degree and never meet the 0.005 deg stop (issue 28,
//! item 4): before the cap the run never ended. It must end within the cap, say so, and report
//! the rounds as oscillating with the turn of every round (the warning's turns are the report's
//! own per-round medians).
#![allow(clippy::unwrap_used)]

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn a_million_adjust_passes_end_at_the_cap_and_report_the_oscillation() {
    let (Some(a), Some(b)) = (
        aerorect_testkit::shared_data("drone-xmp/DJI_0010.JPG"),
        aerorect_testkit::shared_data("drone-xmp/DJI_0012.JPG"),
    ) else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_aerorect"))
        .args([
            "batch",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--out-dir",
        ])
        .arg(&out)
        .args(["--gsd-m", "0.5", "--adjust", "--adjust-passes", "1000000"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if started.elapsed() > Duration::from_secs(300) {
            child.kill().unwrap();
            panic!("--adjust-passes 1000000 still running after 300 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    assert!(status.success(), "{err}");
    assert!(
        err.contains("1000000 matching rounds asked for: at most 20 are run"),
        "{err}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("adjustment.json")).unwrap())
            .unwrap();
    let rounds = r["rounds"].as_array().unwrap();
    assert_eq!(r["passes"], 20);
    assert_eq!(rounds.len(), 20);
    assert_eq!(r["settled"], false);
    assert_eq!(r["oscillating"], true);
    // The warning lists every round's median turn, in order, as the report has them.
    let line = err
        .lines()
        .find(|l| l.contains("rounds oscillate"))
        .unwrap_or_else(|| panic!("no oscillation warning: {err}"));
    let listed = line
        .split("turned by ")
        .nth(1)
        .and_then(|s| s.split(" deg per round").next())
        .unwrap_or_else(|| panic!("{line}"));
    let listed: Vec<f64> = listed
        .split(", ")
        .map(|t| t.trim().parse().unwrap())
        .collect();
    assert_eq!(listed.len(), 20, "{line}");
    for (shown, round) in listed.iter().zip(rounds) {
        let median = round["median_turn_deg"].as_f64().unwrap();
        assert!(
            (shown - median).abs() <= 5e-4,
            "{shown} vs {median}: {line}"
        );
    }
    assert!(
        listed.iter().all(|&t| t > 0.005),
        "an oscillating flight has no round under the stop: {line}"
    );
}
