//! Cloud-optimised GeoTIFF: read back with our TIFF reader and the `tiff` crate, the layout
//! checked by parsing the file's bytes here (independently of the writer's layout code), the
//! overviews against a slow 2x2-average oracle.
//!
//! GDAL's view, stored here: `python3 bench/check_cog.py` (rio-cogeo 7.0.4 `cog_validate` and
//! `rio cogeo validate`, rasterio 1.4.4 / GDAL 3.10.3) on files written by
//! `examples/write_cog.rs` from inputs rasterio wrote:
//!   rgb_deflate    u8 x3 1500 x 1100, tile 256, Deflate, overviews [2, 4, 8]      OK
//!   bigtiff        the same, tile 512, BigTIFF, overviews [2, 4]                   OK
//!   rgb_jpeg_mask  u8 RGBA 1200 x 900 -> RGB JPEG q90 + mask, overviews [2, 4, 8]  OK
//!   u16_nodata     u16 2000 x 1500, nodata 0, defaults (tile 512), [2, 4]           OK
//!   dem_f32        ../shared/data/ngi/dem.tif, f32 NaN nodata, tile 128, [2, 4]     OK
//! each "is a valid cloud optimized GeoTIFF" (no errors, no warnings); GDAL reads the full
//! resolution equal to the input (JPEG: mean error < 1.5), every overview equal to the 2x2
//! mean of the valid children computed in numpy, and the mask equal to alpha > 0.
#![allow(clippy::unwrap_used)]

use aerorect_core::ImageSize;
use aerorect_geo::Crs;
use aerorect_io::{
    CogCompression, CogMask, CogOptions, GeoReference, read_georeference, read_image, write_cog,
    write_image_cog,
};
use aerorect_raster::{AnyRaster, Raster};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult};

fn geo(nodata: Option<f64>) -> GeoReference {
    GeoReference {
        crs: Crs::from_epsg(32635).unwrap(),
        pixel_size: [0.5, 0.5],
        top_left: [500_000.0, 5_975_000.0],
        rotation: [0.0, 0.0],
        nodata,
    }
}

/// A deterministic textured image: a gradient plus a hash, so Deflate has work and tiles differ.
fn pattern(w: usize, h: usize, band: usize, max: u32) -> Vec<u32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let hash =
                (x.wrapping_mul(2_654_435_761) ^ y.wrapping_mul(40_503) ^ (band as u32 * 97)) >> 7;
            (x + 2 * y + hash % 17 + band as u32 * 31) % (max + 1)
        })
        .collect()
}

fn rgb_u8(w: usize, h: usize, bands: usize) -> Raster<u8> {
    let planes = (0..bands)
        .map(|b| pattern(w, h, b, 255).into_iter().map(|v| v as u8).collect())
        .collect();
    Raster::from_planes(ImageSize::new(w, h), planes).unwrap()
}

// ---- an independent TIFF header parser -------------------------------------------------

struct ParsedIfd {
    at: u64,
    /// SHORT, LONG and LONG8 values by tag (other types: empty).
    tags: BTreeMap<u16, Vec<u64>>,
    /// The end of the IFD's entries and of every out-of-line value it points to.
    end: u64,
}

fn le(b: &[u8], at: u64, n: usize) -> u64 {
    let at = at as usize;
    b[at..at + n]
        .iter()
        .rev()
        .fold(0u64, |acc, &x| (acc << 8) | u64::from(x))
}

/// (BigTIFF?, the IFD chain in file order).
fn parse(b: &[u8]) -> (bool, Vec<ParsedIfd>) {
    assert_eq!(&b[..2], b"II");
    let big = match le(b, 2, 2) {
        42 => false,
        43 => true,
        v => panic!("TIFF version {v}"),
    };
    let (word, count_len, entry_len) = if big { (8, 8, 20) } else { (4, 2, 12) };
    let mut next = if big { le(b, 8, 8) } else { le(b, 4, 4) };
    let mut out = Vec::new();
    while next != 0 {
        let n = le(b, next, count_len);
        let mut tags = BTreeMap::new();
        let mut end = next + count_len as u64 + n * entry_len + word as u64;
        for k in 0..n {
            let e = next + count_len as u64 + k * entry_len;
            let (tag, typ) = (le(b, e, 2) as u16, le(b, e + 2, 2));
            let count = le(b, e + 4, word);
            let size = match typ {
                1 | 2 | 7 => 1,
                3 => 2,
                4 => 4,
                12 | 16 => 8,
                t => panic!("type {t}"),
            };
            let bytes = count * size;
            let field = e + 4 + word as u64;
            let data = if bytes as usize > word {
                let off = le(b, field, word);
                end = end.max(off + bytes);
                off
            } else {
                field
            };
            let vals = match typ {
                3 | 4 | 16 => (0..count)
                    .map(|i| le(b, data + i * size, size as usize))
                    .collect(),
                _ => Vec::new(),
            };
            tags.insert(tag, vals);
        }
        out.push(ParsedIfd {
            at: next,
            tags,
            end,
        });
        next = le(b, next + count_len as u64 + n * entry_len, word);
    }
    (big, out)
}

impl ParsedIfd {
    fn one(&self, tag: u16) -> u64 {
        self.tags[&tag][0]
    }
    fn size(&self) -> (u64, u64) {
        (self.one(256), self.one(257))
    }
}

/// The checks every COG must pass: IFDs first and in order, all tag data before any tile,
/// tiles of each level after those of the next smaller one, the file ending with the last
/// full-resolution tile, GeoTIFF tags on the first IFD only. Returns the parsed IFDs.
fn check_cog_layout(path: &Path, tile: u64) -> (bool, Vec<ParsedIfd>) {
    let b = std::fs::read(path).unwrap();
    let (big, ifds) = parse(&b);
    assert_eq!(
        ifds[0].at,
        if big { 16 } else { 8 },
        "main IFD right after the header"
    );
    for w in ifds.windows(2) {
        assert!(w[0].at < w[1].at, "IFD offsets ascend");
    }
    let header_end = ifds.iter().map(|i| i.end).max().unwrap();
    let first_tile = ifds
        .iter()
        .flat_map(|i| i.tags[&324].clone())
        .min()
        .unwrap();
    assert!(
        header_end <= first_tile,
        "tag data ({header_end}) before tiles ({first_tile})"
    );
    for (k, ifd) in ifds.iter().enumerate() {
        assert_eq!(ifd.one(322), tile);
        assert_eq!(ifd.one(323), tile);
        assert!(tile.is_multiple_of(16));
        let (w, h) = ifd.size();
        let n = w.div_ceil(tile) * h.div_ceil(tile);
        assert_eq!(ifd.tags[&324].len() as u64, n, "IFD {k} tile count");
        assert_eq!(ifd.tags[&325].len() as u64, n);
        let geo = ifd.tags.contains_key(&33550) || ifd.tags.contains_key(&34735);
        assert_eq!(geo, k == 0, "GeoTIFF tags on the main IFD only (IFD {k})");
        let sub = ifd.one(254);
        assert_eq!(
            sub & 1 == 1,
            k > 0 && ifd.size() != ifds[0].size(),
            "IFD {k}"
        );
    }
    // Levels: the image IFDs (mask IFDs share their level's tile span).
    let span = |ifd: &ParsedIfd| {
        let o = &ifd.tags[&324];
        let c = &ifd.tags[&325];
        let lo = *o.iter().min().unwrap();
        let hi = o.iter().zip(c).map(|(a, b)| a + b).max().unwrap();
        (lo, hi)
    };
    let mut levels: Vec<(u64, u64)> = Vec::new();
    for ifd in &ifds {
        let (lo, hi) = span(ifd);
        if ifd.one(254) & 4 == 0 {
            levels.push((lo, hi));
        } else {
            let l = levels.last_mut().unwrap();
            *l = (l.0.min(lo), l.1.max(hi));
        }
    }
    for w in levels.windows(2) {
        assert!(
            w[1].1 <= w[0].0,
            "smaller overview's tiles first: {levels:?}"
        );
    }
    assert_eq!(
        levels[0].1,
        b.len() as u64,
        "the full resolution's tiles end the file"
    );
    (big, ifds)
}

// ---- an obvious overview oracle ----------------------------------------------------------

/// 2x2 means of the valid children (`valid(band, index)`), rounded half up for integers.
fn oracle_half(
    planes: &[Vec<f64>],
    w: usize,
    h: usize,
    valid: impl Fn(usize, usize) -> bool,
    fill: f64,
    round: bool,
) -> (Vec<Vec<f64>>, usize, usize) {
    let (w2, h2) = (w.div_ceil(2), h.div_ceil(2));
    let out = planes
        .iter()
        .enumerate()
        .map(|(b, p)| {
            let mut o = vec![fill; w2 * h2];
            for y in 0..h2 {
                for x in 0..w2 {
                    let mut v = Vec::new();
                    for (cx, cy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (sx, sy) = (2 * x + cx, 2 * y + cy);
                        if sx < w && sy < h && valid(b, sy * w + sx) {
                            v.push(p[sy * w + sx]);
                        }
                    }
                    if !v.is_empty() {
                        let m = v.iter().sum::<f64>() / v.len() as f64;
                        o[y * w2 + x] = if round { (m + 0.5).floor() } else { m };
                    }
                }
            }
            o
        })
        .collect();
    (out, w2, h2)
}

/// Image `k` of the file (the `tiff` crate's IFD order), as f64 planes.
fn read_ifd(path: &Path, k: usize, bands: usize) -> Vec<Vec<f64>> {
    let mut dec = Decoder::new(std::fs::File::open(path).unwrap()).unwrap();
    dec.seek_to_image(k).unwrap();
    let v: Vec<f64> = match dec.read_image().unwrap() {
        DecodingResult::U8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
        _ => panic!("sample type"),
    };
    (0..bands)
        .map(|b| v.iter().skip(b).step_by(bands).copied().collect())
        .collect()
}

fn same(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
}

// ---- tests ---------------------------------------------------------------------------------

#[test]
fn deflate_rgb_round_trips_with_the_cog_layout_and_averaged_overviews() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rgb.tif");
    let r = rgb_u8(1000, 700, 3);
    let opts = CogOptions {
        tile: 256,
        ..CogOptions::default()
    };
    write_cog(&p, &AnyRaster::U8(r.clone()), &geo(None), &opts).unwrap();
    assert_eq!(read_image(&p).unwrap(), AnyRaster::U8(r.clone()));
    assert_eq!(read_georeference(&p).unwrap(), Some(geo(None)));
    let (big, ifds) = check_cog_layout(&p, 256);
    assert!(!big);
    let sizes: Vec<_> = ifds.iter().map(|i| i.size()).collect();
    assert_eq!(sizes, [(1000, 700), (500, 350), (250, 175)]);
    let subfile: Vec<_> = ifds.iter().map(|i| i.one(254)).collect();
    assert_eq!(subfile, [0, 1, 1]);
    for ifd in &ifds {
        assert_eq!(ifd.one(259), 8, "Deflate");
        assert_eq!(ifd.one(262), 2, "RGB");
        assert_eq!(ifd.tags[&258], [8, 8, 8]);
    }
    let mut planes: Vec<Vec<f64>> = r
        .planes()
        .iter()
        .map(|p| p.iter().map(|&v| f64::from(v)).collect())
        .collect();
    let (mut w, mut h) = (1000, 700);
    for k in 1..3 {
        let (o, w2, h2) = oracle_half(&planes, w, h, |_, _| true, 0.0, true);
        let got = read_ifd(&p, k, 3);
        for b in 0..3 {
            assert!(same(&got[b], &o[b]), "overview {k} band {b}");
        }
        (planes, w, h) = (o, w2, h2);
    }
}

#[test]
fn nodata_is_left_out_of_the_overview_means() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("u16.tif");
    let (w, h) = (301, 203);
    let mut v: Vec<u16> = pattern(w, h, 0, 4000)
        .into_iter()
        .map(|x| x as u16 + 1)
        .collect();
    for (i, s) in v.iter_mut().enumerate() {
        let (x, y) = (i % w, i / w);
        if x < 40 || (x + y) % 7 == 0 || (y > 150 && x > 200) {
            *s = 0;
        }
    }
    let r = Raster::from_planes(ImageSize::new(w, h), vec![v.clone()]).unwrap();
    let opts = CogOptions {
        tile: 64,
        ..CogOptions::default()
    };
    write_cog(&p, &AnyRaster::U16(r.clone()), &geo(Some(0.0)), &opts).unwrap();
    assert_eq!(read_image(&p).unwrap(), AnyRaster::U16(r));
    assert_eq!(read_georeference(&p).unwrap().unwrap().nodata, Some(0.0));
    let (_, ifds) = check_cog_layout(&p, 64);
    let sizes: Vec<_> = ifds.iter().map(|i| i.size()).collect();
    assert_eq!(sizes, [(301, 203), (151, 102), (76, 51), (38, 26)]);
    let mut planes = vec![v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>()];
    let (mut w, mut h) = (w, h);
    for k in 1..ifds.len() {
        let pl = planes.clone();
        let (o, w2, h2) = oracle_half(&planes, w, h, |b, i| pl[b][i] != 0.0, 0.0, true);
        assert!(same(&read_ifd(&p, k, 1)[0], &o[0]), "overview {k}");
        (planes, w, h) = (o, w2, h2);
    }
    // A pixel whose four children are all nodata is nodata; the left strip is.
    assert_eq!(read_ifd(&p, 1, 1)[0][0], 0.0);
}

#[test]
fn nan_nodata_in_f32_and_one_level_when_the_image_fits_a_tile() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (90, 70);
    let mut v: Vec<f32> = (0..w * h).map(|i| (i as f32) * 0.37 - 100.0).collect();
    for (i, s) in v.iter_mut().enumerate() {
        if i % 5 == 0 || i % w < 4 {
            *s = f32::NAN;
        }
    }
    let r = Raster::from_planes(ImageSize::new(w, h), vec![v.clone()]).unwrap();
    let p = dir.path().join("f32.tif");
    let opts = CogOptions {
        tile: 32,
        nodata: Some(f64::NAN),
        ..CogOptions::default()
    };
    write_cog(&p, &AnyRaster::F32(r.clone()), &geo(None), &opts).unwrap();
    let back = read_image(&p).unwrap();
    let AnyRaster::F32(b) = back else { panic!() };
    let as64 = |x: &[f32]| x.iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
    assert!(same(&as64(b.plane(0)), &as64(&v)));
    assert!(
        read_georeference(&p)
            .unwrap()
            .unwrap()
            .nodata
            .unwrap()
            .is_nan()
    );
    let (_, ifds) = check_cog_layout(&p, 32);
    assert_eq!(ifds.len(), 3); // 90x70 -> 45x35 -> 23x18
    let planes = vec![as64(&v)];
    let (o, _, _) = oracle_half(
        &planes,
        w,
        h,
        |_, i| !planes[0][i].is_nan(),
        f64::NAN,
        false,
    );
    let got = read_ifd(&p, 1, 1);
    let tol = got[0]
        .iter()
        .zip(&o[0])
        .all(|(a, b)| (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-4 * b.abs().max(1.0));
    assert!(tol);
    assert!(got[0][0].is_nan(), "all four children NaN");

    let small = dir.path().join("small.tif");
    write_cog(
        &small,
        &AnyRaster::F32(r),
        &geo(None),
        &CogOptions::default(),
    )
    .unwrap();
    let (_, ifds) = check_cog_layout(&small, 512);
    assert_eq!(ifds.len(), 1);
    assert_eq!(ifds[0].tags[&339], [3], "IEEE float");
}

fn unpack_mask_tile(path: &Path, ifd: &ParsedIfd, t: usize, tile: usize) -> Vec<u8> {
    let b = std::fs::read(path).unwrap();
    let (o, c) = (ifd.tags[&324][t] as usize, ifd.tags[&325][t] as usize);
    let mut raw = Vec::new();
    flate2::read::ZlibDecoder::new(&b[o..o + c])
        .read_to_end(&mut raw)
        .unwrap();
    let rb = tile.div_ceil(8);
    assert_eq!(raw.len(), rb * tile);
    (0..tile * tile)
        .map(|i| (raw[(i / tile) * rb + (i % tile) / 8] >> (7 - i % 8)) & 1)
        .collect()
}

#[test]
fn a_mask_gets_its_own_ifds_after_each_image_and_masks_the_means() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("mask.tif");
    let (w, h) = (200, 130);
    let r = rgb_u8(w, h, 1);
    let mask: Vec<u8> = (0..w * h)
        .map(|i| u8::from(!((i % w) * 3 < (i / w) * 2 || (i % w) % 9 == 4)))
        .collect();
    let opts = CogOptions {
        tile: 64,
        mask: CogMask::Plane(mask.clone()),
        ..CogOptions::default()
    };
    write_cog(&p, &AnyRaster::U8(r.clone()), &geo(None), &opts).unwrap();
    assert_eq!(read_image(&p).unwrap(), AnyRaster::U8(r.clone()));
    let (_, ifds) = check_cog_layout(&p, 64);
    let kinds: Vec<_> = ifds.iter().map(|i| (i.one(254), i.size())).collect();
    assert_eq!(
        kinds,
        [
            (0, (200, 130)),
            (4, (200, 130)),
            (1, (100, 65)),
            (5, (100, 65)),
            (1, (50, 33)),
            (5, (50, 33))
        ]
    );
    for m in ifds.iter().filter(|i| i.one(254) & 4 != 0) {
        assert_eq!((m.one(258), m.one(262), m.one(277)), (1, 4, 1));
    }
    // Each image tile is followed by its mask tile.
    for pair in ifds.chunks(2) {
        let (io, ic) = (&pair[0].tags[&324], &pair[0].tags[&325]);
        for ((o, c), m) in io.iter().zip(ic).zip(&pair[1].tags[&324]) {
            assert_eq!(o + c, *m);
        }
    }
    // Mask tile (1, 1) of the full resolution and tile 0 of the first overview (nearest).
    let t11 = unpack_mask_tile(&p, &ifds[1], 5, 64); // 4 tiles across
    for j in 0..64 {
        for i in 0..64 {
            let (x, y) = (64 + i, 64 + j);
            let want = if x < w && y < h {
                u8::from(mask[y * w + x] != 0)
            } else {
                0
            };
            assert_eq!(t11[j * 64 + i], want, "({x}, {y})");
        }
    }
    let o0 = unpack_mask_tile(&p, &ifds[3], 0, 64);
    for y in 0..64 {
        for x in 0..64 {
            assert_eq!(o0[y * 64 + x], u8::from(mask[2 * y * w + 2 * x] != 0));
        }
    }
    let planes = vec![r.plane(0).iter().map(|&v| f64::from(v)).collect::<Vec<_>>()];
    let (o, _, _) = oracle_half(&planes, w, h, |_, i| mask[i] != 0, 0.0, true);
    assert!(
        same(&read_ifd(&p, 2, 1)[0], &o[0]),
        "first overview over the mask"
    );
}

fn smooth_rgba(w: usize, h: usize) -> Raster<u8> {
    let f = |i: usize, b: usize| {
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        let v = 128.0 + 90.0 * ((x / 37.0 + b as f64).sin() * (y / 53.0).cos());
        v.round() as u8
    };
    let mut planes: Vec<Vec<u8>> = (0..3)
        .map(|b| (0..w * h).map(|i| f(i, b)).collect())
        .collect();
    planes.push(
        (0..w * h)
            .map(|i| if i % w > 30 { 255 } else { 0 })
            .collect(),
    );
    Raster::from_planes(ImageSize::new(w, h), planes).unwrap()
}

#[test]
fn jpeg_rgb_with_the_alpha_band_as_mask_reads_back_within_jpeg_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("jpeg.tif");
    let (w, h) = (600, 400);
    let r = smooth_rgba(w, h);
    let opts = CogOptions {
        tile: 256,
        compression: CogCompression::Jpeg { quality: 90 },
        mask: CogMask::AlphaBand,
        ..CogOptions::default()
    };
    write_image_cog(&p, &AnyRaster::U8(r.clone()), Some(&geo(None)), &opts).unwrap();
    let (_, ifds) = check_cog_layout(&p, 256);
    let kinds: Vec<_> = ifds.iter().map(|i| i.one(254)).collect();
    assert_eq!(kinds, [0, 4, 1, 5, 1, 5]); // 600x400, 300x200, 150x100
    assert_eq!((ifds[0].one(259), ifds[0].one(262)), (7, 6), "JPEG, YCbCr");
    assert_eq!(ifds[0].tags[&530], [1, 1]);
    assert_eq!(ifds[1].one(259), 8, "masks are Deflate");
    let AnyRaster::U8(back) = read_image(&p).unwrap() else {
        panic!()
    };
    assert_eq!(back.bands(), 3, "alpha became the mask");
    let (mut sum, mut max, mut n) = (0.0, 0i32, 0.0);
    for b in 0..3 {
        for (a, c) in back.plane(b).iter().zip(r.plane(b)) {
            let d = (i32::from(*a) - i32::from(*c)).abs();
            sum += f64::from(d);
            max = max.max(d);
            n += 1.0;
        }
    }
    assert!(sum / n < 1.5 && max < 16, "mean {} max {max}", sum / n);

    let gray = dir.path().join("gray.tif");
    let g = rgb_u8(300, 300, 1);
    let opts = CogOptions {
        tile: 128,
        compression: CogCompression::Jpeg { quality: 95 },
        ..CogOptions::default()
    };
    write_cog(&gray, &AnyRaster::U8(g.clone()), &geo(None), &opts).unwrap();
    let (_, ifds) = check_cog_layout(&gray, 128);
    assert_eq!((ifds[0].one(259), ifds[0].one(262)), (7, 1));
    let AnyRaster::U8(back) = read_image(&gray).unwrap() else {
        panic!()
    };
    let mean = back
        .plane(0)
        .iter()
        .zip(g.plane(0))
        .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
        .sum::<f64>()
        / 90_000.0;
    assert!(mean < 4.0, "{mean}");
}

#[test]
fn bigtiff_on_request_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.tif");
    let r = rgb_u8(530, 300, 4);
    let opts = CogOptions {
        tile: 128,
        bigtiff: Some(true),
        ..CogOptions::default()
    };
    write_cog(&p, &AnyRaster::U8(r.clone()), &geo(None), &opts).unwrap();
    let (big, ifds) = check_cog_layout(&p, 128);
    assert!(big);
    assert_eq!(ifds.len(), 4); // 530 -> 265 -> 133 -> 67
    assert_eq!(ifds[0].tags[&338], [2], "unassociated alpha");
    assert_eq!(read_image(&p).unwrap(), AnyRaster::U8(r));
    assert_eq!(read_georeference(&p).unwrap(), Some(geo(None)));
}

#[test]
fn bad_options_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.tif");
    let u16img = AnyRaster::U16(
        Raster::from_planes(ImageSize::new(40, 30), vec![vec![7u16; 1200]]).unwrap(),
    );
    let u8img = AnyRaster::U8(rgb_u8(40, 30, 1));
    let jpeg = CogCompression::Jpeg { quality: 80 };
    let cases: Vec<(AnyRaster, CogOptions, &str)> = vec![
        (
            u16img.clone(),
            CogOptions {
                compression: jpeg,
                ..CogOptions::default()
            },
            "JPEG COG takes 8-bit",
        ),
        (
            u8img.clone(),
            CogOptions {
                deflate_level: 0,
                ..CogOptions::default()
            },
            "Deflate level 0",
        ),
        (
            u8img.clone(),
            CogOptions {
                tile: 100,
                ..CogOptions::default()
            },
            "multiple of 16",
        ),
        (
            u8img.clone(),
            CogOptions {
                mask: CogMask::Plane(vec![1; 10]),
                ..CogOptions::default()
            },
            "mask has 10 values",
        ),
        (
            u8img.clone(),
            CogOptions {
                mask: CogMask::AlphaBand,
                ..CogOptions::default()
            },
            "not 2 or 4",
        ),
        (
            u8img.clone(),
            CogOptions {
                compression: jpeg,
                nodata: Some(0.0),
                ..CogOptions::default()
            },
            "JPEG changes the values",
        ),
        (
            u8img.clone(),
            CogOptions {
                nodata: Some(300.0),
                ..CogOptions::default()
            },
            "not a u8 value",
        ),
        (
            u8img.clone(),
            CogOptions {
                nodata: Some(0.0),
                mask: CogMask::Plane(vec![1; 1200]),
                ..CogOptions::default()
            },
            "choose one",
        ),
        (
            u8img.clone(),
            CogOptions {
                compression: CogCompression::Jpeg { quality: 0 },
                ..CogOptions::default()
            },
            "quality 0",
        ),
    ];
    for (img, opts, want) in cases {
        let e = write_cog(&p, &img, &geo(None), &opts)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{e}");
        assert!(e.contains("bad.tif"), "{e}");
    }
    let e = write_image_cog(
        &dir.path().join("x.png"),
        &u8img,
        None,
        &CogOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains(".tif"), "{e}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing left behind"
    );
}

#[test]
fn without_a_georeference_it_is_a_plain_tiled_tiff() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("plain.tif");
    let r = AnyRaster::U8(rgb_u8(100, 50, 2));
    write_image_cog(
        &p,
        &r,
        None,
        &CogOptions {
            tile: 16,
            ..CogOptions::default()
        },
    )
    .unwrap();
    assert_eq!(read_image(&p).unwrap(), r);
    assert_eq!(read_georeference(&p).unwrap(), None);
    let b = std::fs::read(&p).unwrap();
    let (_, ifds) = parse(&b);
    assert!(ifds.iter().all(|i| !i.tags.contains_key(&34735)));
    assert_eq!(ifds.last().unwrap().size(), (13, 7));
}
