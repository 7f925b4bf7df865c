//! The paper JTC's joint image: its geometry (6w x 2h, a half spectrum of 3w + 1 columns) and
//! its power spectrum's filtered columns and threshold sample.

/// The joint image's geometry: 6w x 2h, half spectrum of 3w + 1 columns of 2h.
#[derive(Debug, Clone, Copy)]
pub(super) struct Joint {
    pub(super) w: usize,
    pub(super) h: usize,
    pub(super) filter: bool,
}

impl Joint {
    pub(super) fn hh(self) -> usize {
        2 * self.h
    }

    pub(super) fn hw(self) -> usize {
        3 * self.w + 1
    }

    /// Whether column u's filtered values need no reflection (and there is a filter).
    fn interior(self, u: usize) -> bool {
        self.filter && u > 0 && u < 3 * self.w
    }

    /// E(u, v) = 2 P(u, v) - P(u - 1, v) - P(u + 1, v) with P(-u, -v) = P(u, v) beyond the half
    /// spectrum's ends (or P without the filter), at one frequency of the power spectrum `p`.
    fn filtered(self, p: &[f32], u: usize, v: usize) -> f32 {
        let (hh, hw) = (self.hh(), self.hw());
        if !self.filter {
            return p[u * hh + v];
        }
        let mirror = || (hh - v) % hh;
        let lo = if u == 0 {
            p[hh + mirror()]
        } else {
            p[(u - 1) * hh + v]
        };
        let hi = if u + 1 == hw {
            p[(hw - 2) * hh + mirror()]
        } else {
            p[(u + 1) * hh + v]
        };
        2.0 * p[u * hh + v] - lo - hi
    }

    /// Columns u - 1, u and u + 1 of the power spectrum `p` (u an interior column).
    fn neighbours(self, p: &[f32], u: usize) -> [&[f32]; 3] {
        let hh = self.hh();
        [u - 1, u, u + 1].map(|c| &p[c * hh..(c + 1) * hh])
    }

    /// Column u of the filtered spectrum.
    pub(super) fn filtered_column(self, p: &[f32], u: usize, out: &mut [f32]) {
        let hh = self.hh();
        if !self.filter {
            out.copy_from_slice(&p[u * hh..(u + 1) * hh]);
        } else if self.interior(u) {
            let [lo, mid, hi] = self.neighbours(p, u);
            for (((e, &b), &a), &c) in out.iter_mut().zip(mid).zip(lo).zip(hi) {
                *e = 2.0 * b - a - c;
            }
        } else {
            for (v, e) in out.iter_mut().enumerate() {
                *e = self.filtered(p, u, v);
            }
        }
    }

    /// Appends column u's share of the threshold's sample: the filtered values at every 8th
    /// index u * 2h + v of the u-major half spectrum.
    pub(super) fn sample_column(self, p: &[f32], u: usize, sample: &mut Vec<f32>) {
        let hh = self.hh();
        let start = (8 - (u * hh) % 8) % 8;
        if self.interior(u) {
            let [lo, mid, hi] = self.neighbours(p, u);
            sample.extend((start..hh).step_by(8).map(|v| 2.0 * mid[v] - lo[v] - hi[v]));
        } else {
            sample.extend((start..hh).step_by(8).map(|v| self.filtered(p, u, v)));
        }
    }
}
