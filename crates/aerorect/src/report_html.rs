//! The batch report: one self-contained HTML page (inline SVG map, base64 PNG thumbnails).

use crate::drone::PhotoResult;
use base64::Engine;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn name(path: &str) -> String {
    std::path::Path::new(path)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.to_string())
}

/// The footprints of all frames on the ground, north up, with camera positions and a scale bar.
fn footprint_map(frames: &[&PhotoResult]) -> String {
    let pts: Vec<[f64; 2]> = frames
        .iter()
        .flat_map(|f| {
            f.footprint_en
                .iter()
                .copied()
                .chain([f.info.easting_northing_m])
        })
        .collect();
    if pts.is_empty() {
        return "<p>No frame was rectified.</p>".into();
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &pts {
        for d in 0..2 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    let (w, h, pad) = (800.0, 600.0, 30.0);
    let span = ((hi[0] - lo[0]) / (w - 2.0 * pad))
        .max((hi[1] - lo[1]) / (h - 2.0 * pad))
        .max(1e-9);
    let xy = |p: [f64; 2]| (pad + (p[0] - lo[0]) / span, h - pad - (p[1] - lo[1]) / span);
    let colours = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf",
    ];
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" style=\"background:#f4f4f0;border:1px solid #999\">"
    );
    for (k, f) in frames.iter().enumerate() {
        let c = colours[k % colours.len()];
        let poly: Vec<String> = f
            .footprint_en
            .iter()
            .map(|&p| {
                let (x, y) = xy(p);
                format!("{x:.1},{y:.1}")
            })
            .collect();
        let (cx, cy) = xy(f.info.easting_northing_m);
        svg += &format!(
            "<polygon points=\"{}\" fill=\"{c}\" fill-opacity=\"0.18\" stroke=\"{c}\" stroke-width=\"1.5\"><title>{}</title></polygon>\
             <circle cx=\"{cx:.1}\" cy=\"{cy:.1}\" r=\"4\" fill=\"{c}\"/><text x=\"{:.1}\" y=\"{:.1}\" font-size=\"12\" fill=\"{c}\">{}</text>",
            poly.join(" "),
            esc(&name(&f.input)),
            cx + 6.0,
            cy - 6.0,
            esc(&name(&f.input))
        );
    }
    // Scale bar: a round length near a fifth of the width.
    let target = (w - 2.0 * pad) * span / 5.0;
    let mag = 10f64.powf(target.log10().floor());
    let len = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .filter(|l| *l <= target)
        .fold(mag, f64::max);
    let px = len / span;
    svg += &format!(
        "<line x1=\"{pad}\" y1=\"{y}\" x2=\"{x2:.1}\" y2=\"{y}\" stroke=\"black\" stroke-width=\"3\"/><text x=\"{pad}\" y=\"{ty}\" font-size=\"12\">{len} m</text>\
         <text x=\"{nx}\" y=\"{ny}\" font-size=\"16\" font-weight=\"bold\">N &#8593;</text></svg>",
        y = h - 12.0,
        x2 = pad + px,
        ty = h - 18.0,
        nx = w - 40.0,
        ny = 24.0
    );
    svg
}

fn img(png: &[u8]) -> String {
    format!(
        "<img src=\"data:image/png;base64,{}\" style=\"max-width:320px;max-height:240px\">",
        base64::engine::general_purpose::STANDARD.encode(png)
    )
}

fn frame_row(f: &PhotoResult) -> String {
    let i = &f.info;
    let (before, after) = match &f.thumbnails {
        Some((b, a)) => (img(b), img(a)),
        None => (String::new(), String::new()),
    };
    let warnings = if i.warnings.is_empty() {
        "none".to_string()
    } else {
        i.warnings
            .iter()
            .map(|w| format!("&#9888; {}", esc(w)))
            .collect::<Vec<_>>()
            .join("<br>")
    };
    format!(
        "<tr><td><b>{}</b><br>{} x {} &rarr; {} x {} px<br>{}<br>{:.2} s</td><td>{before}</td><td>{after}</td>\
         <td>gimbal yaw {:.1}&deg;<br>pitch {:.1}&deg;<br>roll {:.1}&deg;<br>off nadir {:.1}&deg;</td>\
         <td>{:.1} m<br><small>{}</small></td><td>{:.3} m</td><td>{warnings}</td></tr>",
        esc(&name(&f.input)),
        f.input_size[0],
        f.input_size[1],
        f.output_size[0],
        f.output_size[1],
        esc(&i.geo.crs.to_string()),
        f.seconds,
        i.gimbal_yaw_pitch_roll_deg[0],
        i.gimbal_yaw_pitch_roll_deg[1],
        i.gimbal_yaw_pitch_roll_deg[2],
        i.off_nadir_deg,
        i.height_m,
        esc(&i.height_source),
        i.gsd_m,
    )
}

/// The whole page.
pub fn render(
    done: &[&PhotoResult],
    skipped: &[(String, String)],
    failed: &[(String, String)],
    seconds: f64,
) -> String {
    let list = |items: &[(String, String)]| -> String {
        items
            .iter()
            .map(|(f, w)| format!("<li><b>{}</b>: {}</li>", esc(&name(f)), esc(w)))
            .collect()
    };
    let rows: String = done.iter().map(|f| frame_row(f)).collect();
    format!(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>aerorect batch report</title>\
         <style>body{{font-family:sans-serif;margin:20px}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:6px;vertical-align:top}}</style></head><body>\
         <h1>aerorect batch report</h1><p>{} rectified, {} skipped, {} failed in {:.1} s.</p>\
         <h2>Footprints on the ground</h2>{}\
         <h2>Frames</h2><table><tr><th>frame</th><th>before</th><th>after (north up)</th><th>attitude</th><th>height</th><th>GSD</th><th>warnings</th></tr>{rows}</table>\
         <h2>Failed</h2><ul>{}</ul><h2>Skipped</h2><ul>{}</ul></body></html>",
        done.len(),
        skipped.len(),
        failed.len(),
        seconds,
        footprint_map(done),
        list(failed),
        list(skipped),
    )
}
