//! Extended tests on the real images of ../shared/data (skipped, saying so, when absent).
#![allow(clippy::unwrap_used)]

use aerorect::core::ImageSize;
use aerorect::io::read_image;
use aerorect::motion::{Displacement, Method, MotionSimConfig, Tracker, gray, motion_sim};

use aerorect_testkit::shared_data as shared;

/// The paper's headline: JTC error RMS <= 0.1 px at SNR 4 dB on airport, coast, roads, urban
/// (256 x 256 windows, shifts by linear interpolation, noise on both frames).
#[test]
fn jtc_meets_the_papers_headline_on_the_four_scenes() {
    let Some(dir) = shared("aerial") else { return };
    let scenes: Vec<_> = [
        ("airport", "sipi_5.3.02.tiff"),
        ("coast", "sipi_2.1.05.tiff"),
        ("roads", "sipi_2.2.17.tiff"),
        ("urban", "sipi_5.2.09.tiff"),
    ]
    .iter()
    .map(|(n, f)| {
        (
            n.to_string(),
            gray(&read_image(&dir.join(f)).unwrap()).unwrap(),
        )
    })
    .collect();
    let cfg = MotionSimConfig {
        size: 256,
        snr_db: vec![4.0],
        trials: 30,
        max_shift: 2.5,
        displacement: Displacement::Linear,
        methods: vec![("jtc".into(), Method::parse("jtc").unwrap())],
        seed: 1,
        dump_dir: None,
    };
    for r in motion_sim(&scenes, &cfg).unwrap() {
        assert!(
            r.error_rms_px <= 0.1,
            "{}: {} px at 4 dB",
            r.scene,
            r.error_rms_px
        );
        assert!(
            r.error_rms_px > r.crlb_rms_px,
            "no estimator beats the bound: {} vs {}",
            r.error_rms_px,
            r.crlb_rms_px
        );
    }
}

/// The fly-over sequence has a cut between 6.2.16 and 6.2.17: that step must be the least
/// confident one, for the JTC and for cross-correlation.
#[test]
fn the_sequence_cut_is_the_least_confident_step() {
    let Some(dir) = shared("aerial-seq") else {
        return;
    };
    for method in ["jtc", "xcorr"] {
        let mut t = Tracker::new(Method::parse(method).unwrap(), ImageSize::new(256, 256)).unwrap();
        let mut steps = vec![];
        for k in 1..=32 {
            let f = gray(&read_image(&dir.join(format!("sipi_6.2.{k:02}.tiff"))).unwrap()).unwrap();
            if let Some(s) = t.push(f.plane(0).to_vec()).unwrap() {
                steps.push((k, s.estimate.confidence));
            }
        }
        let worst = steps.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        assert_eq!(worst.0, 17, "{method}: least confident step {worst:?}");
    }
}
