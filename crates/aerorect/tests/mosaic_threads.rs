//! The mosaic on many threads: tiles composited and compressed at once give the file one
//! thread writes, byte for byte; threads share decoded frames (a frame wanted by several at
//! once is decoded once); a frame of another format is named, and a failed mosaic leaves no
//! file.
#![allow(clippy::unwrap_used)]

mod mosaic_scene;
use aerorect::mosaic::{MosaicFrame, MosaicOptions, MosaicPlan, MosaicRun, Window};
use aerorect::raster::{AnyRaster, Raster};
use mosaic_scene::*;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// The scene's frames written as files in `dir`.
fn frames_on_disk(s: &Scene, dir: &std::path::Path) -> Vec<MosaicFrame> {
    let mut frames = s.frames.clone();
    for (f, im) in frames.iter_mut().zip(&s.images) {
        f.path = dir.join(&f.path);
        aerorect::io::write_image(&f.path, im).unwrap();
    }
    frames
}

#[test]
fn the_mosaic_on_one_thread_or_three_is_the_same_file() {
    let s = scene([0.0, 20.0, -20.0]);
    let dir = tempfile::tempdir().unwrap();
    let frames = frames_on_disk(&s, dir.path());
    // 64 px tiles: several batches of 12 tiles on three threads.
    let opts = MosaicOptions {
        tile_px: 64,
        ..MosaicOptions::default()
    };
    let crs = aerorect::geo::Crs::from_epsg(32635).unwrap();
    let on = |threads: usize, cog: bool| {
        let path = dir.path().join(format!("m{threads}{cog}.tif"));
        let c = aerorect::io::CogOptions::masked_by_alpha(true);
        let (f, crs) = (frames.clone(), crs.clone());
        let r = pool(threads)
            .install(|| match cog {
                true => aerorect::mosaic::mosaic_cog(f, crs, &path, &opts, &c),
                false => aerorect::mosaic::mosaic(f, crs, &path, &opts),
            })
            .unwrap();
        let cells: Vec<usize> = r.frames.iter().map(|f| f.cells).collect();
        assert_eq!(cells.iter().sum::<usize>(), r.covered_cells);
        (std::fs::read(&path).unwrap(), cells, r.tiles)
    };
    for cog in [false, true] {
        let (one, three) = (on(1, cog), on(3, cog));
        assert!(one.2 > 3 * 12, "{} tiles", one.2);
        assert!(one.0 == three.0, "cog {cog}: the files differ");
        assert_eq!(one.1, three.1);
        assert!(one.1.iter().all(|&n| n > 0), "{:?}", one.1);
    }
}

/// Every tile of `plan`, composited on `threads` threads sharing one run, and the decodes.
fn tiles_on(
    s: &Scene,
    plan: &MosaicPlan,
    threads: usize,
) -> (Vec<Result<AnyRaster, String>>, Vec<usize>) {
    let decodes: Vec<AtomicUsize> = s.images.iter().map(|_| AtomicUsize::new(0)).collect();
    let run = MosaicRun::new(plan, |f: &MosaicFrame| {
        let k = s.frames.iter().position(|g| g.path == f.path).unwrap();
        decodes[k].fetch_add(1, Ordering::Relaxed);
        Ok(s.images[k].clone())
    });
    let windows: Vec<Window> = plan.tile_windows().collect();
    let tiles = pool(threads).install(|| {
        windows
            .par_iter()
            .map(|&w| run.tile(w).map_err(|e| e.full_message()))
            .collect()
    });
    let decoded: Vec<usize> = decodes.iter().map(|n| n.load(Ordering::Relaxed)).collect();
    assert_eq!(run.loads(), decoded);
    (tiles, decoded)
}

#[test]
fn threads_share_decoded_frames_and_make_the_tiles_one_thread_makes() {
    let s = scene([0.0, 20.0, -20.0]);
    let opts = |cache_frames| MosaicOptions {
        tile_px: 32,
        cache_frames,
        cache_bytes: 0,
        ..MosaicOptions::default()
    };
    // A cache of every frame: each decoded once, however many tiles want it at once.
    let plan = MosaicPlan::new(s.frames.clone(), GSD, opts(3)).unwrap();
    let (serial, loads) = tiles_on(&s, &plan, 1);
    assert_eq!(loads, [1, 1, 1]);
    let (parallel, loads) = tiles_on(&s, &plan, 4);
    assert_eq!(loads, [1, 1, 1]);
    assert_eq!(parallel.len(), serial.len());
    let same = |a: &Result<AnyRaster, String>, b: &Result<AnyRaster, String>| match (a, b) {
        (Ok(AnyRaster::F32(a)), Ok(AnyRaster::F32(b))) => a.planes() == b.planes(),
        _ => false,
    };
    assert!(parallel.iter().zip(&serial).all(|(a, b)| same(a, b)));
    // A cache of one frame: frames let go while other threads render them, decoded again.
    let plan = MosaicPlan::new(s.frames.clone(), GSD, opts(1)).unwrap();
    let (parallel, loads) = tiles_on(&s, &plan, 4);
    assert!(loads.iter().sum::<usize>() > 3, "{loads:?}");
    assert!(parallel.iter().zip(&serial).all(|(a, b)| same(a, b)));
}

/// The cache holds as many frames as its bytes allow (counted by the largest frame), however
/// few it is asked to hold at least: bytes for all three frames decode each once, bytes for
/// one decode them again.
#[test]
fn the_cache_holds_as_many_frames_as_its_bytes_allow() {
    let s = scene([0.0, 20.0, -20.0]);
    // One f32 band.
    let largest = s
        .frames
        .iter()
        .map(|f| f.plan.camera.size.pixels())
        .max()
        .unwrap()
        * 4;
    for (bytes, once) in [(3 * largest, true), (largest, false)] {
        let opts = MosaicOptions {
            tile_px: 32,
            cache_frames: 1,
            cache_bytes: bytes,
            ..MosaicOptions::default()
        };
        let plan = MosaicPlan::new(s.frames.clone(), GSD, opts).unwrap();
        for threads in [1, 4] {
            let (_, loads) = tiles_on(&s, &plan, threads);
            assert_eq!(
                loads == [1, 1, 1],
                once,
                "{bytes} bytes, {threads}: {loads:?}"
            );
        }
    }
}

#[test]
fn a_frame_of_another_format_is_named_and_no_mosaic_is_left() {
    let mut s = scene([0.0; 3]);
    let AnyRaster::F32(f) = &s.images[1] else {
        panic!("f32 frames")
    };
    let bytes = f.plane(0).iter().map(|&v| v as u8).collect();
    s.images[1] = AnyRaster::U8(Raster::from_planes(f.size(), vec![bytes]).unwrap());
    let plan = MosaicPlan::new(s.frames.clone(), GSD, MosaicOptions::default()).unwrap();
    let (tiles, _) = tiles_on(&s, &plan, 4);
    let errors: Vec<&String> = tiles.iter().filter_map(|t| t.as_ref().err()).collect();
    assert!(!errors.is_empty());
    for e in errors {
        assert!(e.contains("frame1.tif: 1 bands of u8"), "{e}");
        assert!(e.contains("other frames have 1 of f32"), "{e}");
    }

    let dir = tempfile::tempdir().unwrap();
    let frames = frames_on_disk(&s, dir.path());
    let out = dir.path().join("mosaic.tif");
    let crs = aerorect::geo::Crs::from_epsg(32635).unwrap();
    let opts = MosaicOptions {
        tile_px: 64,
        ..MosaicOptions::default()
    };
    let e = pool(3)
        .install(|| aerorect::mosaic::mosaic(frames, crs, &out, &opts))
        .unwrap_err();
    assert!(e.full_message().contains("frame1.tif"), "{e:?}");
    let left = std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(left, 3, "the three frames and nothing else");
}
