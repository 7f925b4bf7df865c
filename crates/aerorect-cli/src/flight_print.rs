//! What the CLI prints of a flight's adjustment and of its ground control's accuracy.

/// The adjustment's pairs, warnings, residuals and datum, and the accuracy of its ground
/// control.
pub(crate) fn print_adjustment(r: &aerorect::flight::FlightReport) {
    for p in &r.pairs {
        outln!(
            "pair {} / {}: {} tie points of {} patches{}, misalignment {:.3} m -> {}",
            p.a,
            p.b,
            p.inliers,
            p.patches,
            if p.reliable {
                ""
            } else {
                " (nothing reliable shared: not used)"
            },
            p.misalignment_before_m,
            p.misalignment_after_m
                .map_or("-".to_string(), |m| format!("{m:.3} m"))
        );
    }
    for u in &r.unconnected {
        eprintln!("warning: {u}: overlaps no other frame reliably; left as recorded");
    }
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    let adj = &r.adjustment;
    outln!(
        "adjustment: {} frames, {} tie points, rms {:.2} -> {:.2} px in {} iterations ({}), {:.2} s",
        r.frames.len(),
        adj.tie_points,
        adj.rms_before_px,
        adj.rms_after_px,
        adj.iterations,
        serde_json::to_value(adj.termination)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default(),
        adj.seconds
    );
    if let Some(d) = &adj.datum {
        outln!(
            "datum of the recorded positions ({:?}): shift {:.3}, {:.3}, {:.3} m, rotation {:.4}, {:.4}, {:.4} deg, scale {:.0} ppm",
            d.model,
            d.shift_m[0],
            d.shift_m[1],
            d.shift_m[2],
            d.rotation_deg[0],
            d.rotation_deg[1],
            d.rotation_deg[2],
            d.scale_ppm
        );
    }
    if let Some(s) = &r.surface {
        outln!(
            "ground: the tie points' surface, {} points ({} left out), {} x {} cells of {:.1} m over x {:.1}..{:.1}, y {:.1}..{:.1}, heights {:.1}..{:.1} m, points {:.2} m rms about it",
            s.tie_points,
            s.rejected,
            s.size[0],
            s.size[1],
            s.cell_m,
            s.extent[0],
            s.extent[2],
            s.extent[1],
            s.extent[3],
            s.heights_m[0],
            s.heights_m[1],
            s.spread_m
        );
    }
    if let Some(a) = &r.accuracy {
        print_accuracy(a);
    }
}

fn print_accuracy(a: &aerorect::flight::AccuracyReport) {
    for p in &a.points {
        let m = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:+.3}"));
        outln!(
            "{:?} {}: dX {} dY {} dZ {} m; {} marks",
            p.role,
            p.name,
            m(p.residual_m.map(|r| r[0])),
            m(p.residual_m.map(|r| r[1])),
            m(p.residual_z_m),
            p.images.len()
        );
    }
    for (what, b, r) in [
        ("control", &a.control_before, &a.control),
        ("check", &a.check_before, &a.check),
    ] {
        if r.count > 0 {
            outln!(
                "RMSE over {} {what} points XY / Z: {:.3} / {:.3} m recorded, {:.3} / {:.3} m adjusted (GSD {:.3} m)",
                r.count,
                b.xy_m,
                b.z_m,
                r.xy_m,
                r.z_m,
                a.mean_gsd_m
            );
        }
    }
    if let Some(c) = &a.asprs_horizontal {
        outln!(
            "ASPRS 2014 horizontal accuracy class: {} ({:.3} m at 95 %, {} check points)",
            c.class_cm
                .map_or("beyond 10 m".into(), |c| format!("{c} cm")),
            c.accuracy_95_m,
            c.check_points
        );
    }
    if !a.unreached.is_empty() {
        eprintln!(
            "warning: {} frames in blocks no ground control point reaches: {}",
            a.unreached.len(),
            a.unreached.join(", ")
        );
    }
}
