//! Ties on water and on moving cars (issue 27, bad input): features that are not fixed to the
//! ground. Waves and glint move every view of a point on a lake; a car that drove on between
//! two exposures is seen moved in the later frame only. The robust (Huber) loss must
//! down-weight such views, so every frame comes out within a pixel of where it comes out
//! without them; a quadratic loss, given the same ties, bends the frames they are in by more
//! than twice as much (which shows the test can fail). Huber's loss bounds what a gross view
//! pulls but does not end it: here it halves the bend (0.55 px against 1.33 px).
#![allow(clippy::unwrap_used)]

use aerorect_solve::adjust::{AdjustFrame, AdjustOptions, Adjusted, TiePoint, adjust};
use aerorect_testkit::flight::{camera, flight};
use nalgebra::Rotation3;
use rand::{Rng, SeedableRng};

fn hills(x: f64, y: f64) -> f64 {
    25.0 + 20.0 * (x / 40.0).sin() * (y / 35.0).cos()
}

/// The rotation error of each adjusted frame against the truth, degrees.
fn errors_deg(truth: &[AdjustFrame], got: &[AdjustFrame]) -> Vec<f64> {
    truth
        .iter()
        .zip(got)
        .map(|(t, g)| {
            let d = Rotation3::from_matrix_unchecked(
                g.world_from_camera * t.world_from_camera.transpose(),
            );
            d.angle().to_degrees()
        })
        .collect()
}

fn solve(recorded: &[AdjustFrame], ties: &[TiePoint], huber: f64) -> Adjusted {
    let h = |x: f64, y: f64| hills(x, y);
    let opts = AdjustOptions {
        refine_focal: false,
        refine_principal_point: false,
        terrain: Some((&h, 0.05)),
        huber,
        ..Default::default()
    };
    adjust(recorded, &[camera(800.0)], ties, &opts).unwrap()
}

/// Frame 6's top-left quarter is a lake: every view of a point seen there moves 4-20 px in a
/// random direction. A road crosses frame 12 at rows 360-440: a car there is seen 12 px on in
/// frame 12 only. Returns the ties and how many views were moved (lake, road).
fn water_and_cars(ties: &[TiePoint], seed: u64) -> (Vec<TiePoint>, usize, usize) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (mut ties, mut lake, mut road) = (ties.to_vec(), 0, 0);
    for t in &mut ties {
        let on_lake = t
            .observations
            .iter()
            .any(|o| o.frame == 6 && o.pixel[0] < 500.0 && o.pixel[1] < 375.0);
        if on_lake {
            for o in &mut t.observations {
                let a = rng.random::<f64>() * std::f64::consts::TAU;
                let r = 4.0 + 16.0 * rng.random::<f64>();
                o.pixel[0] += r * a.cos();
                o.pixel[1] += r * a.sin();
                lake += 1;
            }
            continue;
        }
        for o in &mut t.observations {
            if o.frame == 12 && (o.pixel[1] - 400.0).abs() < 40.0 {
                o.pixel[0] += 12.0;
                road += 1;
            }
        }
    }
    (ties, lake, road)
}

#[test]
fn ties_on_water_and_moving_cars_are_down_weighted_not_followed() {
    let fl = flight(5, 4, 1.0, &hills, 21);
    let clean = solve(&fl.recorded, &fl.ties, 3.0);
    let clean_err = errors_deg(&fl.truth, &clean.frames);
    let (ties, lake, road) = water_and_cars(&fl.ties, 7);
    assert!(
        lake >= 20 && road >= 10,
        "{lake} views on the lake, {road} on the road"
    );
    let robust = solve(&fl.recorded, &ties, 3.0);
    let quadratic = solve(&fl.recorded, &ties, 1e9);
    let robust_err = errors_deg(&fl.truth, &robust.frames);
    let quadratic_err = errors_deg(&fl.truth, &quadratic.frames);
    let worst = |e: &[f64]| e.iter().copied().fold(0.0, f64::max);
    let outliers: usize = robust.report.frames.iter().map(|f| f.outliers).sum();
    eprintln!(
        "{} ties, {lake} views on the lake, {road} on the road: worst error clean {:.4}, robust {:.4}, quadratic {:.4} deg; {outliers} down-weighted",
        ties.len(),
        worst(&clean_err),
        worst(&robust_err),
        worst(&quadratic_err)
    );
    // An angle as the pixels it moves a point near the centre (focal length 800 px).
    let px = |deg: f64| deg.to_radians() * 800.0;
    let moved = |e: &[f64]| {
        e.iter()
            .zip(&clean_err)
            .map(|(a, b)| px((a - b).abs()))
            .fold(0.0, f64::max)
    };
    eprintln!(
        "moved from the clean solve: robust {:.2} px, quadratic {:.2} px",
        moved(&robust_err),
        moved(&quadratic_err)
    );
    // The robust solve stays within a pixel of the clean one, and every frame is right.
    assert!(moved(&robust_err) < 1.0, "{robust_err:?}");
    assert!(px(worst(&robust_err)) < 1.0, "{robust_err:?}");
    // The moved views are the ones down-weighted (a few good ones may join them).
    assert!(
        outliers * 10 >= (lake + road) * 7,
        "{outliers} of {}",
        lake + road
    );
    assert!(
        outliers <= (lake + road) * 2,
        "{outliers} of {}",
        lake + road
    );
    // Without the robust loss the same ties bend the frames more than twice as far.
    assert!(moved(&quadratic_err) > 2.0 * moved(&robust_err));
}
