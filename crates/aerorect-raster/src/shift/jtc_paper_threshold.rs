//! The paper JTC's threshold: the median of the filtered spectrum's sample, selected on
//! integer keys in `f32::total_cmp`'s order.

/// The element of rank n / 2 of `sample` in `f32::total_cmp`'s order (its upper median), selected
/// on `ordered_key`s in `keys` (integer comparisons instead of `total_cmp`'s).
pub(super) fn median(sample: &[f32], keys: &mut Vec<u32>) -> f32 {
    keys.clear();
    keys.extend(sample.iter().map(|&v| ordered_key(v)));
    let n = keys.len();
    from_ordered_key(*keys.select_nth_unstable(n / 2).1)
}

/// An f32's bits as a u32 whose order is `f32::total_cmp`'s: negatives' bits flipped, the sign
/// bit set on the others.
fn ordered_key(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// The f32 of an `ordered_key`.
fn from_ordered_key(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `median` against sorting with `total_cmp`, on samples with ties, signed zeros,
    /// infinities and odd and even lengths; the keys keep `total_cmp`'s order.
    #[test]
    fn the_median_is_total_cmp_s() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let special = [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE,
            -1e-40,
        ];
        let mut keys = Vec::new();
        for n in 1..300 {
            let sample: Vec<f32> = (0..n)
                .map(|i| match i % 5 {
                    0 => special[rng.random_range(0..special.len())],
                    1 => rng.random_range(-3..3) as f32,
                    _ => rng.random_range(-1e6f32..1e6),
                })
                .collect();
            let mut sorted = sample.clone();
            sorted.sort_by(f32::total_cmp);
            let m = median(&sample, &mut keys);
            assert_eq!(m.to_bits(), sorted[n / 2].to_bits(), "n {n}");
            for w in sorted.windows(2) {
                assert!(ordered_key(w[0]) <= ordered_key(w[1]), "{} {}", w[0], w[1]);
            }
        }
    }
}
