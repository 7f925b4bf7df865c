//! A consumer GPS drifts in time: on one real GPS-only flight the altitude climbed 110 m over
//! the flight while the images held it within 40 m. Where the images contradict the fixes,
//! the flight solves them again robustly ([`super::relook`]) and, over a DEM, with a drift
//! linear in time on top of the block's common shift ([`AdjustOptions::gps_drift_times`]).
//!
//! The images fix the block's shape up to a similarity, and the DEM its tilt and height. A
//! drift linear in time is then told apart wherever the block spreads in two directions: a
//! drift that grows along the strips, or across them, would stretch or shear the block one
//! way only, which no similarity does, and its height part would tilt the ground the DEM
//! holds. A single strip has no such shape: along it, a drift is a scale.

use super::*;

/// Fewest frames for a drift to be solved.
pub(super) const MIN_DRIFT_FRAMES: usize = 10;

/// A block is two-dimensional enough for a drift when its positions' smaller spread is at
/// least this share of the larger (standard deviations): a single strip with metres of GPS
/// noise across a few hundred metres is near 0.02, two strips 45 m apart 0.2.
pub(super) const MIN_BLOCK_ASPECT: f64 = 0.1;

/// Each frame's time in the flight: its rank in the order the photos were taken (EXIF
/// DateTimeOriginal, then file name), centred and scaled to -0.5..0.5 (0 for one frame).
pub(super) fn flight_times(metas: &[(PathBuf, PhotoMetadata)]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..metas.len()).collect();
    let key = |k: usize| (metas[k].1.time.clone().unwrap_or_default(), &metas[k].0);
    order.sort_by(|&a, &b| key(a).cmp(&key(b)));
    let last = metas.len().saturating_sub(1).max(1) as f64;
    let mut times = vec![0.0; metas.len()];
    for (rank, k) in order.into_iter().enumerate() {
        times[k] = match metas.len() {
            1 => 0.0,
            _ => rank as f64 / last - 0.5,
        };
    }
    times
}

/// Whether the images (with a DEM) can tell a GPS drift from the block's similarity, with the
/// frames recorded at `centres` (see the module's doc).
pub(super) fn drift_decided(centres: &[[f64; 3]]) -> bool {
    let n = centres.len();
    if n < MIN_DRIFT_FRAMES {
        return false;
    }
    let nf = n as f64;
    let mean = centres
        .iter()
        .fold([0.0; 2], |m, c| [m[0] + c[0] / nf, m[1] + c[1] / nf]);
    let cov = nalgebra::Matrix2::from_fn(|i, j| {
        centres
            .iter()
            .map(|c| (c[i] - mean[i]) * (c[j] - mean[j]))
            .sum::<f64>()
            / nf
    });
    let eig = cov.symmetric_eigen().eigenvalues;
    let (small, large) = (eig.min().max(0.0), eig.max());
    large > 0.0 && (small / large).sqrt() >= MIN_BLOCK_ASPECT
}

/// The warning that names a solved drift (over the flight, first photo to last), where the
/// solve took one.
pub(super) fn drift_warning(report: &aerorect_solve::adjust::AdjustReport) -> Option<String> {
    let d = report.datum.as_ref()?.drift.as_ref()?;
    let [x, y, z] = d.over_flight_m;
    let [sx, sy, sz] = d.sigma_m;
    Some(format!(
        "the GPS drifted over the flight (first photo to last, in the order they were taken): {x:.1} m east, {y:.1} m north, {z:.1} m up (sigma {sx:.1}, {sy:.1}, {sz:.1} m); the images decided it, and each fix is taken less that drift"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `strips` strips of `per` frames 22 m apart, 45 m between strips.
    fn block(strips: usize, per: usize) -> Vec<[f64; 3]> {
        (0..strips * per)
            .map(|k| [(k % per) as f64 * 22.0, (k / per) as f64 * 45.0, 100.0])
            .collect()
    }

    #[test]
    fn a_block_of_strips_decides_a_drift_and_one_strip_or_a_few_frames_do_not() {
        // Aspects: 10 strips of 10, sd 130 m across and 63 m along; one strip, 0.
        assert!(drift_decided(&block(10, 10)));
        assert!(drift_decided(&block(2, 10)));
        assert!(!drift_decided(&block(1, 30)));
        let mut wobbly = block(1, 30);
        for (k, c) in wobbly.iter_mut().enumerate() {
            c[1] += if k % 2 == 0 { 3.0 } else { -3.0 };
        }
        assert!(
            !drift_decided(&wobbly),
            "a strip with 3 m of GPS noise across it"
        );
        assert!(
            !drift_decided(&block(3, 3)),
            "fewer than {MIN_DRIFT_FRAMES} frames"
        );
    }

    #[test]
    fn times_follow_the_capture_time_then_the_file_name() {
        let meta = |name: &str, time: Option<&str>| {
            let m = PhotoMetadata {
                time: time.map(str::to_string),
                ..PhotoMetadata::default()
            };
            (PathBuf::from(name), m)
        };
        let metas = [
            meta("c.jpg", Some("2024:05:01 10:00:02")),
            meta("a.jpg", Some("2024:05:01 10:00:03")),
            meta("b.jpg", Some("2024:05:01 10:00:01")),
        ];
        assert_eq!(flight_times(&metas), vec![0.0, 0.5, -0.5]);
        let untimed = [meta("b.jpg", None), meta("a.jpg", None)];
        assert_eq!(flight_times(&untimed), vec![0.5, -0.5]);
        assert_eq!(flight_times(&untimed[..1]), vec![0.0]);
    }
}
