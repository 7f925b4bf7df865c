//! Exact Euclidean distance transform: each cell's distance to the nearest feature in its
//! column (two scans, a row of cells at a time), then along rows the least of the squared
//! distances those make. Within a small cap a row's cells take the least over the columns at
//! most the cap away, a pass per offset; beyond it, the lower envelope of the parabolas
//! (Felzenszwalb and Huttenlocher; the column pass of a binary image needs no envelope, as in
//! Meijster et al.).

/// Caps up to this (cells) take the per-offset row pass: `2 cap + 1` passes of a few
/// instructions per cell against the envelope's divisions, a tenth of the mosaic's weights'
/// time at the default feather of 16.
const ROW_PASS_MAX_CAP: usize = 32;

/// For each cell of a grid `width` cells wide (`feature` row-major), the distance (in cells,
/// between centres) to the nearest cell where `feature` is true, where that is at most `cap`;
/// infinity where it is more (or there is no feature). Beyond `cap` nothing is computed: a row whose columns have
/// no feature within `cap`, and the part of a row farther than `cap` from every such column.
pub(crate) fn distance_within(feature: &[bool], width: usize, cap: usize) -> Vec<f32> {
    let mut out = vec![f32::INFINITY; feature.len()];
    if !feature.iter().any(|&f| f) {
        return out;
    }
    let along = column_distances(feature, width, cap);
    if cap <= ROW_PASS_MAX_CAP {
        rows_by_offsets(&along, width, cap, &mut out);
    } else {
        rows_by_envelope(&along, width, cap, &mut out);
    }
    out
}

/// The row pass for a small `cap`: each cell's least `dx^2 + along^2` over the columns at
/// most `cap` away, in integers (at most `2 cap^2`). A row's pass covers only the cells within
/// `cap` of its first and last column with a distance (beyond, every term is over the cap).
fn rows_by_offsets(along: &[u32], width: usize, cap: usize, out: &mut [f32]) {
    const FAR: u32 = u32::MAX / 4;
    let cap2 = (cap * cap) as u32;
    // The span's squared column distances, with `cap` more cells either side.
    let mut g = vec![FAR; width + 2 * cap];
    let mut best = vec![FAR; width];
    for (row, dst) in along.chunks_exact(width).zip(out.chunks_exact_mut(width)) {
        let Some(std::ops::Range { start: lo, end: hi }) = reach(row, cap) else {
            continue;
        };
        let n = hi - lo;
        // g[i] is column lo - cap + i.
        g[..n + 2 * cap].fill(FAR);
        let (c0, c1) = (lo.saturating_sub(cap), (hi + cap).min(width));
        for (gi, &d) in g[c0 + cap - lo..c1 + cap - lo].iter_mut().zip(&row[c0..c1]) {
            *gi = if d == u32::MAX { FAR } else { d * d };
        }
        let best = &mut best[..n];
        best.fill(FAR);
        for dx in 0..=2 * cap {
            let dd = (dx.abs_diff(cap) * dx.abs_diff(cap)) as u32;
            for (b, &v) in best.iter_mut().zip(&g[dx..dx + n]) {
                *b = (*b).min(v + dd);
            }
        }
        // The row's cells are infinity until here: each is written (a conditional write became
        // masked stores, slow on AMD's cores).
        for (o, &s) in dst[lo..hi].iter_mut().zip(best.iter()) {
            *o = match s <= cap2 {
                true => f64::from(s).sqrt() as f32,
                false => f32::INFINITY,
            };
        }
    }
}

/// The cells of a row of column distances that can lie within `cap` of a feature: from `cap`
/// before its first column with a distance to `cap` after its last (beyond, every term of the
/// row pass is over the cap); `None` when no column has one.
fn reach(row: &[u32], cap: usize) -> Option<std::ops::Range<usize>> {
    let first = row.iter().position(|&d| d != u32::MAX)?;
    let last = row.iter().rposition(|&d| d != u32::MAX)?;
    let end = last.saturating_add(cap).saturating_add(1).min(row.len());
    Some(first.saturating_sub(cap)..end)
}

/// The row pass by the lower envelope of the parabolas: any `cap`.
fn rows_by_envelope(along: &[u32], width: usize, cap: usize, out: &mut [f32]) {
    const FAR: f64 = 1e20;
    let mut scratch = Envelope::new(width);
    let (mut f, mut row_out) = (vec![0.0; width], vec![0.0; width]);
    let cap2 = (cap as f64) * (cap as f64);
    for (row, dst) in along.chunks_exact(width).zip(out.chunks_exact_mut(width)) {
        let Some(span) = reach(row, cap) else {
            continue;
        };
        for (fi, &d) in f[span.clone()].iter_mut().zip(&row[span.clone()]) {
            *fi = if d == u32::MAX {
                FAR
            } else {
                f64::from(d) * f64::from(d)
            };
        }
        let n = span.len();
        scratch.transform(&f[span.clone()], &mut row_out[..n]);
        for (o, &s) in dst[span].iter_mut().zip(&row_out[..n]) {
            if s <= cap2 {
                *o = s.sqrt() as f32;
            }
        }
    }
}

/// Each cell's distance (cells) to the nearest feature in its column, `u32::MAX` when that is
/// more than `cap`: down the grid, then up, a whole row at a time.
fn column_distances(feature: &[bool], width: usize, cap: usize) -> Vec<u32> {
    let mut d = vec![u32::MAX; feature.len()];
    let mut above = vec![u32::MAX; width];
    for (row, feat) in d.chunks_exact_mut(width).zip(feature.chunks_exact(width)) {
        for ((v, &f), a) in row.iter_mut().zip(feat).zip(&above) {
            *v = if f { 0 } else { a.saturating_add(1) };
        }
        above.copy_from_slice(row);
    }
    // Capped on the way up: a distance over the cap stays over it one row on (and a
    // conditional write of the cap's marker became masked stores, slow on AMD's cores).
    let cap = u32::try_from(cap).unwrap_or(u32::MAX - 1);
    let mut below = vec![u32::MAX; width];
    for row in d.chunks_exact_mut(width).rev() {
        for (v, b) in row.iter_mut().zip(&below) {
            let m = (*v).min(b.saturating_add(1));
            *v = if m > cap { u32::MAX } else { m };
        }
        below.copy_from_slice(row);
    }
    d
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
    fn equals_brute_force_within_the_cap() {
        let (w, h) = (37, 23);
        let feature: Vec<bool> = (0..w * h)
            .map(|i| (i * 7919 + i / 5 * 31) % 53 == 0)
            .collect();
        let mut capped = 0;
        // Both row passes: by offsets up to ROW_PASS_MAX_CAP, by the envelope beyond.
        for cap in [
            0,
            1,
            3,
            8,
            ROW_PASS_MAX_CAP,
            ROW_PASS_MAX_CAP + 1,
            usize::MAX,
        ] {
            let d = distance_within(&feature, w, cap);
            for (i, &got) in d.iter().enumerate() {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let want = (0..w * h)
                    .filter(|&j| feature[j])
                    .map(|j| ((j % w) as f64 - x).hypot((j / w) as f64 - y))
                    .fold(f64::INFINITY, f64::min);
                if want > cap as f64 {
                    assert!(got.is_infinite(), "cap {cap}, {i}: {got} {want}");
                    capped += 1;
                } else {
                    assert!(
                        (got as f64 - want).abs() < 1e-4,
                        "cap {cap}, {i}: {got} {want}"
                    );
                }
            }
        }
        assert!(capped > w * h, "{capped}");
        let none = distance_within(&[false; 6], 3, usize::MAX);
        assert!(none.iter().all(|v| v.is_infinite()));
    }
}
