//! Whether a RANSAC consensus could be chance: its number of false alarms, a contrario.
//!
//! Moisan, Moulon and Monasse, "Automatic homographic registration of a pair of images, with
//! a contrario elimination of outliers", IPOL 2 (2012), section 2.2: a model fit to a sample of
//! `s` of `n` pairs and agreeing with `k` of them (sample included) would be matched by chance
//! NFA = `models` (n - s) C(n, k) C(k, s) alpha^(k - s) times, where `alpha` is the
//! probability that a pair with no true counterpart agrees with a given model and `models`
//! the models one sample gives. The consensus is meaningful when NFA < 1.
//!
//! RANSAC's inlier count alone does not say this: a fundamental matrix fits any 8 pairs, and
//! among a few hundred chance matches confined to a small search window it finds a band that
//! holds a dozen or more of them.

/// How a RANSAC model meets pairs that have no true counterpart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChanceModel {
    /// Pairs in a minimal sample.
    pub sample: usize,
    /// Models one sample gives.
    pub models: usize,
    /// The probability that a chance pair agrees with a given model (clamped to at most 1).
    pub alpha: f64,
}

/// log10 of the number of false alarms of a consensus of `k` of `n` pairs under `model`
/// (see the module doc); infinity when the consensus is no larger than a sample or `alpha`
/// is not positive.
pub fn false_alarms_log10(n: usize, k: usize, model: &ChanceModel) -> f64 {
    let s = model.sample;
    let positive = model.alpha.partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater);
    if k <= s || k > n || !positive || model.models == 0 {
        return f64::INFINITY;
    }
    let ln10 = std::f64::consts::LN_10;
    ((model.models * (n - s)) as f64).log10()
        + ln_choose(n, k) / ln10
        + ln_choose(k, s) / ln10
        + (k - s) as f64 * model.alpha.min(1.0).log10()
}

/// Whether `inliers` (a RANSAC consensus over its pairs) is meaningful under `model`: fewer
/// than one false alarm.
pub fn meaningful(inliers: &[bool], model: &ChanceModel) -> bool {
    let k = inliers.iter().filter(|&&b| b).count();
    false_alarms_log10(inliers.len(), k, model) < 0.0
}

/// ln C(n, k), as a sum of min(k, n - k) logarithms.
fn ln_choose(n: usize, k: usize) -> f64 {
    let k = k.min(n - k);
    (0..k).map(|i| ((n - i) as f64 / (i + 1) as f64).ln()).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binomials_are_exact_products() {
        for (n, k, want) in [
            (10, 3, 120.0),
            (10, 7, 120.0),
            (52, 5, 2_598_960.0),
            (7, 0, 1.0),
            (7, 7, 1.0),
        ] {
            let got = ln_choose(n, k).exp();
            assert!((got - want).abs() <= 1e-9 * want, "C({n}, {k}) = {got}");
        }
    }

    /// Against the formula evaluated with Python's exact `math.comb`:
    /// log10(96) + log10(comb(100, 20)) + log10(comb(20, 4)) + 16 log10(0.01) and
    /// log10(2 (50 - 8)) + log10(comb(50, 30)) + log10(comb(30, 8)) + 22 log10(0.05).
    #[test]
    fn false_alarms_match_the_exact_formula() {
        let h = ChanceModel {
            sample: 4,
            models: 1,
            alpha: 0.01,
        };
        let f = ChanceModel {
            sample: 8,
            models: 2,
            alpha: 0.05,
        };
        for (got, want) in [
            (false_alarms_log10(100, 20, &h), -5.6032836702351645),
            (false_alarms_log10(50, 30, &f), -6.257717478822691),
        ] {
            assert!((got - want).abs() < 1e-9, "{got} {want}");
        }
        // No larger than a sample, or more inliers than pairs: never meaningful.
        assert_eq!(false_alarms_log10(100, 4, &h), f64::INFINITY);
        assert_eq!(false_alarms_log10(10, 11, &h), f64::INFINITY);
        assert!(meaningful(
            &[[true; 20].as_slice(), &[false; 80]].concat(),
            &h
        ));
        assert!(!meaningful(
            &[[true; 6].as_slice(), &[false; 94]].concat(),
            &h
        ));
    }
}
