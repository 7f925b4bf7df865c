//! The batch report: one self-contained HTML page (inline SVG map, base64 PNG thumbnails).

use crate::drone::PhotoResult;
use crate::flight::{FlightReport, TieVector};
use base64::Engine;

/// What `batch --adjust` adds to the page: the adjustment, its tie points and an overview.
pub struct FlightSection<'a> {
    pub report: &'a FlightReport,
    pub ties: &'a [TieVector],
    /// A PNG of the adjusted flight's overview.
    pub overview_png: Option<Vec<u8>>,
}

/// At most this many tie points are drawn (every k-th).
const MAX_DRAWN_TIES: usize = 4000;

/// The tie points on the ground, each with its gap between the two frames before (red) and
/// after (blue) the adjustment, both exaggerated by one factor so the median gap before is
/// about 20 px on the map.
fn tie_map(ties: &[TieVector]) -> String {
    if ties.is_empty() {
        return "<p>No tie points.</p>".into();
    }
    let ground: Vec<[f64; 2]> = ties.iter().map(|t| t.ground).collect();
    let map = GroundMap::fit(&ground);
    let (w, h, pad, span) = (MAP_W, MAP_H, MAP_PAD, map.span);
    let xy = |p| map.xy(p);
    let mut gaps: Vec<f64> = ties
        .iter()
        .map(|t| t.before_m[0].hypot(t.before_m[1]))
        .collect();
    gaps.sort_by(f64::total_cmp);
    let median = gaps[gaps.len() / 2].max(1e-6);
    let exaggerate = 20.0 * span / median;
    let step = ties.len().div_ceil(MAX_DRAWN_TIES);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" style=\"background:#f4f4f0;border:1px solid #999\">"
    );
    let line = |x: f64, y: f64, v: [f64; 2], colour: &str| {
        format!(
            "<line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{:.1}\" stroke=\"{colour}\" stroke-width=\"1\"/>",
            x + v[0] * exaggerate / span,
            y - v[1] * exaggerate / span
        )
    };
    for t in ties.iter().step_by(step) {
        let (x, y) = xy(t.ground);
        svg += &line(x, y, t.before_m, "#d62728");
        svg += &line(x, y, t.after_m, "#1f77b4");
        svg += &format!("<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"1.2\" fill=\"black\"/>");
    }
    svg += &format!(
        "<text x=\"{pad}\" y=\"{:.0}\" font-size=\"12\">{} of {} tie points; gaps x{exaggerate:.0}: <tspan fill=\"#d62728\">before</tspan> (median {median:.3} m), <tspan fill=\"#1f77b4\">after</tspan></text></svg>",
        h - 10.0,
        ties.len().div_ceil(step),
        ties.len()
    );
    svg
}

fn flight_section(f: &FlightSection) -> String {
    let r = f.report;
    let a = &r.adjustment;
    let rounds: String = r
        .rounds
        .iter()
        .enumerate()
        .map(|(k, x)| {
            format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.4}</td><td>{:.4}</td><td>{:.1}</td></tr>",
                k + 1,
                x.tie_points,
                x.reliable_pairs,
                x.rms_after_px,
                x.median_turn_deg,
                x.largest_turn_deg,
                x.seconds
            )
        })
        .collect();
    let pairs: String = r
        .pairs
        .iter()
        .map(|p| {
            format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{}</td></tr>",
                esc(&name(&p.a)),
                esc(&name(&p.b)),
                p.patches,
                p.inliers,
                if p.reliable { "yes" } else { "no: not used" },
                p.misalignment_before_m,
                p.misalignment_after_m
                    .map_or("-".to_string(), |m| format!("{m:.3}"))
            )
        })
        .collect();
    let overview = f
        .overview_png
        .as_deref()
        .map_or(String::new(), |png| {
            format!(
                "<h3>Overview of the adjusted flight</h3><img src=\"data:image/png;base64,{}\" style=\"max-width:800px\">",
                base64::engine::general_purpose::STANDARD.encode(png)
            )
        });
    let unconnected: String = r
        .unconnected
        .iter()
        .map(|u| {
            format!(
                "<li>{}: overlaps no frame reliably; left as recorded</li>",
                esc(&name(u))
            )
        })
        .collect();
    format!(
        "<h2>Flight adjustment</h2><p>{} frames, {} tie points, {} observations; residual RMS {:.2} &rarr; {:.3} px; {} matching rounds; {:.1} s.</p><ul>{unconnected}</ul>         <table><tr><th>round</th><th>tie points</th><th>reliable pairs</th><th>RMS after (px)</th><th>median turn (&deg;)</th><th>largest turn (&deg;)</th><th>s</th></tr>{rounds}</table>         <h3>Tie points and their gaps between frames</h3>{}         <h3>Pairs: misalignment on the ground (median over the tie points, m)</h3>         <table><tr><th>a</th><th>b</th><th>patches</th><th>tie points</th><th>reliable</th><th>before</th><th>after</th></tr>{pairs}</table>{}{overview}",
        r.frames.len(),
        a.tie_points,
        a.observations,
        a.rms_before_px,
        a.rms_after_px,
        r.passes,
        r.seconds,
        tie_map(f.ties),
        r.accuracy.as_ref().map_or(String::new(), accuracy_section),
    )
}

fn metres(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.3}"))
}

/// The accuracy report against the ground control and check points.
fn accuracy_section(a: &crate::flight::AccuracyReport) -> String {
    let rows: String = a
        .points
        .iter()
        .map(|p| {
            let px: Vec<String> = p
                .images
                .iter()
                .map(|m| format!("{} {}", esc(&name(&m.image)), metres(m.residual_px)))
                .collect();
            format!(
                "<tr><td>{}</td><td>{:?}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&p.name),
                p.role,
                metres(p.residual_m.map(|r| r[0])),
                metres(p.residual_m.map(|r| r[1])),
                metres(p.residual_z_m),
                px.join("; ")
            )
        })
        .collect();
    let rmse = |what: &str, b: &crate::flight::Rmse, r: &crate::flight::Rmse| {
        format!(
            "<tr><td>{what}</td><td>{}</td><td>{:.3} / {:.3}</td><td>{:.3} / {:.3}</td></tr>",
            r.count, b.xy_m, b.z_m, r.xy_m, r.z_m
        )
    };
    let class = a.asprs_horizontal.as_ref().map_or(
        "<p>No check points: the horizontal accuracy class is not assessed.</p>".into(),
        |c| {
            format!(
                "<p>ASPRS (2014) horizontal accuracy class: {} (RMSE<sub>x</sub> and RMSE<sub>y</sub> within it); {:.3} m at 95 % confidence; from {} check points (the standard asks for at least 20).</p>",
                c.class_cm.map_or("beyond 10 m".into(), |c| format!("{c} cm")),
                c.accuracy_95_m,
                c.check_points
            )
        },
    );
    let unreached = match a.unreached.len() {
        0 => String::new(),
        n => format!(
            "<p>{n} frames in blocks no control point reaches: {}</p>",
            esc(&a
                .unreached
                .iter()
                .map(|u| name(u))
                .collect::<Vec<_>>()
                .join(", "))
        ),
    };
    format!(
        "<h3>Accuracy against ground control ({})</h3><p>Mean GSD {:.3} m.</p>{class}{unreached}<table><tr><th>points</th><th>count</th><th>RMSE XY / Z recorded (m)</th><th>RMSE XY / Z adjusted (m)</th></tr>{}{}</table><table><tr><th>point</th><th>role</th><th>dX (m)</th><th>dY (m)</th><th>dZ (m)</th><th>per image (px)</th></tr>{rows}</table>",
        esc(&a.file),
        a.mean_gsd_m,
        rmse("control", &a.control_before, &a.control),
        rmse("check", &a.check_before, &a.check),
    )
}

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

/// The maps' page: width, height and margin (px).
const MAP_W: f64 = 800.0;
const MAP_H: f64 = 600.0;
const MAP_PAD: f64 = 30.0;

/// A north-up page of ground points: metres per page pixel and the lower-left corner.
struct GroundMap {
    lo: [f64; 2],
    span: f64,
}

impl GroundMap {
    /// The scale that fits every point inside the padded page.
    fn fit(points: &[[f64; 2]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for d in 0..2 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let span = ((hi[0] - lo[0]) / (MAP_W - 2.0 * MAP_PAD))
            .max((hi[1] - lo[1]) / (MAP_H - 2.0 * MAP_PAD))
            .max(1e-9);
        Self { lo, span }
    }

    /// Page position of a ground point.
    fn xy(&self, p: [f64; 2]) -> (f64, f64) {
        (
            MAP_PAD + (p[0] - self.lo[0]) / self.span,
            MAP_H - MAP_PAD - (p[1] - self.lo[1]) / self.span,
        )
    }
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
    let map = GroundMap::fit(&pts);
    let (w, h, pad, span) = (MAP_W, MAP_H, MAP_PAD, map.span);
    let xy = |p| map.xy(p);
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
    flight: Option<&FlightSection>,
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
         <h2>Footprints on the ground</h2>{}{}\
         <h2>Frames</h2><table><tr><th>frame</th><th>before</th><th>after (north up)</th><th>attitude</th><th>height</th><th>GSD</th><th>warnings</th></tr>{rows}</table>\
         <h2>Failed</h2><ul>{}</ul><h2>Skipped</h2><ul>{}</ul></body></html>",
        done.len(),
        skipped.len(),
        failed.len(),
        seconds,
        footprint_map(done),
        flight.map_or(String::new(), flight_section),
        list(failed),
        list(skipped),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The drawn lines of a colour: (x1, y1, x2, y2).
    fn lines(svg: &str, colour: &str) -> Vec<[f64; 4]> {
        svg.split("<line ")
            .skip(1)
            .map(|l| &l[..l.find("/>").unwrap()])
            .filter(|l| l.contains(colour))
            .map(|l| {
                let v = |k: &str| -> f64 {
                    let at = l.find(&format!("{k}=\"")).unwrap() + k.len() + 2;
                    l[at..at + l[at..].find('"').unwrap()].parse().unwrap()
                };
                [v("x1"), v("y1"), v("x2"), v("y2")]
            })
            .collect()
    }

    #[test]
    fn tie_gaps_are_drawn_east_and_north_at_one_scale() {
        let ties = [
            TieVector {
                ground: [0.0, 0.0],
                before_m: [2.0, 0.0],
                after_m: [0.1, 0.0],
            },
            TieVector {
                ground: [100.0, 50.0],
                before_m: [0.0, 2.0],
                after_m: [0.0, -0.2],
            },
        ];
        let svg = tie_map(&ties);
        let (red, blue) = (lines(&svg, "#d62728"), lines(&svg, "#1f77b4"));
        assert_eq!((red.len(), blue.len()), (2, 2));
        // East is +x on the page, north is -y; one exaggeration for before and after.
        let d = |l: [f64; 4]| [l[2] - l[0], l[3] - l[1]];
        let (r0, b0, r1, b1) = (d(red[0]), d(blue[0]), d(red[1]), d(blue[1]));
        assert!(r0[0] > 0.0 && r0[1].abs() < 0.2 && r1[1] < 0.0 && r1[0].abs() < 0.2);
        assert!((b0[0] / r0[0] - 0.05).abs() < 0.01, "{b0:?} {r0:?}");
        assert!((b1[1] / r1[1] + 0.1).abs() < 0.01, "{b1:?} {r1:?}");
        // The median gap before (2 m) is drawn about 20 px long.
        assert!((r0[0] - 20.0).abs() < 0.2, "{r0:?}");
    }
}
