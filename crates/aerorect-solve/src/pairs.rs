//! Candidate frame pairs for matching, from the frames' GPS positions and, where known, their
//! predicted ground footprints (as ODM's matcher-neighbors does: the k nearest neighbours by
//! position, the Delaunay neighbours, and any pair whose footprints overlap).

use delaunator::{Point, triangulate};
use rayon::prelude::*;
use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum PairError {
    #[error("frame {index} has a position that is not finite: ({x}, {y})")]
    NotFinite { index: usize, x: f64, y: f64 },
    #[error("{footprints} footprints given for {frames} frames")]
    FootprintCount { footprints: usize, frames: usize },
    #[error("footprint of frame {index} has {corners} corners, at least 3 needed")]
    FootprintCorners { index: usize, corners: usize },
}

/// Which pairs to propose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairOptions {
    /// Each frame is paired with this many nearest frames by position (0: none).
    pub neighbours: usize,
    /// Also pair the frames joined by an edge of the Delaunay triangulation of the positions.
    pub delaunay: bool,
    /// Drop pairs farther apart than this (in the positions' units); `None` keeps all.
    pub max_distance: Option<f64>,
}

impl Default for PairOptions {
    fn default() -> Self {
        Self {
            neighbours: 8,
            delaunay: true,
            max_distance: None,
        }
    }
}

/// The pairs (i, j), i < j, sorted and without repeats: the union of the k nearest neighbours of
/// every frame, the Delaunay edges, and (when `footprints` is given, one convex polygon per
/// frame in the positions' coordinates) every pair whose footprints overlap; pairs beyond
/// `max_distance` are dropped (footprint overlaps are always kept).
pub fn candidate_pairs(
    centres: &[[f64; 2]],
    footprints: Option<&[Vec<[f64; 2]>]>,
    opts: &PairOptions,
) -> Result<Vec<(usize, usize)>, PairError> {
    if let Some((index, p)) = centres
        .iter()
        .enumerate()
        .find(|(_, p)| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(PairError::NotFinite {
            index,
            x: p[0],
            y: p[1],
        });
    }
    let near = |i: usize, j: usize| {
        opts.max_distance
            .is_none_or(|d| dist2(centres[i], centres[j]) <= d * d)
    };
    let mut pairs: Vec<(usize, usize)> = nearest_neighbours(centres, opts.neighbours)
        .into_iter()
        .chain(if opts.delaunay {
            delaunay_edges(centres)
        } else {
            vec![]
        })
        .filter(|&(i, j)| near(i, j))
        .collect();
    if let Some(fp) = footprints {
        pairs.extend(overlapping(fp, centres.len())?);
    }
    for p in &mut pairs {
        *p = (p.0.min(p.1), p.0.max(p.1));
    }
    pairs.sort_unstable();
    pairs.dedup();
    Ok(pairs)
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Each frame with its `k` nearest others (ties by index), by a sweep along x: frames sorted
/// by x are visited outwards from each frame until the x gap alone exceeds the k-th distance.
pub fn nearest_neighbours(centres: &[[f64; 2]], k: usize) -> Vec<(usize, usize)> {
    let n = centres.len();
    if k == 0 || n < 2 {
        return vec![];
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| centres[a][0].total_cmp(&centres[b][0]).then(a.cmp(&b)));
    let mut pairs = Vec::with_capacity(n * k);
    for (rank, &i) in order.iter().enumerate() {
        // The best k so far, sorted by (distance, index).
        let mut best: Vec<(f64, usize)> = Vec::with_capacity(k + 1);
        let consider = |j: usize, best: &mut Vec<(f64, usize)>| {
            let d = dist2(centres[i], centres[j]);
            let pos = best.partition_point(|&(e, m)| (e, m) < (d, j));
            if pos < k {
                best.insert(pos, (d, j));
                best.truncate(k);
            }
        };
        let (mut lo, mut hi) = (rank, rank + 1);
        loop {
            let bound = if best.len() == k {
                best[k - 1].0
            } else {
                f64::INFINITY
            };
            let gap = |r: usize| (centres[order[r]][0] - centres[i][0]).powi(2);
            let left = (lo > 0 && gap(lo - 1) <= bound).then(|| lo - 1);
            let right = (hi < n && gap(hi) <= bound).then_some(hi);
            match (left, right) {
                (None, None) => break,
                (l, r) => {
                    if let Some(l) = l {
                        consider(order[l], &mut best);
                        lo = l;
                    }
                    if let Some(r) = r {
                        consider(order[r], &mut best);
                        hi = r + 1;
                    }
                }
            }
        }
        pairs.extend(best.iter().map(|&(_, j)| (i, j)));
    }
    pairs
}

/// The edges of the Delaunay triangulation (none when all frames are collinear: then the
/// nearest neighbours are the pairs).
pub fn delaunay_edges(centres: &[[f64; 2]]) -> Vec<(usize, usize)> {
    let points: Vec<Point> = centres.iter().map(|p| Point { x: p[0], y: p[1] }).collect();
    let t = triangulate(&points);
    t.triangles
        .chunks_exact(3)
        .flat_map(|tri| [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])])
        .collect()
}

/// Pairs whose convex footprints overlap (separating-axis test), pruned by bounding boxes
/// sorted along x.
fn overlapping(fp: &[Vec<[f64; 2]>], frames: usize) -> Result<Vec<(usize, usize)>, PairError> {
    if fp.len() != frames {
        return Err(PairError::FootprintCount {
            footprints: fp.len(),
            frames,
        });
    }
    if let Some((index, f)) = fp.iter().enumerate().find(|(_, f)| f.len() < 3) {
        return Err(PairError::FootprintCorners {
            index,
            corners: f.len(),
        });
    }
    let bbox = |f: &Vec<[f64; 2]>| {
        f.iter()
            .fold([f64::MAX, f64::MAX, f64::MIN, f64::MIN], |b, p| {
                [
                    b[0].min(p[0]),
                    b[1].min(p[1]),
                    b[2].max(p[0]),
                    b[3].max(p[1]),
                ]
            })
    };
    let boxes: Vec<[f64; 4]> = fp.iter().map(bbox).collect();
    let mut order: Vec<usize> = (0..frames).collect();
    order.sort_by(|&a, &b| boxes[a][0].total_cmp(&boxes[b][0]));
    // Frames in parallel: a DEM's footprints have 256 corners, and the 1,000-frame
    // simulation's pairs whose boxes overlap took 2 s on one core.
    let (boxes, order) = (&boxes, &order);
    let out = order
        .par_iter()
        .enumerate()
        .flat_map_iter(|(r, &i)| {
            order[r + 1..]
                .iter()
                .take_while(move |&&j| boxes[j][0] <= boxes[i][2])
                .filter(move |&&j| {
                    boxes[j][1] <= boxes[i][3]
                        && boxes[i][1] <= boxes[j][3]
                        && convex_overlap(&fp[i], &fp[j])
                })
                .map(move |&j| (i, j))
        })
        .collect();
    Ok(out)
}

/// Whether two convex polygons (either winding) share any point: no edge normal of either
/// separates their projections.
pub fn convex_overlap(a: &[[f64; 2]], b: &[[f64; 2]]) -> bool {
    let separated_by = |poly: &[[f64; 2]]| {
        (0..poly.len()).any(|k| {
            let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
            let axis = [q[1] - p[1], p[0] - q[0]];
            let range = |s: &[[f64; 2]]| {
                s.iter()
                    .map(|v| v[0] * axis[0] + v[1] * axis[1])
                    .fold((f64::MAX, f64::MIN), |(lo, hi), d| (lo.min(d), hi.max(d)))
            };
            let ((a0, a1), (b0, b1)) = (range(a), range(b));
            a1 < b0 || b1 < a0
        })
    };
    !separated_by(a) && !separated_by(b)
}
