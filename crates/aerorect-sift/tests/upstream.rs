//! The fork against kornia-imgproc 0.2 itself: the same keypoints and descriptors, bit for
//! bit, on textured scenes of even, odd and small sizes, at native and doubled first octave,
//! with and without a keypoint budget.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A textured scene on a 0..255 scale: sinusoids, a checker of blocks and noise.
fn scene(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (kx, ky): (f32, f32) = (rng.random_range(0.03..0.2), rng.random_range(0.03..0.2));
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let smooth = 0.5 + 0.25 * (kx * x).sin() * (ky * y).cos();
            let block = if ((i % w) / 11 + (i / w) / 7).is_multiple_of(2) {
                0.1
            } else {
                0.0
            };
            let noise: f32 = rng.random_range(-0.05..0.05);
            255.0 * (smooth + block + noise).clamp(0.0, 1.0)
        })
        .collect()
}

#[test]
fn fork_equals_kornia_imgproc_bit_for_bit() {
    use kornia_imgproc::features as up;
    let mut compared = 0;
    for (w, h, seed) in [(480, 360, 1), (333, 257, 2), (64, 48, 3), (97, 131, 4)] {
        let img = scene(w, h, seed);
        for (double, n_features) in [(false, 0), (false, 500), (true, 0)] {
            let ours_cfg = aerorect_sift::SiftConfig {
                n_features,
                contrast_threshold: 0.02,
                ..Default::default()
            };
            let up_cfg = up::SiftConfig {
                n_features,
                contrast_threshold: 0.02,
                ..Default::default()
            };
            let (of, uf) = if double {
                (aerorect_sift::FirstOctave::Double, up::FirstOctave::Double)
            } else {
                (aerorect_sift::FirstOctave::Native, up::FirstOctave::Native)
            };
            let mut ows = aerorect_sift::SiftWorkspace::new();
            let mut uws = up::SiftWorkspace::new();
            let ours = aerorect_sift::sift_detect_and_compute(
                &mut ows,
                &img,
                w,
                h,
                &ours_cfg,
                of,
                usize::MAX,
                false,
            )
            .expect("fork");
            let theirs =
                up::sift_detect_and_compute(&mut uws, &img, w, h, &up_cfg, uf, usize::MAX, false)
                    .expect("upstream");
            let what = format!("{w} x {h}, doubled {double}, budget {n_features}");
            assert_eq!(ours.keypoints.len(), theirs.keypoints.len(), "{what}");
            for (a, b) in ours.keypoints.iter().zip(&theirs.keypoints) {
                let bits = |k: [f32; 5]| k.map(f32::to_bits);
                assert_eq!(
                    bits([a.x, a.y, a.size, a.angle, a.response]),
                    bits([b.x, b.y, b.size, b.angle, b.response]),
                    "{what}"
                );
                assert_eq!(a.octave, b.octave, "{what}");
            }
            let dbits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                dbits(&ours.descriptors),
                dbits(&theirs.descriptors),
                "{what}"
            );
            compared += ours.keypoints.len();
        }
    }
    assert!(compared > 1000, "only {compared} keypoints compared");
}
