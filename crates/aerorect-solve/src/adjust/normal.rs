//! The reduced system's symmetric matrix, accumulated in dense blocks: one per pair of
//! parameter blocks (a frame's free parameters, a camera's, the datum's) that meet through a
//! tie point or a prior.
//!
//! This is the adjustment's hot loop: 14 x 14 entries per observation, and up to 20 x 20 per
//! tie point's Schur update, for tens of thousands of tie points and every step. A map of
//! entries searched per entry spent most of a large flight's solve there; here a block pair is
//! found once per addition and its entries are plain array slots, and [`Gathered`] sums the
//! additions of consecutive points at the same indices before they reach the matrix.
//!
//! Every entry receives the additions made to it that a map of entries would, in the same
//! order, so it holds the same values bit for bit. A block pair is stored whole from its first use: the entries of
//! it that nothing reached are zeros that a map would not have held (the factorisation
//! carries them as explicit zeros; a frame's block is dense in practice anyway).

use std::collections::HashMap;
use std::sync::Arc;

/// Block pairs are hashed by foldhash with a fixed seed: SipHash's cost was 3 % of a large
/// flight's solve, and the map is never exposed to untrusted keys.
type BlockPairs = HashMap<(u32, u32), usize, foldhash::fast::FixedState>;

/// Which parameter block each parameter of the reduced system belongs to. A block's
/// parameters are consecutive.
#[derive(Debug)]
pub(super) struct Blocks {
    /// Per parameter: its block.
    block: Vec<u32>,
    /// Per block: its first parameter; one more entry, the number of parameters.
    start: Vec<usize>,
}

impl Blocks {
    /// Blocks of the given lengths, in parameter order (empty ones are skipped).
    pub fn new(lengths: impl IntoIterator<Item = usize>) -> Self {
        let mut block = Vec::new();
        let mut start = vec![0];
        for len in lengths.into_iter().filter(|&n| n > 0) {
            let b = u32::try_from(start.len() - 1).unwrap_or(u32::MAX);
            block.extend(std::iter::repeat_n(b, len));
            start.push(block.len());
        }
        Self { block, start }
    }

    fn len(&self, b: u32) -> usize {
        self.start[b as usize + 1] - self.start[b as usize]
    }

    /// Parameter `i`'s block and its place in it.
    fn locate(&self, i: usize) -> (u32, usize) {
        let b = self.block[i];
        (b, i - self.start[b as usize])
    }
}

/// A symmetric matrix over the reduced system (both triangles stored), block by block.
#[derive(Debug, Clone)]
pub(super) struct SymBlocks {
    blocks: Arc<Blocks>,
    /// Each block pair's first slot (row-major, rows of the first block).
    base: BlockPairs,
    values: Vec<f64>,
    /// [`SymBlocks::add_dense`]'s runs, kept between calls.
    runs: Vec<Run>,
    /// The last block pairs looked up, by a hash of the pair: consecutive tie points join
    /// the same frames, and the map's lookups were a tenth of the points' elimination.
    recent: [(u32, u32, usize); RECENT],
}

/// Entries of [`SymBlocks::recent`].
const RECENT: usize = 8;

/// Positions of a dense matrix whose indices are consecutive in one block: the first
/// position, how many, the block and the first index's place in it.
#[derive(Debug, Clone, Copy)]
struct Run {
    at: usize,
    len: usize,
    block: u32,
    offset: usize,
}

impl SymBlocks {
    pub fn new(blocks: Arc<Blocks>) -> Self {
        Self {
            blocks,
            base: BlockPairs::default(),
            values: Vec::new(),
            runs: Vec::new(),
            recent: [(u32::MAX, u32::MAX, 0); RECENT],
        }
    }

    /// An empty matrix over the same blocks.
    pub fn empty_like(&self) -> Self {
        Self::new(self.blocks.clone())
    }

    /// The first slot of block pair (a, b), allocated at its first use.
    fn base(&mut self, a: u32, b: u32) -> usize {
        let k = (a as usize * 3 + b as usize) % RECENT;
        let (x, y, s) = self.recent[k];
        if (x, y) == (a, b) {
            return s;
        }
        if let Some(&s) = self.base.get(&(a, b)) {
            self.recent[k] = (a, b, s);
            return s;
        }
        let s = self.values.len();
        let n = self.blocks.len(a) * self.blocks.len(b);
        self.values.resize(s + n, 0.0);
        self.base.insert((a, b), s);
        self.recent[k] = (a, b, s);
        s
    }

    fn slot(&mut self, i: usize, j: usize) -> usize {
        let (a, oi) = self.blocks.locate(i);
        let (b, oj) = self.blocks.locate(j);
        self.base(a, b) + oi * self.blocks.len(b) + oj
    }

    /// Entry (i, j) (zero until something is added).
    pub fn entry(&mut self, i: usize, j: usize) -> &mut f64 {
        let s = self.slot(i, j);
        &mut self.values[s]
    }

    /// Adds the dense n x n matrix `m` (row-major) at rows and columns `idx` (n indices,
    /// each at most once): entry (idx[a], idx[b]) gets m[a n + b]. The indices are taken in
    /// runs that are consecutive in one block (a frame's parameters, in order), so each run
    /// pair's block is looked up once and its rows are added as slices.
    pub fn add_dense(&mut self, idx: &[usize], m: &[f64]) {
        let n = idx.len();
        debug_assert_eq!(m.len(), n * n);
        let mut runs = std::mem::take(&mut self.runs);
        runs.clear();
        for (at, &i) in idx.iter().enumerate() {
            let (block, offset) = self.blocks.locate(i);
            match runs.last_mut() {
                Some(r) if r.block == block && r.offset + r.len == offset => r.len += 1,
                _ => runs.push(Run {
                    at,
                    len: 1,
                    block,
                    offset,
                }),
            }
        }
        for ra in &runs {
            for rb in &runs {
                let base = self.base(ra.block, rb.block);
                let stride = self.blocks.len(rb.block);
                for r in 0..ra.len {
                    let to = base + (ra.offset + r) * stride + rb.offset;
                    let from = (ra.at + r) * n + rb.at;
                    let row = &mut self.values[to..to + rb.len];
                    for (d, v) in row.iter_mut().zip(&m[from..from + rb.len]) {
                        *d += v;
                    }
                }
            }
        }
        self.runs = runs;
    }

    /// Adds every entry of `other` (a matrix over the same blocks) to this one's: a partial
    /// sum of [`Self::add_dense`] calls merged into the whole.
    pub fn add_matrix(&mut self, other: &SymBlocks) {
        for (&(a, b), &from) in &other.base {
            let n = self.blocks.len(a) * self.blocks.len(b);
            let to = self.base(a, b);
            for (d, v) in self.values[to..to + n]
                .iter_mut()
                .zip(&other.values[from..from + n])
            {
                *d += v;
            }
        }
    }

    /// The lower triangle (i >= j) of every stored block pair in compressed columns: each
    /// column's first entry (one more, the count), the entries' rows (ascending within a
    /// column) and values. Built column block by column block from the block pairs, with no
    /// sort of the entries: on the 1,000-frame flight, each step sorted some 700 k triplets
    /// twice (ours by row, faer's by column), about a tenth of the solves' single-threaded
    /// samples in a profile.
    pub fn lower_columns(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let count = self.blocks.start.len() - 1;
        // Per column block, the row blocks that meet it at or below the diagonal, ascending.
        let mut below: Vec<Vec<(u32, usize)>> = vec![Vec::new(); count];
        for (&(a, b), &base) in &self.base {
            if a >= b {
                below[b as usize].push((a, base));
            }
        }
        let n = self.blocks.block.len();
        let (mut col_ptr, mut rows, mut values) =
            (Vec::with_capacity(n + 1), Vec::new(), Vec::new());
        col_ptr.push(0);
        for (b, pairs) in below.iter_mut().enumerate() {
            pairs.sort_unstable();
            let (sb, cols) = (self.blocks.start[b], self.blocks.len(b as u32));
            for oj in 0..cols {
                let j = sb + oj;
                for &(a, base) in pairs.iter() {
                    let sa = self.blocks.start[a as usize];
                    for oi in 0..self.blocks.len(a) {
                        if sa + oi >= j {
                            rows.push(sa + oi);
                            values.push(self.values[base + oi * cols + oj]);
                        }
                    }
                }
                col_ptr.push(rows.len());
            }
        }
        (col_ptr, rows, values)
    }

    /// The entries of the lower triangle (i >= j) of every stored block pair, ordered by
    /// (i, j).
    #[cfg(test)]
    pub fn lower_triplets(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for (&(a, b), &base) in &self.base {
            if a < b {
                continue;
            }
            let (sa, sb) = (self.blocks.start[a as usize], self.blocks.start[b as usize]);
            let cols = self.blocks.len(b);
            for oi in 0..self.blocks.len(a) {
                for oj in 0..cols {
                    let (i, j) = (sa + oi, sb + oj);
                    if i >= j {
                        out.push((i, j, self.values[base + oi * cols + oj]));
                    }
                }
            }
        }
        out.sort_unstable_by_key(|&(i, j, _)| (i, j));
        out
    }
}

/// Index sets [`Gathered`] holds at once: a part's tie points add at one pair's indices, and
/// their observations at each of its two frames'.
const GATHERED: usize = 4;

/// Dense symmetric additions gathered by their indices before they reach a [`SymBlocks`]. A
/// part's tie points come pair by pair, so consecutive points add at the same indices:
/// summed apart in a plain array, a run of them costs one block lookup and one scattered
/// addition instead of one per point (those were a fifth of the 1,000-frame flight's final
/// solve). The set used longest ago goes to the matrix when a new one comes.
#[derive(Debug, Default)]
pub(super) struct Gathered {
    sets: Vec<GatheredSet>,
    clock: u64,
}

#[derive(Debug, Default)]
struct GatheredSet {
    idx: Vec<usize>,
    sum: Vec<f64>,
    used: u64,
}

impl Gathered {
    /// The running sum at `idx` (n x n, row-major; zero where `idx` is new) for the caller to
    /// add to. Only its lower triangle (column <= row) counts: the upper is mirrored from it
    /// when the sum goes to the matrix.
    pub fn sum_at(&mut self, into: &mut SymBlocks, idx: &[usize]) -> &mut [f64] {
        self.clock += 1;
        let k = match self.sets.iter().position(|s| s.idx == idx) {
            Some(k) => k,
            None => self.start(into, idx),
        };
        let set = &mut self.sets[k];
        set.used = self.clock;
        &mut set.sum
    }

    /// A set for `idx` at zero: a new one, or the one used longest ago, sent to `into` first.
    fn start(&mut self, into: &mut SymBlocks, idx: &[usize]) -> usize {
        let k = if self.sets.len() < GATHERED {
            self.sets.push(GatheredSet::default());
            self.sets.len() - 1
        } else {
            let k = (0..GATHERED)
                .min_by_key(|&k| self.sets[k].used)
                .unwrap_or(0);
            self.sets[k].send(into);
            k
        };
        let set = &mut self.sets[k];
        set.idx.clear();
        set.idx.extend_from_slice(idx);
        set.sum.clear();
        set.sum.resize(idx.len() * idx.len(), 0.0);
        k
    }

    /// Whether no sum is held.
    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }

    /// Adds every held sum to `into` and holds none.
    pub fn flush(&mut self, into: &mut SymBlocks) {
        for set in &mut self.sets {
            set.send(into);
        }
        self.sets.clear();
    }
}

impl GatheredSet {
    fn send(&mut self, into: &mut SymBlocks) {
        let n = self.idx.len();
        for a in 0..n {
            for b in 0..a {
                self.sum[b * n + a] = self.sum[a * n + b];
            }
        }
        into.add_dense(&self.idx, &self.sum);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::collections::BTreeMap;

    /// The same additions into block storage and into a map of entries give the same
    /// entries, bit for bit; the stored entries the map lacks are zeros; a matrix of partial
    /// sums merged by `add_matrix` holds the same entries to rounding.
    #[test]
    fn blocks_hold_what_a_map_of_entries_holds() {
        let blocks = Arc::new(Blocks::new([3, 0, 2, 4, 1]));
        let mut sym = SymBlocks::new(blocks.clone());
        let (mut first, mut second) = (SymBlocks::new(blocks.clone()), SymBlocks::new(blocks));
        let mut map: BTreeMap<(usize, usize), f64> = BTreeMap::new();
        // Runs within a block, across blocks, out of order, and one index alone.
        let groups: [&[usize]; 5] = [&[0, 2, 5, 6], &[3, 4, 9], &[1, 7, 8], &[8, 7, 1, 0], &[6]];
        for (g, idx) in groups.iter().enumerate() {
            let n = idx.len();
            let m: Vec<f64> = (0..n * n)
                .map(|k| 0.1 * (g + 1) as f64 / (1 + k / n + 3 * (k % n)) as f64)
                .collect();
            sym.add_dense(idx, &m);
            match g % 2 {
                0 => first.add_dense(idx, &m),
                _ => second.add_dense(idx, &m),
            }
            for (a, i) in idx.iter().enumerate() {
                for (b, j) in idx.iter().enumerate() {
                    *map.entry((*i, *j)).or_insert(0.0) += m[a * n + b];
                }
            }
        }
        *sym.entry(9, 0) -= 0.25;
        *first.entry(9, 0) -= 0.25;
        *map.entry((9, 0)).or_insert(0.0) -= 0.25;
        first.add_matrix(&second);
        let got = sym.lower_triplets();
        let merged = first.lower_triplets();
        assert_eq!(got.len(), merged.len());
        let mut found = 0;
        for (g, m) in got.iter().zip(&merged) {
            assert_eq!((g.0, g.1), (m.0, m.1));
            assert!(
                (g.2 - m.2).abs() <= 1e-15 * g.2.abs().max(1.0),
                "{g:?} {m:?}"
            );
            match map.get(&(g.0, g.1)) {
                Some(v) => {
                    assert_eq!(g.2.to_bits(), v.to_bits(), "{g:?}");
                    found += 1;
                }
                None => assert_eq!(g.2, 0.0, "{g:?}"),
            }
        }
        assert_eq!(found, map.keys().filter(|(i, j)| i >= j).count());
    }

    /// Symmetric additions gathered by their index sets give the matrix that adding each
    /// directly gives, to rounding: runs at one set, sets interleaved, more sets than are held
    /// (the oldest sent and started again), and a set met again after it was sent. Only the
    /// lower triangle of each sum counts.
    #[test]
    fn gathered_additions_are_the_direct_ones() {
        let blocks = Arc::new(Blocks::new([6, 6, 6, 6, 6, 2]));
        let sets: [&[usize]; 6] = [
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11],
            &[6, 7, 8, 9, 10, 11],
            &[0, 1, 2, 3, 4, 5],
            &[12, 13, 14, 15, 16, 17, 30, 31],
            &[18, 19, 20, 21, 22, 23],
            &[24, 25, 26, 27, 28, 29, 31],
        ];
        let order = [0, 0, 0, 1, 2, 1, 2, 3, 4, 5, 5, 0, 1, 3, 3, 4, 2, 0];
        let (mut direct, mut into) = (SymBlocks::new(blocks.clone()), SymBlocks::new(blocks));
        let mut gathered = Gathered::default();
        for (k, &s) in order.iter().enumerate() {
            let idx = sets[s];
            let n = idx.len();
            let v = |a: usize, b: usize| ((k * 7 + a.max(b) * 3 + a.min(b)) as f64).sin();
            let m: Vec<f64> = (0..n * n).map(|e| v(e / n, e % n)).collect();
            direct.add_dense(idx, &m);
            let sum = gathered.sum_at(&mut into, idx);
            for a in 0..n {
                for b in 0..n {
                    // The upper triangle is not read: what is put there must not count.
                    sum[a * n + b] += if b <= a { m[a * n + b] } else { 1e6 };
                }
            }
        }
        gathered.flush(&mut into);
        let (want, got) = (direct.lower_triplets(), into.lower_triplets());
        assert_eq!(want.len(), got.len());
        assert!(want.iter().any(|w| w.2 != 0.0 && w.0 != w.1));
        // Both triangles, entry by entry.
        for i in 0..32 {
            for j in 0..32 {
                let (w, g) = (*direct.entry(i, j), *into.entry(i, j));
                assert!(
                    (w - g).abs() <= 1e-14 * w.abs().max(1.0),
                    "({i}, {j}): {w} {g}"
                );
            }
        }
    }
}
