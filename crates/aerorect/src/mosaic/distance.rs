//! Exact Euclidean distance transform (Felzenszwalb and Huttenlocher's lower envelope of
//! parabolas, one pass along rows and one along columns).

/// For each cell of a `width` x `height` grid, the distance (in cells, between centres) to the
/// nearest cell where `feature` is true; infinity when there is none.
pub(crate) fn distance_to(feature: &[bool], width: usize, height: usize) -> Vec<f32> {
    const FAR: f64 = 1e20;
    let mut d: Vec<f64> = feature.iter().map(|&f| if f { 0.0 } else { FAR }).collect();
    let n = width.max(height);
    let mut scratch = Envelope::new(n);
    let mut line = vec![0.0; n];
    for r in 0..height {
        let row = &mut d[r * width..(r + 1) * width];
        line[..width].copy_from_slice(row);
        scratch.transform(&line[..width], row);
    }
    let mut col = vec![0.0; height];
    for c in 0..width {
        for r in 0..height {
            line[r] = d[r * width + c];
        }
        scratch.transform(&line[..height], &mut col);
        for r in 0..height {
            d[r * width + c] = col[r];
        }
    }
    d.iter()
        .map(|&s| {
            if s >= FAR * 0.5 {
                f32::INFINITY
            } else {
                s.sqrt() as f32
            }
        })
        .collect()
}

/// Buffers of the 1-D squared distance transform.
struct Envelope {
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Envelope {
    fn new(n: usize) -> Self {
        Self {
            v: vec![0; n],
            z: vec![0.0; n + 1],
        }
    }

    /// out[q] = min_p (q - p)^2 + f[p].
    fn transform(&mut self, f: &[f64], out: &mut [f64]) {
        let n = f.len();
        if n == 0 {
            return;
        }
        let (v, z) = (&mut self.v, &mut self.z);
        let mut k = 0usize;
        v[0] = 0;
        z[0] = f64::NEG_INFINITY;
        z[1] = f64::INFINITY;
        let meet = |q: usize, p: usize| {
            let (qf, pf) = (q as f64, p as f64);
            ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf))
        };
        for q in 1..n {
            let mut s = meet(q, v[k]);
            while s <= z[k] {
                k -= 1; // z[0] is -infinity: never below 0
                s = meet(q, v[k]);
            }
            k += 1;
            v[k] = q;
            z[k] = s;
            z[k + 1] = f64::INFINITY;
        }
        let mut k = 0usize;
        for (q, o) in out.iter_mut().enumerate() {
            let qf = q as f64;
            while z[k + 1] < qf {
                k += 1;
            }
            let p = v[k] as f64;
            *o = (qf - p) * (qf - p) + f[v[k]];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_brute_force() {
        let (w, h) = (37, 23);
        let feature: Vec<bool> = (0..w * h)
            .map(|i| (i * 7919 + i / 5 * 31) % 53 == 0)
            .collect();
        let d = distance_to(&feature, w, h);
        for (i, &got) in d.iter().enumerate() {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let want = (0..w * h)
                .filter(|&j| feature[j])
                .map(|j| ((j % w) as f64 - x).hypot((j / w) as f64 - y))
                .fold(f64::INFINITY, f64::min);
            assert!((got as f64 - want).abs() < 1e-4, "{i}: {got} {want}");
        }
        assert!(
            distance_to(&[false; 6], 3, 2)
                .iter()
                .all(|v| v.is_infinite())
        );
    }
}
