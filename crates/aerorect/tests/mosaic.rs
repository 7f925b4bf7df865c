//! Mosaics of frames simulated from one ground texture: the mosaic is the texture where
//! covered, each cell comes from the frame a brute-force score picks, feathering leaves no step
//! larger than the blend allows, and the tile-by-tile path equals a whole-mosaic composite
//! computed here the slow way.
#![allow(clippy::unwrap_used)]

use aerorect::core::ImageSize;
use aerorect::geo::Pose;
use aerorect::mosaic::{
    Blend, LATTICE_MARGIN_PX, MosaicOptions, MosaicPlan, SCORE_LATTICE, Window,
};
use aerorect::raster::AnyRaster;

mod mosaic_scene;
use mosaic_scene::*;

/// Brute-force scores from the poses by the lattice rule of `mosaic::score`: each cell's
/// corners projected through the camera at nodes every `SCORE_LATTICE` cells of the frame's
/// grid (and its last row and column), blended bilinearly where all four nodes of a block lie
/// `LATTICE_MARGIN_PX` inside the frame, none where all four lie that far beyond one edge, each
/// cell on its own elsewhere.
fn brute_scores(s: &Scene, plan: &MosaicPlan) -> Vec<Vec<f64>> {
    let g = plan.grid;
    let (w, h) = (s.cam.size.width as f64, s.cam.size.height as f64);
    let project = |p: &Pose, x: f64, y: f64| {
        s.cam
            .pixel_from_camera_point(p.camera_from_world([x, y, 0.0]))
            .unwrap()
    };
    // The frame pixel of a frame-grid cell's centre, and its exact score where it is inside.
    let exact = |p: &Pose, fg: &aerorect::geo::OrthoGrid, fc: usize, fr: usize| {
        let [x, y] = fg.centre_of(fc as f64, fr as f64);
        let q = project(p, x, y);
        if !((-0.5..w - 0.5).contains(&q[0]) && (-0.5..h - 0.5).contains(&q[1])) {
            return (q, None);
        }
        let e = 0.5 * GSD;
        let k: Vec<[f64; 2]> = [[-e, e], [e, e], [e, -e], [-e, -e]]
            .iter()
            .map(|d| project(p, x + d[0], y + d[1]))
            .collect();
        let area = 0.5
            * (0..4)
                .map(|i| k[i][0] * k[(i + 1) % 4][1] - k[(i + 1) % 4][0] * k[i][1])
                .sum::<f64>()
                .abs();
        let tan = (x - p.centre[0]).hypot(y - p.centre[1]) / p.centre[2];
        (q, Some(GSD / area.sqrt() * tan.hypot(1.0)))
    };
    let (l, m) = (SCORE_LATTICE, LATTICE_MARGIN_PX);
    let block = |i: usize, n: usize| {
        let a = i / l * l;
        let b = (a + l).min(n - 1);
        (
            a,
            b,
            if b > a {
                (i - a) as f64 / (b - a) as f64
            } else {
                0.0
            },
        )
    };
    s.poses
        .iter()
        .zip(&s.frames)
        .map(|(p, f)| {
            let fg = f.plan.grid;
            (0..g.size.pixels())
                .map(|i| {
                    let (c, r) = ((i % g.size.width) as f64, (i / g.size.width) as f64);
                    let [x, y] = g.centre_of(c, r);
                    let (fc, fr) = (
                        (x - fg.top_left[0]) / GSD - 0.5,
                        (fg.top_left[1] - y) / GSD - 0.5,
                    );
                    let in_grid = fc > -0.1
                        && fr > -0.1
                        && fc < fg.size.width as f64 - 0.9
                        && fr < fg.size.height as f64 - 0.9;
                    if !in_grid {
                        return f64::INFINITY;
                    }
                    let (fc, fr) = (fc.round() as usize, fr.round() as usize);
                    let ((c0, c1, tx), (r0, r1, ty)) =
                        (block(fc, fg.size.width), block(fr, fg.size.height));
                    let nodes: Vec<_> = [(c0, r0), (c1, r0), (c0, r1), (c1, r1)]
                        .iter()
                        .map(|&(a, b)| exact(p, &fg, a, b))
                        .collect();
                    let inside = |q: [f64; 2]| {
                        q[0] >= m - 0.5
                            && q[0] <= w - 0.5 - m
                            && q[1] >= m - 0.5
                            && q[1] <= h - 0.5 - m
                    };
                    let beyond = [
                        nodes.iter().all(|n| n.0[0] <= -0.5 - m),
                        nodes.iter().all(|n| n.0[0] >= w - 0.5 + m),
                        nodes.iter().all(|n| n.0[1] <= -0.5 - m),
                        nodes.iter().all(|n| n.0[1] >= h - 0.5 + m),
                    ];
                    if beyond.contains(&true) {
                        return f64::INFINITY;
                    }
                    if nodes.iter().all(|n| inside(n.0) && n.1.is_some()) {
                        let v: Vec<f64> = nodes.iter().map(|n| n.1.unwrap()).collect();
                        let top = v[0] * (1.0 - tx) + v[1] * tx;
                        let bottom = v[2] * (1.0 - tx) + v[3] * tx;
                        return top * (1.0 - ty) + bottom * ty;
                    }
                    exact(p, &fg, fc, fr).1.unwrap_or(f64::INFINITY)
                })
                .collect()
        })
        .collect()
}

#[test]
fn each_cell_comes_from_the_frame_with_the_best_brute_force_score() {
    let s = scene([0.0; 3]);
    let plan = MosaicPlan::new(s.frames.clone(), GSD, MosaicOptions::default()).unwrap();
    let size = plan.grid.size;
    let labels = plan.labels(Window {
        col0: 0,
        row0: 0,
        size,
    });
    let scores = brute_scores(&s, &plan);
    let (mut checked, mut per_frame) = (0, [0usize; 3]);
    for (i, l) in labels.iter().enumerate() {
        let mut order: Vec<(f64, usize)> = (0..3)
            .map(|k| (scores[k][i], k))
            .filter(|p| p.0.is_finite())
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        match order.first() {
            None => assert_eq!(*l, None, "cell {i}: no frame covers it"),
            Some(&(best, k)) => {
                if order.len() > 1 && order[1].0 - best < 1e-9 * best {
                    continue; // a tie: either is right
                }
                assert_eq!(*l, Some(k), "cell {i}: scores {order:?}");
                per_frame[k] += 1;
                checked += 1;
            }
        }
    }
    println!(
        "mosaic {} x {}, cells per frame {per_frame:?}",
        size.width, size.height
    );
    assert!(checked > 50_000, "{checked}");
    assert!(per_frame.iter().all(|&n| n > 5_000), "{per_frame:?}");
}

#[test]
fn the_mosaic_is_the_ground_where_covered() {
    let s = scene([0.0; 3]);
    for blend in [Blend::None, Blend::Feather] {
        let opts = MosaicOptions {
            blend,
            tile_px: 128,
            ..MosaicOptions::default()
        };
        let (plan, v, a, _) = run_all(&s, opts);
        let mut err: Vec<f64> = Vec::new();
        for i in 0..v.len() {
            let (c, r) = (
                (i % plan.grid.size.width) as f64,
                (i / plan.grid.size.width) as f64,
            );
            if a[i] > 0.0 {
                let [x, y] = plan.grid.centre_of(c, r);
                err.push((v[i] as f64 - texture(x, y)).abs());
            } else {
                assert_eq!(v[i], 0.0, "uncovered cells are nodata");
            }
        }
        err.sort_by(f64::total_cmp);
        let mean = err.iter().sum::<f64>() / err.len() as f64;
        let p99 = err[err.len() * 99 / 100];
        println!(
            "{blend:?}: {} covered cells, mean |error| {mean:.3}, p99 {p99:.3}, max {:.3}",
            err.len(),
            err[err.len() - 1]
        );
        // Bilinear from frames of 0.4-0.7 m pixels over a texture of 13 m wavelength.
        assert!(mean < 1.0 && p99 < 4.0, "mean {mean}, p99 {p99}");
    }
}

/// The largest change between neighbouring covered cells of the mosaic minus the ground,
/// away from the corners where footprint edges cross (within 2 px of a cell whose 3 x 3
/// neighbourhood holds three or more different sets of covering frames): at such a corner one
/// frame alone covers the cells on one side, and no blend can be continuous at the point.
fn largest_step(s: &Scene, plan: &MosaicPlan, v: &[f32], a: &[f32]) -> f64 {
    let (w, h) = (plan.grid.size.width, plan.grid.size.height);
    let scores = brute_scores(s, plan);
    let set = |i: usize| {
        (0..3)
            .filter(|&k| scores[k][i].is_finite())
            .fold(0u8, |m, k| m | 1 << k)
    };
    let around = |c: usize, r: usize, d: usize| {
        let rows = r.saturating_sub(d)..(r + d + 1).min(h);
        rows.flat_map(move |rr| {
            (c.saturating_sub(d)..(c + d + 1).min(w)).map(move |cc| rr * w + cc)
        })
    };
    let corner: Vec<bool> = (0..w * h)
        .map(|i| {
            let mut sets: Vec<u8> = around(i % w, i / w, 1).map(set).collect();
            sets.sort_unstable();
            sets.dedup();
            sets.len() >= 3
        })
        .collect();
    let near_corner = |i: usize| around(i % w, i / w, 2).any(|j| corner[j]);
    let residual = |i: usize| {
        let [x, y] = plan.grid.centre_of((i % w) as f64, (i / w) as f64);
        v[i] as f64 - texture(x, y)
    };
    let mut worst: f64 = 0.0;
    for r in 0..h - 1 {
        for c in 0..w - 1 {
            let i = r * w + c;
            for j in [i + 1, i + w] {
                if a[i] > 0.0 && a[j] > 0.0 && !near_corner(i) && !near_corner(j) {
                    worst = worst.max((residual(i) - residual(j)).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn feathering_leaves_no_step_larger_than_the_blend_allows() {
    // Frames 40 apart in brightness: without blending the seams are steps of 20 to 40.
    let s = scene([0.0, 20.0, -20.0]);
    let (plan, v, a, _) = run_all(
        &s,
        MosaicOptions {
            blend: Blend::None,
            ..MosaicOptions::default()
        },
    );
    let hard = largest_step(&s, &plan, &v, &a);
    let n = 16.0;
    let (plan, v, a, _) = run_all(
        &s,
        MosaicOptions {
            feather_px: 16,
            ..MosaicOptions::default()
        },
    );
    let soft = largest_step(&s, &plan, &v, &a);
    println!("largest step: none {hard:.2}, feather over {n} px {soft:.2}");
    assert!(hard > 19.0, "{hard}");
    // A linear ramp over N px moves 40 / N a pixel; where the seam is a frame's own edge the
    // fade is steeper by up to 2; plus the interpolation error of neighbours (< 4).
    assert!(soft < 2.0 * 40.0 / n + 4.0, "{soft}");
}

/// The whole mosaic composited in one piece, the slow way: brute-force labels, distances by
/// searching every cell within reach, frames from their full orthos.
fn oracle(s: &Scene, plan: &MosaicPlan, n: usize) -> (Vec<f64>, Vec<bool>) {
    let g = plan.grid;
    let (w, h) = (g.size.width as i64, g.size.height as i64);
    let scores = brute_scores(s, plan);
    let label: Vec<Option<usize>> = (0..g.size.pixels())
        .map(|i| {
            (0..3)
                .filter(|&k| scores[k][i].is_finite())
                .min_by(|&a, &b| scores[a][i].total_cmp(&scores[b][i]))
        })
        .collect();
    let reach = n as i64 + 1;
    // Distance from (c, r) to the nearest cell where `f` holds, searched within `reach`.
    let nearest = |c: i64, r: i64, f: &dyn Fn(usize) -> bool| -> f64 {
        let mut best = f64::INFINITY;
        for dr in -reach..=reach {
            for dc in -reach..=reach {
                let (cc, rr) = (c + dc, r + dr);
                if cc >= 0 && rr >= 0 && cc < w && rr < h && f((rr * w + cc) as usize) {
                    best = best.min((dc as f64).hypot(dr as f64));
                }
            }
        }
        best
    };
    let orthos: Vec<AnyRaster> = s
        .frames
        .iter()
        .zip(&s.images)
        .map(|(f, im)| f.plan.run(im).unwrap())
        .collect();
    let nf = n as f64;
    let mut out = vec![0.0; g.size.pixels()];
    let mut covered = vec![false; g.size.pixels()];
    for i in 0..g.size.pixels() {
        let (c, r) = (i as i64 % w, i as i64 / w);
        let (mut sum, mut wsum) = (0.0, 0.0);
        for k in 0..3 {
            if !scores[k][i].is_finite() {
                continue;
            }
            let mine = |j: usize| label[j] == Some(k);
            let signed = if mine(i) {
                nearest(c, r, &|j| !mine(j)) - 0.5
            } else {
                0.5 - nearest(c, r, &mine)
            };
            let cov = nearest(c, r, &|j| !scores[k][j].is_finite());
            let weight = (0.5 + signed / nf).clamp(0.0, 1.0) * (cov / nf).min(1.0);
            if weight <= 0.0 {
                continue;
            }
            let fg = s.frames[k].plan.grid;
            let fc = (c as f64 + (g.top_left[0] - fg.top_left[0]) / GSD).round() as usize;
            let fr = (r as f64 + (fg.top_left[1] - g.top_left[1]) / GSD).round() as usize;
            sum += weight * sample(&orthos[k], 0, fr * fg.size.width + fc);
            wsum += weight;
        }
        if wsum > 0.0 {
            out[i] = sum / wsum;
            covered[i] = true;
        }
    }
    (out, covered)
}

#[test]
fn tiles_equal_the_whole_mosaic_composited_in_one_piece() {
    let s = scene([0.0, 20.0, -20.0]);
    // Odd and even feathers, the narrowest included: the tiles cap the distances to a seam at
    // half the feather (plus one), where the cross-fade saturates; the oracle searches every
    // cell within the feather.
    for n in [1, 3, 8] {
        let opts = MosaicOptions {
            feather_px: n,
            tile_px: 48,
            cache_frames: 2,
            cache_bytes: 0,
            ..MosaicOptions::default()
        };
        let (plan, v, a, loads) = run_all(&s, opts);
        let (want, covered) = oracle(&s, &plan, n);
        let mut worst: f64 = 0.0;
        for i in 0..v.len() {
            assert_eq!(a[i] > 0.0, covered[i], "feather {n}, cell {i}");
            if covered[i] {
                worst = worst.max((v[i] as f64 - want[i]).abs());
            }
        }
        println!(
            "feather {n}: {} tiles, decodes per frame {loads:?}, largest difference {worst:e}",
            plan.tile_windows().count()
        );
        assert!(worst < 1e-3, "feather {n}: {worst}");
        assert!(
            loads.iter().sum::<usize>() > 3,
            "a cache of 2 frames reloads: {loads:?}"
        );
    }
}

#[test]
fn integer_tiles_are_the_oracles_weighted_mean_rounded() {
    // u8 frames: where one frame alone weighs in a tile its weights divide out (the tiles
    // leave them 1 and 0); where frames meet, the feather's. Either way each cell is the slow
    // composite's weighted mean, rounded.
    let s = scene_u8([0.0, 20.0, -20.0]);
    for n in [3, 8] {
        let opts = MosaicOptions {
            feather_px: n,
            tile_px: 48,
            ..MosaicOptions::default()
        };
        let (plan, v, a, _) = run_all(&s, opts);
        let (want, covered) = oracle(&s, &plan, n);
        let (mut worst, mut blended): (f64, usize) = (0.0, 0);
        for i in 0..v.len() {
            assert_eq!(a[i] > 0.0, covered[i], "feather {n}, cell {i}");
            if covered[i] {
                worst = worst.max((v[i] as f64 - want[i]).abs());
                blended += ((want[i] - want[i].round()).abs() > 0.1) as usize;
            }
        }
        println!("feather {n}: {blended} cells blended, largest difference {worst}");
        assert!(worst <= 0.5 + 1e-4, "feather {n}: {worst}");
        assert!(blended > 100, "feather {n}: {blended}");
    }
}

#[test]
fn mosaic_writes_a_tiled_geotiff_of_the_tiles_or_nothing() {
    let s = scene([0.0; 3]);
    let dir = tempfile::tempdir().unwrap();
    let mut frames = s.frames.clone();
    for (f, im) in frames.iter_mut().zip(&s.images) {
        f.path = dir.path().join(&f.path);
        aerorect::io::write_image(&f.path, im).unwrap();
    }
    let opts = MosaicOptions {
        tile_px: 128,
        ..MosaicOptions::default()
    };
    let out = dir.path().join("mosaic.tif");
    let crs = aerorect::geo::Crs::from_epsg(32635).unwrap();
    let report = aerorect::mosaic::mosaic(frames.clone(), crs.clone(), &out, &opts).unwrap();
    let (plan, v, a, _) = run_all(&s, opts.clone());
    assert_eq!(report.size, [plan.grid.size.width, plan.grid.size.height]);
    assert_eq!(report.covered_cells, a.iter().filter(|&&x| x > 0.0).count());
    let AnyRaster::F32(back) = aerorect::io::read_image(&out).unwrap() else {
        panic!("f32")
    };
    assert_eq!(back.plane(0), &v[..]);
    assert_eq!(back.plane(1), &a[..]);
    let geo = aerorect::io::read_georeference(&out).unwrap().unwrap();
    assert_eq!(geo.top_left, plan.grid.top_left);
    assert_eq!(geo.pixel_size, [GSD, GSD]);

    // A frame that cannot be read: an error naming it, and no mosaic (nor temporary file).
    std::fs::remove_file(&out).unwrap();
    std::fs::remove_file(&frames[2].path).unwrap();
    let e = aerorect::mosaic::mosaic(frames, crs, &out, &opts).unwrap_err();
    assert!(e.full_message().contains("frame2.tif"), "{e:?}");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

#[test]
fn window_scores_equal_the_cell_by_cell_scores_bit_for_bit() {
    // The window's scorer evaluates each lattice node once and works in block rows; windows
    // at odd offsets, partly off each frame's grid, must give lattice_score_at's scores.
    let s = scene([0.0; 3]);
    let plan = MosaicPlan::new(s.frames.clone(), GSD, MosaicOptions::default()).unwrap();
    let size = plan.grid.size;
    let windows = [
        Window {
            col0: 0,
            row0: 0,
            size,
        },
        Window {
            col0: 7,
            row0: 5,
            size: ImageSize::new(size.width / 2 + 3, size.height / 3 + 1),
        },
        Window {
            col0: size.width / 3,
            row0: size.height / 2,
            size: ImageSize::new(size.width - size.width / 3, 17),
        },
    ];
    let mut finite = 0;
    for w in windows {
        for k in 0..s.frames.len() {
            let fast = plan.scores(k, w);
            for (i, v) in fast.iter().enumerate() {
                let (c, r) = (w.col0 + i % w.size.width, w.row0 + i / w.size.width);
                let slow = plan.lattice_score_at(k, c, r).unwrap_or(f64::INFINITY);
                assert_eq!(v.to_bits(), slow.to_bits(), "frame {k} cell ({c}, {r})");
                finite += v.is_finite() as usize;
            }
        }
    }
    assert!(finite > 50_000, "{finite}");
}

#[test]
fn lattice_scores_cover_the_same_cells_as_the_exact_scores_and_stay_close() {
    // The lattice rule decides coverage cell by cell wherever a block is not well inside its
    // frame, and its blend departs from the exact score by the score's curvature over 8
    // cells: frames tilted 20 degrees make that curvature largest.
    let s = scene([0.0, 20.0, -20.0]);
    let plan = MosaicPlan::new(s.frames.clone(), GSD, MosaicOptions::default()).unwrap();
    let size = plan.grid.size;
    let (mut worst, mut finite) = (0.0f64, 0);
    for k in 0..s.frames.len() {
        for r in 0..size.height {
            for c in 0..size.width {
                let (lattice, exact) = (plan.lattice_score_at(k, c, r), plan.score_at(k, c, r));
                assert_eq!(
                    lattice.is_some(),
                    exact.is_some(),
                    "frame {k} cell ({c}, {r})"
                );
                if let (Some(a), Some(b)) = (lattice, exact) {
                    worst = worst.max((a - b).abs() / b);
                    finite += 1;
                }
            }
        }
    }
    // Where the labels differ, the exact scores of the two frames are within the blend's
    // error of each other: the seam moves by a fraction of the cells next to it.
    let labels = plan.labels(Window {
        col0: 0,
        row0: 0,
        size,
    });
    let mut moved = 0;
    for (i, l) in labels.iter().enumerate() {
        let (c, r) = (i % size.width, i / size.width);
        let exact: Vec<Option<f64>> = (0..3).map(|k| plan.score_at(k, c, r)).collect();
        let best = (0..3)
            .filter(|&k| exact[k].is_some())
            .min_by(|&a, &b| exact[a].unwrap().total_cmp(&exact[b].unwrap()));
        if *l != best {
            let (a, b) = (exact[l.unwrap()].unwrap(), exact[best.unwrap()].unwrap());
            assert!(
                (a - b).abs() <= 2.0 * worst * b,
                "cell ({c}, {r}): {a} against {b}"
            );
            moved += 1;
        }
    }
    println!(
        "{finite} covered cells, largest relative difference {worst:e}, {moved} of {} labels moved",
        labels.len()
    );
    assert!(finite > 50_000, "{finite}");
    assert!(worst < 1e-3, "{worst}");
    assert!(moved * 1000 < labels.len(), "{moved}");
}
