//! The tie surface on a simulated flight (`simulate_flight NX NY DIR`), for the numbers of
//! issue 27: the flight adjusted with no DEM (level ground at `--ground-height-m`, default
//! 25 m, the hills' mean), its tie-point surface against the simulation's truth `dem.tif`
//! (and the level ground against it), and consecutive frames along each strip (`f_J_I` and
//! `f_J_I+1`) written over the level ground and over the surface, their agreement by the
//! overlap correlator (median of the pairs' median shifts, px of the output GSD).
//!
//! `cargo run --release -p aerorect --example tie_surface_sim -- DIR [GROUND_M [GSD_M]]`
#![allow(clippy::unwrap_used, clippy::expect_used)]

use aerorect::flight::{FlightOptions, adjust_flight};
use aerorect::options::PhotoRequest;
use std::path::{Path, PathBuf};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// RMS and 95th percentile of |a - truth| on a 2 m grid over the frame centres' box, and the
/// mean and standard deviation of a - truth.
fn against(
    truth: &aerorect::geo::Dem,
    b: [f64; 4],
    a: &dyn Fn(f64, f64) -> f64,
) -> (f64, f64, f64, f64) {
    let mut d = Vec::new();
    let (nx, ny) = (
        ((b[2] - b[0]) / 2.0) as usize,
        ((b[3] - b[1]) / 2.0) as usize,
    );
    for i in 0..=nx {
        for j in 0..=ny {
            let (x, y) = (b[0] + 2.0 * i as f64, b[1] + 2.0 * j as f64);
            if let Some(t) = truth.height_at(x, y) {
                d.push(a(x, y) - t);
            }
        }
    }
    let n = d.len() as f64;
    let rms = (d.iter().map(|v| v * v).sum::<f64>() / n).sqrt();
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let mut abs: Vec<f64> = d.iter().map(|v| v.abs()).collect();
    abs.sort_by(f64::total_cmp);
    (rms, abs[abs.len() * 95 / 100], mean, sd)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = Path::new(args.first().expect("DIR")).to_path_buf();
    let ground: f64 = args.get(1).map_or(25.0, |a| a.parse().unwrap());
    let gsd: f64 = args.get(2).map_or(0.25, |a| a.parse().unwrap());
    let mut frames: Vec<PathBuf> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    frames.sort();
    let req = PhotoRequest {
        gsd_m: Some(gsd),
        ground_height_m: Some(ground),
        camera: Some(dir.join("cam.toml")),
        poses: Some(dir.join("pert.csv")),
        ..Default::default()
    };
    let (opts, _) = req.resolve_flight(&frames).unwrap();
    let t = std::time::Instant::now();
    let mut flight = adjust_flight(&frames, &opts, &FlightOptions::default()).unwrap();
    let adjust_s = t.elapsed().as_secs_f64();
    let r = &flight.report;
    eprintln!(
        "adjusted {} frames in {adjust_s:.1} s, rms {:.2} px; surface {:?}",
        frames.len(),
        r.adjustment.rms_after_px,
        r.surface
    );
    let truth = aerorect::io::read_dem(&dir.join("dem.tif")).unwrap();
    let c: Vec<[f64; 3]> = flight.poses.iter().map(|p| p.centre).collect();
    let b = c.iter().fold(
        [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ],
        |b, p| {
            [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ]
        },
    );
    let surface = flight.surface.take().expect("a tie surface");
    let s = against(&truth, b, &|x, y| surface.height_at(x, y).unwrap());
    let l = against(&truth, b, &|_, _| ground);
    for (what, (rms, p95, mean, sd)) in [("surface", s), ("level ground", l)] {
        eprintln!(
            "{what} against the truth DEM over the block: {rms:.3} m rms (95 % {p95:.3} m), mean {mean:+.3} m, sd about it {sd:.3} m"
        );
    }
    let out = tempfile_dir();
    let name = |k: usize| {
        frames[k]
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned()
    };
    let write_all = |flight: &aerorect::flight::AdjustedFlight, tag: &str| -> f64 {
        let t = std::time::Instant::now();
        for k in 0..frames.len() {
            let p = out.join(format!("{tag}_{}.tif", name(k)));
            flight.write_frame(k, &p, &opts).unwrap();
        }
        t.elapsed().as_secs_f64()
    };
    let level_s = write_all(&flight, "level");
    flight.surface = Some(surface);
    let surface_s = write_all(&flight, "surface");
    eprintln!(
        "frames written over the level ground in {level_s:.1} s, over the surface in {surface_s:.1} s"
    );
    for tag in ["level", "surface"] {
        let mut shifts = Vec::new();
        for k in 0..frames.len().saturating_sub(1) {
            let (a, b) = (name(k), name(k + 1));
            // Along a strip: the same row (f_J_...).
            if a[..5] != b[..5] {
                continue;
            }
            let (pa, pb) = (
                out.join(format!("{tag}_{a}.tif")),
                out.join(format!("{tag}_{b}.tif")),
            );
            if let Ok(s) = aerorect::overlap::overlap_shift(&pa, &pb, 64) {
                shifts.push(s.median_px[0].hypot(s.median_px[1]));
            }
        }
        eprintln!(
            "{tag}: consecutive frames agree to a median {:.3} px (worst {:.3} px, {} pairs)",
            median(shifts.clone()),
            shifts.iter().copied().fold(0.0, f64::max),
            shifts.len()
        );
    }
    std::fs::remove_dir_all(&out).ok();
}

fn tempfile_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("tie_surface_sim_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
