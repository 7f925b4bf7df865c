//! Fuzzing of every reader in aerorect-io with seeded byte mutation of real files (see
//! `fuzz_support`): images (PNG, JPEG, TIFF, BigTIFF, GeoTIFF tags, JPEG-in-TIFF), EXIF and XMP,
//! camera and attitude TOML, the other tools' camera files, the CSV tables and CRS strings. Properties: no panic, an error
//! names its file, no allocation beyond the readers' limits.
//!
//! `cargo test` runs a short pass (a few thousand inputs). A longer one, as .ci/run runs it:
//!
//! ```sh
//! AERORECT_FUZZ_SECONDS=60 AERORECT_FUZZ_SEED=1 \
//!     cargo test -p aerorect-io --release --test fuzz -- --ignored --nocapture fuzz_pass
//! ```
//!
//! `AERORECT_FUZZ_INPUTS` caps the count, `AERORECT_FUZZ_THREADS` sets the workers (default:
//! every core). `AERORECT_FUZZ_REPLAY=N` rebuilds input N of the seed's run, saves it under
//! target/tmp/fuzz/ and runs it alone. Inputs that break a property are saved there too.
#![allow(clippy::unwrap_used)]

mod fuzz_support;

use aerorect_io::{decode_image_bytes, read_image};
use fuzz_support::{Config, alloc, targets};

#[global_allocator]
static ALLOC: alloc::Tracking = alloc::Tracking;

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn check(cfg: &Config) {
    let s = fuzz_support::run(cfg);
    let text = fuzz_support::report(cfg, &s);
    println!("{text}");
    assert!(s.findings.is_empty(), "{text}");
}

#[test]
fn a_short_pass_finds_nothing() {
    check(&Config {
        seed: 12,
        inputs: Some(1000),
        seconds: None,
        threads: 1,
    });
}

/// The long pass (ignored by default; .ci/run runs it for a minute).
#[test]
#[ignore = "long: AERORECT_FUZZ_SECONDS (default 60) of fuzzing"]
fn fuzz_pass() {
    let cfg = Config {
        seed: env("AERORECT_FUZZ_SEED").unwrap_or(1),
        inputs: env("AERORECT_FUZZ_INPUTS"),
        seconds: Some(env("AERORECT_FUZZ_SECONDS").unwrap_or(60.0)),
        threads: env("AERORECT_FUZZ_THREADS").unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        }),
    };
    if let Some(index) = env::<u64>("AERORECT_FUZZ_REPLAY") {
        targets::install_panic_hook();
        let dir = tempfile::tempdir().unwrap();
        let seeds = fuzz_support::seeds::all(dir.path());
        let (s, bytes) = fuzz_support::input(&seeds, cfg.seed, index);
        let saved = fuzz_support::out_dir().join(format!("replay-{index}-{}", seeds[s].name));
        std::fs::write(&saved, &bytes).unwrap();
        println!(
            "input {index} (from {}) saved as {}",
            seeds[s].name,
            saved.display()
        );
        for c in targets::run(seeds[s].kind, &bytes, dir.path()) {
            let v = match c.verdict {
                targets::Verdict::Ok => "ok".to_string(),
                targets::Verdict::Err => "refused".to_string(),
                targets::Verdict::Finding(w) => format!("FINDING {w}"),
            };
            println!(
                "  {:<28} {v} ({:.3} s, peak {} bytes)",
                c.reader, c.seconds, c.peak
            );
        }
        return;
    }
    check(&cfg);
}

/// Every seed is read without error by its readers: the mutations start from valid files.
#[test]
fn every_seed_is_read() {
    targets::install_panic_hook();
    let dir = tempfile::tempdir().unwrap();
    let seeds = fuzz_support::seeds::all(dir.path());
    assert!(seeds.len() >= 30, "{} seeds", seeds.len());
    for s in &seeds {
        let calls = targets::run(s.kind, &s.bytes, dir.path());
        let ok = |c: &targets::Call| matches!(c.verdict, targets::Verdict::Ok);
        // Images must decode; a table must be read by its own reader (the others refuse it).
        let refused = |c: &targets::Call| matches!(c.verdict, targets::Verdict::Err);
        let must = match s.kind {
            fuzz_support::seeds::Kind::Image => calls.iter().take(1).all(ok),
            // Bombs and oversized texts: every camera reader refuses them.
            fuzz_support::seeds::Kind::HostileCamera => calls.iter().all(refused),
            _ => calls.iter().any(ok),
        };
        assert!(must, "seed {} is refused by its reader", s.name);
        for c in &calls {
            assert!(
                !matches!(c.verdict, targets::Verdict::Finding(_)),
                "seed {}: {}",
                s.name,
                c.reader
            );
        }
    }
}

/// Inputs the fuzzer found breaking a property, kept in tests/fuzz_regressions as
/// `SEED--what` (SEED: the seed file it was mutated from), go through their readers again.
#[test]
fn found_inputs_stay_fixed() {
    targets::install_panic_hook();
    let dir = tempfile::tempdir().unwrap();
    let seeds = fuzz_support::seeds::all(dir.path());
    let found = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    let mut n = 0;
    for entry in std::fs::read_dir(found).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let (seed, _) = name.split_once("--").unwrap();
        let kind = seeds.iter().find(|s| s.name == seed).unwrap().kind;
        for c in targets::run(kind, &std::fs::read(&path).unwrap(), dir.path()) {
            if let targets::Verdict::Finding(what) = c.verdict {
                panic!("{name}: {}: {what}", c.reader);
            }
        }
        n += 1;
    }
    assert!(n > 0);
}

/// `bytes` with the TIFF entry `tag` of the first IFD (little-endian, LONG) set to `value`.
fn set_tiff_tag(bytes: &mut [u8], tag: u16, value: u32) {
    let ifd = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
    let n = usize::from(u16::from_le_bytes([bytes[ifd], bytes[ifd + 1]]));
    let e = (0..n)
        .map(|i| ifd + 2 + 12 * i)
        .find(|&e| u16::from_le_bytes([bytes[e], bytes[e + 1]]) == tag)
        .unwrap();
    bytes[e + 2..e + 4].copy_from_slice(&4u16.to_le_bytes());
    bytes[e + 4..e + 8].copy_from_slice(&1u32.to_le_bytes());
    bytes[e + 8..e + 12].copy_from_slice(&value.to_le_bytes());
}

/// A header claiming a huge image is refused, naming the file, before anything near its size
/// is allocated; one claiming less than the 4 GiB limit but holding a few bytes allocates at
/// most the limit (lazily zeroed pages) and is refused when its data runs out.
#[test]
fn huge_dimension_headers_are_refused_without_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = fuzz_support::seeds::all(dir.path());
    let bytes = |name: &str| seeds.iter().find(|s| s.name == name).unwrap().bytes.clone();
    let mut png = bytes("rgb8.png");
    png[16..24].copy_from_slice(&[0, 1, 0x86, 0xA0, 0, 1, 0x86, 0xA0]); // 100000 x 100000
    fuzz_support::mutate::fix_png_crcs(&mut png);
    let mut jpeg = bytes("small.jpg");
    let sof = (2..jpeg.len())
        .find(|&i| jpeg[i] == 0xFF && jpeg[i + 1] == 0xC0)
        .unwrap();
    jpeg[sof + 5..sof + 9].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF]); // 65535 x 65535
    let mut tiff = bytes("rgb8.tif");
    set_tiff_tag(&mut tiff, 256, 200_000);
    set_tiff_tag(&mut tiff, 257, 200_000);
    let mut big = bytes("bigtiff-rgb16.tif");
    let at = big.windows(4).position(|w| w == [0, 1, 4, 0]).unwrap(); // ImageWidth, LONG
    big[at + 12..at + 16].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    for (name, b) in [
        ("huge.png", png),
        ("huge.jpg", jpeg),
        ("huge.tif", tiff),
        ("huge-big.tif", big),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, &b).unwrap();
        let base = alloc::reset();
        let e = read_image(&p).unwrap_err().to_string();
        let e2 = decode_image_bytes(&b, name).unwrap_err().to_string();
        let (peak, _) = alloc::measured(base);
        assert!(e.contains(name) && e2.contains(name), "{e} / {e2}");
        assert!(peak < 64 << 20, "{name}: {peak} bytes allocated");
    }
    // 20000 x 20000 RGB = 1.2 GB claimed by a 3 KB PNG: under the 4 GiB limit, but more than
    // its data could inflate to; refused before the buffer is allocated.
    let mut png = bytes("rgb8.png");
    png[16..24].copy_from_slice(&[0, 0, 0x4E, 0x20, 0, 0, 0x4E, 0x20]);
    fuzz_support::mutate::fix_png_crcs(&mut png);
    let p = dir.path().join("lying.png");
    std::fs::write(&p, &png).unwrap();
    let base = alloc::reset();
    let e = read_image_f(&p);
    let (peak, _) = alloc::measured(base);
    assert!(peak < 64 << 20, "lying.png: {peak} bytes allocated");
    assert!(
        e.contains("lying.png") && e.contains("the header claims 20000 x 20000"),
        "{e}"
    );
    // 30000 x 30000 RGB = 2.7 GB claimed by a 3 KB file: under the 4 GiB limit, but more than
    // the file could decompress to; refused before the buffer is allocated.
    for (seed, read) in [
        ("rgb8.tif", read_image_f as fn(&_) -> _),
        ("dem-wkt.tif", read_dem_f),
    ] {
        let mut tiff = bytes(seed);
        set_tiff_tag(&mut tiff, 256, 30_000);
        set_tiff_tag(&mut tiff, 257, 30_000);
        set_tiff_tag(&mut tiff, 278, 30_000); // RowsPerStrip: the one strip holds every row
        let p = dir.path().join("lying.tif");
        std::fs::write(&p, &tiff).unwrap();
        let base = alloc::reset();
        let e = read(&p);
        let (peak, _) = alloc::measured(base);
        assert!(peak < 64 << 20, "{seed}: {peak} bytes allocated");
        assert!(
            e.contains("lying.tif") && e.contains("the header claims 30000 x 30000"),
            "{e}"
        );
    }
}

fn read_image_f(p: &std::path::Path) -> String {
    read_image(p).unwrap_err().to_string()
}

fn read_dem_f(p: &std::path::Path) -> String {
    aerorect_io::read_dem(p).unwrap_err().to_string()
}
