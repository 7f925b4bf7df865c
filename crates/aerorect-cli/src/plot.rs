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
