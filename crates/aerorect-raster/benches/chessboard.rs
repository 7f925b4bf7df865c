//! Chessboard detection speed: a 9 x 6 board rendered at 640 x 480 and 1920 x 1440.
use aerorect_core::ImageSize;
use aerorect_raster::chessboard::ChessboardFinder;
use aerorect_testkit::chessboard::{BoardShot, Lens, render_board};
use criterion::{Criterion, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let finder = ChessboardFinder::new(9, 6).expect("a valid board");
    for scale in [1.0, 3.0] {
        let size = ImageSize::new((640.0 * scale) as usize, (480.0 * scale) as usize);
        let lens = Lens {
            fx: 620.0 * scale,
            fy: 620.0 * scale,
            cx: (size.width as f64 - 1.0) / 2.0,
            cy: (size.height as f64 - 1.0) / 2.0,
            k1: -0.2,
            k2: 0.05,
        };
        let shot = BoardShot {
            cols: 9,
            rows: 6,
            square_m: 0.03,
            rvec: [0.5, 0.1, 0.3],
            t: [-0.10, -0.06, 0.55],
            blur_px: 0.8 * scale,
            noise: 2.0,
            seed: 1,
        };
        let (img, _) = render_board(size, &lens, &shot);
        assert!(finder.find(&img).is_ok(), "the bench board is found");
        c.bench_function(
            &format!("chessboard 9x6 {}x{}", size.width, size.height),
            |b| b.iter(|| finder.find(&img)),
        );
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench
}
criterion_main!(benches);
