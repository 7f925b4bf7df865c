//! No ghost pixels: an ortho pixel is drawn only where its ground point is seen by the camera,
//! the lens inside its valid domain. Checked against the testkit's slow oracle, which marches
//! each ray densely from the axis and asks the lens to be monotonic all the way, and against
//! the footprint polygon of the camera's border rays (issue 28, item 1).

#![allow(clippy::unwrap_used)]

use aerorect_core::distortion::{Distortion, OpenCv};
use aerorect_core::{Camera, CameraRotation, ImageSize, Intrinsics, Mat3};
use aerorect_geo::{GroundMap, OrthoGrid, Pose, Terrain};
use aerorect_raster::PixelMap;
use aerorect_testkit::lens_domain::{folding_camera, folding_lenses, on_image, seen};

/// What one rendering of a scene drew.
#[derive(Debug, Default)]
struct Counts {
    /// Pixels with a source on the image.
    rendered: usize,
    /// Rendered pixels the oracle refuses.
    ghosts: usize,
    /// Rendered pixels inside the corner pixels' centres whose ground lies outside the
    /// footprint polygon by more than three output pixels (the outline is sampled every 5
    /// source pixels and 1.4 degrees of the rim; at a grazing far edge one source pixel spans
    /// metres of ground, the ghost bands tens of metres).
    outside_footprint: usize,
    /// Pixels the lens model draws without its domain (main's code before issue 28) that the
    /// oracle accepts.
    seen_ungated: usize,
    /// The same, drawn with the domain.
    seen_gated: usize,
}

/// The ideal normalised point of grid pixel (c, r) on flat ground at z = 0.
fn ideal_of(map: &GroundMap, c: usize, r: usize) -> [f64; 2] {
    let [x, y] = map.grid.centre_of(c as f64, r as f64);
    let d = map.pose.camera_from_world([x, y, 0.0]);
    [d.x / -d.z, d.y / d.z]
}

/// The source of ideal point `n` through the lens without its valid domain (main's GroundMap).
fn ungated(camera: &Camera, n: [f64; 2]) -> Option<[f64; 2]> {
    let q = match &camera.distortion {
        None => n,
        Some(d) => d.model().observed_from_ideal(n)?,
    };
    Some(camera.intrinsics.pixel_from_normalized(q[0], q[1]))
}

fn counts(map: &GroundMap, footprint: &[[f64; 2]]) -> Counts {
    let (w, h) = (map.grid.size.width, map.grid.size.height);
    let (mut xs, mut ys) = (vec![0.0; w], vec![0.0; w]);
    let mut k = Counts::default();
    for r in 0..h {
        map.source_row(r, 0, &mut xs, &mut ys);
        for c in 0..w {
            let n = ideal_of(map, c, r);
            let before = ungated(&map.camera, n);
            let seen_before = before.is_some_and(|px| seen(&map.camera, n, px));
            k.seen_ungated += usize::from(seen_before);
            let px = [xs[c], ys[c]];
            if !on_image(map.camera.size, px) {
                continue;
            }
            k.rendered += 1;
            let same = before.is_some_and(|b| b == px);
            if (same && seen_before) || (!same && seen(&map.camera, n, px)) {
                k.seen_gated += 1;
            } else {
                k.ghosts += 1;
            }
            // The footprint runs through the corner pixels' centres; the half pixel beyond
            // them is drawn too (the footprint convention) and is not counted.
            let size = map.camera.size;
            let within_centres = px[0] >= 0.0
                && px[1] >= 0.0
                && px[0] <= size.width as f64 - 1.0
                && px[1] <= size.height as f64 - 1.0;
            let g = map.grid.centre_of(c as f64, r as f64);
            if within_centres && !near_polygon(footprint, g, 3.0 * map.grid.gsd) {
                k.outside_footprint += 1;
            }
        }
    }
    k
}

/// Whether `p` is inside `poly` or within `tol` of its outline.
fn near_polygon(poly: &[[f64; 2]], p: [f64; 2], tol: f64) -> bool {
    let mut inside = false;
    let mut near = false;
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])
        {
            inside = !inside;
        }
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let t = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        near |= (a[0] + t * dx - p[0]).hypot(a[1] + t * dy - p[1]) <= tol;
    }
    inside || near
}

/// A camera 100 m over flat ground at z = 0, `off_nadir_deg` from the vertical, the ground of
/// its border rays (the footprint polygon) and the ortho grid that covers it (as georef
/// builds it).
fn scene(camera: Camera, off_nadir_deg: f64, gsd: f64) -> (GroundMap, Vec<[f64; 2]>) {
    let r = CameraRotation::dji_gimbal(0.0, off_nadir_deg - 90.0, 0.0).unwrap();
    let pose = Pose::from_enu([0.0, 0.0, 100.0], &r, &Mat3::identity());
    let footprint: Vec<[f64; 2]> = camera
        .border_rays(64)
        .iter()
        .map(|ray| pose.level_point(pose.world_direction(*ray), 0.0).unwrap())
        .collect();
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in &footprint {
        b = [
            b[0].min(p[0]),
            b[1].min(p[1]),
            b[2].max(p[0]),
            b[3].max(p[1]),
        ];
    }
    let map = GroundMap {
        camera,
        pose,
        grid: OrthoGrid::covering(b, gsd),
        terrain: Terrain::Flat(0.0),
    };
    (map, footprint)
}

/// The DJI Phantom 4 RTK of Orthority's test frames, scaled to 1368 x 912: DewarpData k1
/// -0.267, k2 0.112, k3 -0.033 (OpenCV's model), focal 3666 px at 5472 x 3648.
fn p4_rtk() -> Camera {
    let lens = OpenCv {
        k1: -0.267,
        k2: 0.112,
        k3: -0.033,
        ..OpenCv::default()
    };
    let k = Intrinsics::new(3666.0 / 4.0, 3666.0 / 4.0, 683.5, 455.5).unwrap();
    Camera::new(k, Some(Distortion::OpenCv(lens)), ImageSize::new(1368, 912))
}

#[test]
fn p4_rtk_ortho_30_degrees_off_nadir_has_no_ghost_pixels() {
    let (map, footprint) = scene(p4_rtk(), 30.0, 2.0);
    let k = counts(&map, &footprint);
    // Main's code drew every pixel the lens polynomial sends onto the image, folded or not.
    let before = {
        let (w, h) = (map.grid.size.width, map.grid.size.height);
        let mut drawn = 0;
        for r in 0..h {
            for c in 0..w {
                let n = ideal_of(&map, c, r);
                drawn += usize::from(
                    ungated(&map.camera, n).is_some_and(|px| on_image(map.camera.size, px)),
                );
            }
        }
        drawn
    };
    eprintln!(
        "P4 RTK, 30 deg off nadir, grid {}x{}: before {before} drawn, {} outside the footprint \
         ({:.2} %); after {} drawn, {} ghosts, {} outside the footprint polygon",
        map.grid.size.width,
        map.grid.size.height,
        before - k.seen_ungated,
        100.0 * (before - k.seen_ungated) as f64 / before.max(1) as f64,
        k.rendered,
        k.ghosts,
        k.outside_footprint
    );
    assert!(
        before - k.seen_ungated > 300,
        "the lens folds inside the view"
    );
    assert_eq!((k.ghosts, k.outside_footprint), (0, 0), "{k:?}");
    assert_eq!(k.seen_gated, k.seen_ungated, "{k:?}");
}

#[test]
fn every_model_renders_a_folding_lens_without_pixels_outside_its_footprint() {
    for lens in folding_lenses() {
        let kind = lens.kind();
        let (map, footprint) = scene(folding_camera(lens), 30.0, 2.0);
        let k = counts(&map, &footprint);
        eprintln!("{kind}: {k:?}");
        assert!(k.rendered > 2000, "{kind}: {k:?}");
        assert_eq!((k.ghosts, k.outside_footprint), (0, 0), "{kind}: {k:?}");
        // Only ghosts went: the domain's margin costs at most 1 % of the seen pixels.
        assert!(
            k.seen_gated as f64 >= 0.99 * k.seen_ungated as f64,
            "{kind}: {k:?}"
        );
    }
}
