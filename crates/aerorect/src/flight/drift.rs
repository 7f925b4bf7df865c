//! A consumer GPS drifts in time: on one real GPS-only flight the altitude climbed 110 m over
//! the flight while the images held it within 40 m. Where the images contradict the fixes,
//! the flight solves them again robustly ([`super::relook`]) with a drift linear in time on
//! top of the block's common shift ([`AdjustOptions::gps_drift_times`]), where the images
//! can tell that drift apart.
//!
//! The images fix the block's shape up to a similarity. A drift linear in time is told apart
//! wherever the block spreads in two directions: a drift that grows along the strips, or
//! across them, would stretch or shear the block one way only, which no similarity does. A
//! single strip has no such shape: along it, a drift is a scale. In height, a drift tilts the
//! block: a DEM holds its tilt and height, and without one the order the strips were flown in
//! must decide it ([`drift_tilt_sigma_rad`]): strips flown east and west in turn, as survey
//! flights are, leave a sawtooth in time along each strip that no tilt has. The drift's value
//! at mid-flight is then the one thing nothing observes, so the ground, not the fixes, places
//! the block in height ([`super::relook::drifting_shift_sigma_m`]).

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

/// Without a DEM, a drift is solved where the images alone decide the block's tilt under it to
/// within this (degrees, one standard deviation, [`drift_tilt_sigma_rad`]): the level ground,
/// the alternative, leaves a block tilted by about the relief's mean slope (3.5 deg under the
/// simulated fixed wing) and the GPS's drift on top of it (4.7 deg off with 110 m of drift).
pub(super) const MAX_DRIFT_TILT_SIGMA_DEG: f64 = 3.0;

/// How well the images decide a block's tilt under a drift in height without a DEM (radians,
/// one standard deviation) for fixes at `centres` taken at `times`, each to `sigma_m`.
///
/// A drift linear in time tilts the fixes wherever time runs linearly across the block: the
/// part of the times a plane through the positions explains trades the drift for the block's
/// tilt, which nothing but a DEM holds. What the plane leaves (the strips flown east and west
/// in turn: a sawtooth along each) is seen as the drift alone, and decides it to
/// `sigma_m / |residual|` over the flight; that drift's error tilts the block by it times the
/// times' gradient across the block. On the simulated fixed wing (10 strips of 10, fixes to
/// 5 m) 2.2 deg; measured with 2 m of noise in height, 0.8 deg (2.2 x 2 / 5 = 0.9). A flight
/// whose strips all run one way leaves no residual: infinite.
pub(super) fn drift_tilt_sigma_rad(centres: &[[f64; 3]], times: &[f64], sigma_m: f64) -> f64 {
    match unplanar_times(centres, times) {
        Some((left, gradient)) if left.norm() > 0.0 => sigma_m / left.norm() * gradient,
        _ => f64::INFINITY,
    }
}

/// The part of the frames' `times` that no plane through their `centres` explains (per frame),
/// and that plane's gradient (per metre); `None` with fewer than four frames or no plane.
fn unplanar_times(centres: &[[f64; 3]], times: &[f64]) -> Option<(nalgebra::DVector<f64>, f64)> {
    let n = centres.len().min(times.len());
    if n < 4 {
        return None;
    }
    let design = nalgebra::DMatrix::from_fn(n, 3, |r, c| match c {
        0 => 1.0,
        _ => centres[r][c - 1] - centres[0][c - 1],
    });
    let t = nalgebra::DVector::from_column_slice(&times[..n]);
    let plane = design.clone().svd(true, true).solve(&t, 1e-12).ok()?;
    let left = &t - &design * &plane;
    Some((left, plane[1].hypot(plane[2])))
}

/// A drift is seen in the fixes when their offsets follow the times' unplanar part by more
/// than this many of the standard deviations their priors give ([`drift_seen`]).
pub(super) const DRIFT_SEEN_SIGMAS: f64 = 3.0;

/// Whether a solve without a drift left the fixes' `offsets` (adjusted less recorded, each
/// axis to the frame's prior `sigmas`) following, in height, the part of the `times` no plane
/// through the `centres` explains, as a drift would, by more than [`DRIFT_SEEN_SIGMAS`] of its
/// standard deviation (a weighted regression on that part).
///
/// A freed block takes a drift's planar part in height as its tilt, and each fix then stays
/// within its sigma: on the 1,000-frame fixed wing without a DEM (25 strips, the GPS 110 m up
/// over the flight), the 4.4 m each strip adds was no contradiction, the block tilted 5.6
/// deg, and each round's frames, rendered over the level ground from cameras 85 m too high,
/// missed each other by metres. What is left in the fixes is the drift's sawtooth along the
/// strips. Across, a drift shears the block, which its images hold, and is contradicted as
/// fixes are; the same regression there saw a drift of 60 +- 13 m north in the same flight
/// flown without any (its own offsets, which flip with the strips' direction), so height alone
/// is looked at.
pub(super) fn drift_seen(
    centres: &[[f64; 3]],
    times: &[f64],
    offsets: &[[f64; 3]],
    sigmas: &[[f64; 3]],
) -> bool {
    let Some((left, _)) = unplanar_times(centres, times) else {
        return false;
    };
    let (mut num, mut den) = (0.0, 0.0);
    for ((r, o), s) in left.iter().zip(offsets).zip(sigmas) {
        let w = s[2].powi(-2);
        num += w * r * o[2];
        den += w * r * r;
    }
    // The drift num / den, over its standard deviation 1 / sqrt(den).
    den > 0.0 && f64::abs(num / den.sqrt()) > DRIFT_SEEN_SIGMAS
}

/// Whether the solve of `report` took a GPS drift.
pub(super) fn drift_solved(report: &aerorect_solve::adjust::AdjustReport) -> bool {
    report.datum.as_ref().is_some_and(|d| d.drift.is_some())
}

/// The warning that names a solved drift (over the flight, first photo to last), where the
/// solve took one.
pub(super) fn drift_warning(report: &aerorect_solve::adjust::AdjustReport) -> Option<String> {
    report.datum.as_ref()?.drift.as_ref().map(drift_words)
}

/// A solved drift in words: how the fixes moved over the flight. The solve's drift is where a
/// recorded position belongs (`c + drift t`), the opposite of the fixes' own drift.
fn drift_words(d: &aerorect_solve::adjust::GpsDrift) -> String {
    let [x, y, z] = d.over_flight_m.map(|v| -v);
    let [sx, sy, sz] = d.sigma_m;
    format!(
        "the GPS drifted over the flight (first photo to last, in the order they were taken): {x:.1} m east, {y:.1} m north, {z:.1} m up (sigma {sx:.1}, {sy:.1}, {sz:.1} m); the images decided it, and each fix is taken less that drift"
    )
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
    fn the_warning_says_how_the_fixes_moved() {
        // Fixes that climbed 110 m: the solve puts each recorded position back down the drift.
        let d = aerorect_solve::adjust::GpsDrift {
            over_flight_m: [-15.0, 10.0, -110.0],
            sigma_m: [1.0, 2.0, 3.0],
        };
        let w = drift_words(&d);
        assert!(
            w.contains("15.0 m east, -10.0 m north, 110.0 m up (sigma 1.0, 2.0, 3.0 m)"),
            "{w}"
        );
    }

    /// Strips of `per` frames flown in turn east and west (`serpentine`) or all east, one
    /// photo after the other.
    fn timed_block(strips: usize, per: usize, serpentine: bool) -> (Vec<[f64; 3]>, Vec<f64>) {
        let n = strips * per;
        let centres = (0..n)
            .map(|k| {
                let (s, i) = (k / per, k % per);
                let i = if serpentine && s % 2 == 1 {
                    per - 1 - i
                } else {
                    i
                };
                [i as f64 * 22.0, s as f64 * 45.0, 100.0]
            })
            .collect();
        let times = (0..n).map(|k| k as f64 / (n - 1) as f64 - 0.5).collect();
        (centres, times)
    }

    #[test]
    fn alternating_strips_decide_a_drift_apart_from_the_tilt_and_strips_flown_one_way_do_not() {
        // 10 strips of 10 flown both ways: the plane through the times leaves a sawtooth of
        // +-0.045 along each strip (sd 0.029 over 100 frames: |residual| 0.290); the plane
        // climbs 0.00224 / m; at 5 m a fix, the drift is decided to 5 / 0.290 = 17.2 m, the
        // tilt to 17.2 x 0.00224 = 0.0387 rad = 2.22 deg (numpy's lstsq: 2.2164).
        let (c, t) = timed_block(10, 10, true);
        let tilt = drift_tilt_sigma_rad(&c, &t, 5.0).to_degrees();
        assert!((tilt - 2.2164).abs() < 1e-3, "{tilt}");
        assert!(tilt < MAX_DRIFT_TILT_SIGMA_DEG);
        // Twice the noise, twice the tilt.
        let loose = drift_tilt_sigma_rad(&c, &t, 10.0).to_degrees();
        assert!((loose / tilt - 2.0).abs() < 1e-9, "{loose} {tilt}");
        // All strips flown east: the times are a plane through the positions, up to rounding.
        let (c, t) = timed_block(10, 10, false);
        assert!(drift_tilt_sigma_rad(&c, &t, 5.0).to_degrees() > 1e3);
    }

    #[test]
    fn a_sawtooth_in_the_fixes_is_seen_as_a_drift_and_noise_or_a_tilt_is_not() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let (c, t) = timed_block(10, 10, true);
        let sigmas = vec![[5.0; 3]; c.len()];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, 3.0).expect("normal");
        let noisy: Vec<[f64; 3]> = (0..c.len())
            .map(|_| [0.0; 3].map(|_: f64| noise.sample(&mut rng)))
            .collect();
        assert!(!drift_seen(&c, &t, &noisy, &sigmas), "noise alone");
        // A tilt of the whole block (offsets a plane through the positions) is no drift.
        let tilted: Vec<[f64; 3]> = c.iter().map(|p| [0.0, 0.0, 0.05 * p[1]]).collect();
        assert!(!drift_seen(&c, &t, &tilted, &sigmas), "a tilt");
        // 100 m up over the flight (decided to 17 m here), less the planar part the solve's
        // tilt takes.
        let (left, _) = unplanar_times(&c, &t).expect("plane");
        let drifting: Vec<[f64; 3]> = noisy
            .iter()
            .zip(left.iter())
            .map(|(n, r)| [n[0], n[1], n[2] + 100.0 * r])
            .collect();
        assert!(drift_seen(&c, &t, &drifting, &sigmas), "a drift");
        // The same across the strips is not looked at (see drift_seen).
        let across: Vec<[f64; 3]> = noisy
            .iter()
            .zip(left.iter())
            .map(|(n, r)| [n[0], n[1] + 100.0 * r, n[2]])
            .collect();
        assert!(!drift_seen(&c, &t, &across, &sigmas), "across");
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
