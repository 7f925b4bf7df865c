//! The misalignment of two orthos on one grid by one phase correlation over the largest square
//! of their common window (nodata filled with the valid mean), for misalignments beyond the
//! tiled estimator's quarter-tile limit (`aerorect overlap`). Prints B's offset from A in
//! pixels and metres east, north, and the peak's confidence.
//!
//! cargo run --release -p aerorect --example overlap_whole -- A.tif B.tif

use aerorect::raster::shift::{PhaseCorrelator, PhaseOptions, ShiftEstimator, Weighting};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b] = &args[..] else {
        return Err("usage: overlap_whole A.tif B.tif".into());
    };
    let (a, b) = (std::path::Path::new(a), std::path::Path::new(b));
    let ga = aerorect::io::read_georeference(a)?.ok_or("A: not a GeoTIFF")?;
    let gb = aerorect::io::read_georeference(b)?.ok_or("B: not a GeoTIFF")?;
    let gsd = ga.pixel_size[0];
    let off = [
        ((gb.top_left[0] - ga.top_left[0]) / gsd).round() as i64,
        ((ga.top_left[1] - gb.top_left[1]) / gsd).round() as i64,
    ];
    let ia = aerorect::motion::gray(&aerorect::io::read_image(a)?)?;
    let ib = aerorect::motion::gray(&aerorect::io::read_image(b)?)?;
    let (sa, sb) = (ia.size(), ib.size());
    let [x0, y0, x1, y1] = aerorect::geo::common_window(sa, sb, off);
    let side = ((x1 - x0).min(y1 - y0)) as usize;
    let n = side & !1;
    let (cx, cy) = (x0 + (x1 - x0 - n as i64) / 2, y0 + (y1 - y0 - n as i64) / 2);
    let mut pa = vec![0f32; n * n];
    let mut pb = vec![0f32; n * n];
    for r in 0..n {
        for c in 0..n {
            let (x, y) = (cx + c as i64, cy + r as i64);
            pa[r * n + c] = ia.plane(0)[y as usize * sa.width + x as usize];
            pb[r * n + c] = ib.plane(0)[(y - off[1]) as usize * sb.width + (x - off[0]) as usize];
        }
    }
    let valid: Vec<bool> = pa
        .iter()
        .zip(&pb)
        .map(|(x, y)| *x != 0.0 && *y != 0.0)
        .collect();
    for p in [&mut pa, &mut pb] {
        let (s, k) = p
            .iter()
            .zip(&valid)
            .filter(|(_, v)| **v)
            .fold((0f64, 0usize), |(s, k), (x, _)| (s + *x as f64, k + 1));
        let mean = (s / k.max(1) as f64) as f32;
        for (x, v) in p.iter_mut().zip(&valid) {
            if !*v {
                *x = mean;
            }
        }
    }
    let opts = PhaseOptions {
        weighting: Weighting::Phase,
        window: true,
        smooth: 0.0,
    };
    let e = PhaseCorrelator::new(n, n, opts)?.estimate(&pa, &pb)?;
    let valid_share = valid.iter().filter(|v| **v).count() as f64 / valid.len() as f64;
    println!(
        "{:.2} {:.2} px = {:.2} m east {:.2} m north, |d| {:.2} m = {:.2} px, confidence {:.3}, window {n} px ({:.0}% valid)",
        e.dx,
        e.dy,
        e.dx * gsd,
        -e.dy * gsd,
        e.dx.hypot(e.dy) * gsd,
        e.dx.hypot(e.dy),
        e.confidence,
        100.0 * valid_share
    );
    Ok(())
}
