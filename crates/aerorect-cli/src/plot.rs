//! The error-vs-SNR plot of `motion-sim` (like the paper's Fig. 7b), as SVG.

use aerorect::motion::MotionSimRow;
use anyhow::{Result, anyhow};
use plotters::prelude::*;
use std::path::Path;

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// One line per (scene, method) coloured by method, the CRLB of each scene dashed in gray: the
/// SVG text (written by the caller with its other outputs; `path` names it in errors).
pub fn error_vs_snr(path: &Path, rows: &[MotionSimRow]) -> Result<String> {
    let mut text = String::new();
    draw(path, rows, &mut text)?;
    Ok(text)
}

fn draw(path: &Path, rows: &[MotionSimRow], text: &mut String) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow!("{}: {e}", path.display());
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| {
            (l.min(r.snr_db), h.max(r.snr_db))
        });
    let ymin = rows
        .iter()
        .map(|r| r.crlb_rms_px.min(r.error_rms_px))
        .fold(f64::INFINITY, f64::min)
        .max(1e-4);
    let ymax = rows
        .iter()
        .map(|r| r.error_rms_px.max(r.crlb_rms_px))
        .fold(0.0, f64::max)
        .max(ymin * 10.0);
    let mut methods: Vec<&str> = rows.iter().map(|r| r.method.as_str()).collect();
    methods.dedup();
    methods.sort();
    methods.dedup();
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    let svg = SVGBackend::with_string(text, (900, 600)).into_drawing_area();
    svg.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&svg)
        .caption(
            "shift error RMS vs SNR (dashed: Cramer-Rao bound)",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(lo..hi, (ymin * 0.8..ymax * 1.25).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("SNR (dB)")
        .y_desc("error RMS (px)")
        .draw()
        .map_err(|e| err(&e))?;
    for scene in &scenes {
        let crlb: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.scene == *scene && r.method == methods[0])
            .map(|r| (r.snr_db, r.crlb_rms_px))
            .collect();
        chart
            .draw_series(DashedLineSeries::new(
                crlb,
                6,
                4,
                ShapeStyle::from(&RGBColor(150, 150, 150)),
            ))
            .map_err(|e| err(&e))?;
        for (k, method) in methods.iter().enumerate() {
            let c = COLOURS[k % COLOURS.len()];
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| r.scene == *scene && r.method == *method)
                .map(|r| (r.snr_db, r.error_rms_px))
                .collect();
            let s = chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(|e| err(&e))?;
            if scene == &scenes[0] {
                s.label(*method).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;
    svg.present().map_err(|e| err(&e))?;
    Ok(())
}

/// The calibration's coverage heat map: one cell per grid cell of the image, shaded by its
/// point count (white = none), the count written in it, the image's 3 x 3 split dashed.
pub fn coverage_svg(
    path: &Path,
    cov: &aerorect::solve::calib::Coverage,
    size: aerorect::core::ImageSize,
) -> Result<String> {
    let err = |e: &dyn std::fmt::Display| anyhow!("{}: {e}", path.display());
    let scale = 800.0 / size.width.max(size.height) as f64;
    let (w, h) = (
        (size.width as f64 * scale).round() as i32,
        (size.height as f64 * scale).round() as i32,
    );
    let mut text = String::new();
    {
        let svg =
            SVGBackend::with_string(&mut text, (w as u32 + 20, h as u32 + 50)).into_drawing_area();
        svg.fill(&WHITE).map_err(|e| err(&e))?;
        let max = cov.counts.iter().copied().max().unwrap_or(0).max(1) as f64;
        let (cw, ch) = (w as f64 / cov.cols as f64, h as f64 / cov.rows as f64);
        let at = |c: f64, r: f64| (10 + (c * cw).round() as i32, 40 + (r * ch).round() as i32);
        for r in 0..cov.rows {
            for c in 0..cov.cols {
                let n = cov.counts[r * cov.cols + c];
                let t = n as f64 / max;
                let shade = RGBColor(
                    (255.0 * (1.0 - 0.85 * t)) as u8,
                    (255.0 * (1.0 - 0.55 * t)) as u8,
                    255,
                );
                let (a, b) = (at(c as f64, r as f64), at(c as f64 + 1.0, r as f64 + 1.0));
                svg.draw(&Rectangle::new([a, b], shade.filled()))
                    .map_err(|e| err(&e))?;
                svg.draw(&Rectangle::new([a, b], BLACK.stroke_width(1)))
                    .map_err(|e| err(&e))?;
                let centre = ((a.0 + b.0) / 2 - 8, (a.1 + b.1) / 2 - 7);
                svg.draw(&Text::new(n.to_string(), centre, ("sans-serif", 14)))
                    .map_err(|e| err(&e))?;
            }
        }
        for k in 1..3 {
            let x = 10 + (w as f64 * k as f64 / 3.0).round() as i32;
            let y = 40 + (h as f64 * k as f64 / 3.0).round() as i32;
            for line in [[(x, 40), (x, 40 + h)], [(10, y), (10 + w, y)]] {
                svg.draw(&PathElement::new(line, RED.stroke_width(2)))
                    .map_err(|e| err(&e))?;
            }
        }
        let title = match cov.empty_corners.is_empty() {
            true => format!("control points per cell ({} x {})", cov.cols, cov.rows),
            false => format!(
                "control points per cell; empty corners: {}",
                cov.empty_corners.join(", ")
            ),
        };
        svg.draw(&Text::new(title, (10, 12), ("sans-serif", 16)))
            .map_err(|e| err(&e))?;
        svg.present().map_err(|e| err(&e))?;
    }
    Ok(text)
}
