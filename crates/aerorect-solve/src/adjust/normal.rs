//! The reduced system's symmetric matrix, accumulated in dense blocks: one per pair of
//! parameter blocks (a frame's free parameters, a camera's, the datum's) that meet through a
//! tie point or a prior.
//!
//! This is the adjustment's hot loop: 14 x 14 entries per observation, and up to 20 x 20 per
//! tie point's Schur update, for tens of thousands of tie points and every step. A map of
//! entries searched per entry spent most of a large flight's solve there; here a block pair is
//! found once per observation and its entries are plain array slots.
//!
//! It is bit for bit the matrix a map of entries gives: every entry receives the same additions
//! in the same order, and only entries that were written become the sparse matrix (a block's
//! slots that no observation reached stay out of it, as a map would never have held them).

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
    written: Vec<bool>,
    /// [`SymBlocks::add_outer`]'s working space, kept between calls (it allocated four
    /// vectors per call: a fifth of a large flight's solve went to the allocator).
    scratch: OuterScratch,
}

/// Per call of [`SymBlocks::add_outer`]: the call's distinct blocks, each position's place
/// among them and in its block, the blocks' lengths and the block pairs' first slots.
#[derive(Debug, Clone, Default)]
struct OuterScratch {
    here: Vec<u32>,
    /// (position in `idx`, place among `here`, place in the block).
    located: Vec<(usize, usize, usize)>,
    lens: Vec<usize>,
    bases: Vec<usize>,
}

impl SymBlocks {
    pub fn new(blocks: Arc<Blocks>) -> Self {
        Self {
            blocks,
            base: BlockPairs::default(),
            values: Vec::new(),
            written: Vec::new(),
            scratch: OuterScratch::default(),
        }
    }

    /// An empty matrix over the same blocks.
    pub fn empty_like(&self) -> Self {
        Self::new(self.blocks.clone())
    }

    /// The first slot of block pair (a, b), allocated at its first use.
    fn base(&mut self, a: u32, b: u32) -> usize {
        if let Some(&s) = self.base.get(&(a, b)) {
            return s;
        }
        let s = self.values.len();
        let n = self.blocks.len(a) * self.blocks.len(b);
        self.values.resize(s + n, 0.0);
        self.written.resize(s + n, false);
        self.base.insert((a, b), s);
        s
    }

    fn slot(&mut self, i: usize, j: usize) -> usize {
        let (a, oi) = self.blocks.locate(i);
        let (b, oj) = self.blocks.locate(j);
        self.base(a, b) + oi * self.blocks.len(b) + oj
    }

    /// Entry (i, j), written (zero until something is added).
    pub fn entry(&mut self, i: usize, j: usize) -> &mut f64 {
        let s = self.slot(i, j);
        self.written[s] = true;
        &mut self.values[s]
    }

    /// Adds `value(a, b)` to entry (idx[a], idx[b]) for every pair of positions that hold an
    /// index, rows outer, columns inner (the order a loop over entries would add them in).
    /// The first slots of the call's block pairs are looked up once, before the loop.
    pub fn add_outer(&mut self, idx: &[Option<usize>], mut value: impl FnMut(usize, usize) -> f64) {
        let mut sc = std::mem::take(&mut self.scratch);
        // Each position that holds an index: the position, its block as its place among
        // the call's distinct blocks, and its place in the block. Positions without one
        // are dropped here (an observation holds 3 of its 14 when only attitudes are
        // solved for, and the double loop below ran over all 14 x 14).
        sc.here.clear();
        sc.located.clear();
        for (a, i) in idx.iter().enumerate() {
            let Some(i) = *i else { continue };
            let (b, o) = self.blocks.locate(i);
            let u = sc.here.iter().position(|&x| x == b).unwrap_or_else(|| {
                sc.here.push(b);
                sc.here.len() - 1
            });
            sc.located.push((a, u, o));
        }
        let n = sc.here.len();
        sc.lens.clear();
        sc.lens.extend(sc.here.iter().map(|&b| self.blocks.len(b)));
        sc.bases.clear();
        for &ba in &sc.here {
            for &bb in &sc.here {
                sc.bases.push(self.base(ba, bb));
            }
        }
        for &(a, ua, oa) in &sc.located {
            let row = &sc.bases[ua * n..ua * n + n];
            for &(b, ub, ob) in &sc.located {
                let s = row[ub] + oa * sc.lens[ub] + ob;
                self.values[s] += value(a, b);
                self.written[s] = true;
            }
        }
        self.scratch = sc;
    }

    /// Adds every written entry of `other` (a matrix over the same blocks) to this one's,
    /// and marks it written: a partial sum of [`Self::add_outer`] calls merged into the whole.
    pub fn add_matrix(&mut self, other: &SymBlocks) {
        for (&(a, b), &from) in &other.base {
            let n = self.blocks.len(a) * self.blocks.len(b);
            let to = self.base(a, b);
            let (values, written) = (
                &other.values[from..from + n],
                &other.written[from..from + n],
            );
            for (k, (&v, &w)) in values.iter().zip(written).enumerate() {
                if w {
                    self.values[to + k] += v;
                    self.written[to + k] = true;
                }
            }
        }
    }

    /// The written entries of the lower triangle (i >= j), ordered by (i, j).
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
                    let s = base + oi * cols + oj;
                    let (i, j) = (sa + oi, sb + oj);
                    if self.written[s] && i >= j {
                        out.push((i, j, self.values[s]));
                    }
                }
            }
        }
        out.sort_unstable_by_key(|&(i, j, _)| (i, j));
        out
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use std::collections::BTreeMap;

    /// The same additions into block storage and into a map of entries give the same
    /// entries, bit for bit, and the same set of written ones.
    #[test]
    fn blocks_hold_what_a_map_of_entries_holds() {
        let blocks = Arc::new(Blocks::new([3, 0, 2, 4, 1]));
        let mut sym = SymBlocks::new(blocks);
        let mut map: BTreeMap<(usize, usize), f64> = BTreeMap::new();
        let groups: [&[Option<usize>]; 4] = [
            &[Some(0), None, Some(2), Some(5), Some(6)],
            &[Some(3), Some(4), Some(9)],
            &[Some(1), Some(7), None, Some(8)],
            &[Some(0), Some(2), Some(5)],
        ];
        for (g, idx) in groups.iter().enumerate() {
            let value = |a: usize, b: usize| 0.1 * (g + 1) as f64 / (1 + a + 3 * b) as f64;
            sym.add_outer(idx, value);
            for (a, i) in idx.iter().enumerate() {
                for (b, j) in idx.iter().enumerate() {
                    if let (Some(i), Some(j)) = (i, j) {
                        *map.entry((*i, *j)).or_insert(0.0) += value(a, b);
                    }
                }
            }
        }
        *sym.entry(9, 0) -= 0.25;
        *map.entry((9, 0)).or_insert(0.0) -= 0.25;
        let want: Vec<(usize, usize, f64)> = map
            .iter()
            .filter(|((i, j), _)| i >= j)
            .map(|(&(i, j), &v)| (i, j, v))
            .collect();
        let got = sym.lower_triplets();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(&want) {
            assert_eq!((g.0, g.1), (w.0, w.1));
            assert_eq!(g.2.to_bits(), w.2.to_bits());
        }
    }
}
