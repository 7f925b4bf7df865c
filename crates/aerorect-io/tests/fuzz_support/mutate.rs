//! Seeded mutation: bit flips, random bytes, truncation, deletion, duplication and splices from
//! other seeds, boundary integers written into the header fields the seed's structure names
//! (TIFF/BigTIFF and EXIF entries, PNG IHDR, JPEG segment lengths and frame size) or anywhere,
//! PNG CRCs repaired so a mutation reaches the decoder, and token-level edits of text files.

use super::seeds::Seed;

/// SplitMix64: small, seedable and good enough to pick mutations.
pub struct Rng(u64);

impl Rng {
    /// The generator of input `index` of a run with `seed`: every input is reproducible alone.
    pub fn for_input(seed: u64, index: u64) -> Self {
        let mut r = Rng(seed ^ 0x5851_F42D_4C95_7F2D);
        let a = r.next();
        Rng(a ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in 0..n (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    pub fn chance(&mut self, one_in: usize) -> bool {
        self.below(one_in) == 0
    }
}

/// An integer field of the seed's structure: where it is, its width in bytes, its byte order.
#[derive(Debug, Clone, Copy)]
pub struct Field {
    pub pos: usize,
    pub width: usize,
    pub big_endian: bool,
}

/// Values at the edges of a field of `width` bytes, and a few small ones.
fn boundary(rng: &mut Rng, width: usize, file_len: usize) -> u64 {
    let max = if width >= 8 {
        u64::MAX
    } else {
        (1u64 << (8 * width)) - 1
    };
    let half = max / 2;
    let picks = [
        0,
        1,
        2,
        3,
        4,
        7,
        8,
        16,
        255,
        256,
        max,
        max - 1,
        half,
        half + 1,
        file_len as u64,
        file_len as u64 + 1,
        file_len.saturating_sub(1) as u64,
        rng.next(),
    ];
    picks[rng.below(picks.len())] & max
}

fn put(bytes: &mut [u8], f: Field, v: u64) {
    if f.pos + f.width > bytes.len() {
        return;
    }
    let b = if f.big_endian {
        v.to_be_bytes()[8 - f.width..].to_vec()
    } else {
        v.to_le_bytes()[..f.width].to_vec()
    };
    bytes[f.pos..f.pos + f.width].copy_from_slice(&b);
}

const DICT: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "+inf",
    "1e308",
    "-1e308",
    "1e999",
    "0",
    "-0",
    "-1",
    "4294967296",
    "18446744073709551616",
    "9999999999",
    "1e-320",
    "0x10",
    "1_000",
    "\"",
    "'",
    "\n",
    "\r\n",
    ",",
    ";",
    "=",
    "[",
    "]",
    "[[",
    "{",
    "}",
    "#",
    "\0",
    "\u{feff}",
    "é",
    "\u{1d11e}",
    "-90",
    "+90",
    "180",
    "360",
    "true",
    "\"\"\"",
    "<",
    ">",
    "&amp;",
    "&#0;",
    "&#x110000;",
    "<!DOCTYPE x [<!ENTITY a \"aaaaaaaa\">]>",
    "&a;",
    "xmlns:",
    "drone-dji:",
    "rdf:",
    "model",
    "opencv",
    "brown",
    "tsai",
    "improved",
    "k1",
    "image_size_px",
    "[distortion]",
    "AUTHORITY[",
    "PROJCS[",
    "GEOGCS[",
    "UNIT[",
    "PARAMETER[",
    "+proj=",
    "+zone=",
    "+lon_0=",
    "tmerc",
    "utm",
    "longlat",
    "EPSG:",
    "ESRI:",
    "32635",
    "4326",
    " ",
    "\t",
    "",
    "x",
];

fn text_token(rng: &mut Rng) -> &'static [u8] {
    DICT[rng.below(DICT.len())].as_bytes()
}

/// The span of the token (a run of number or word characters) around `at`.
fn token_at(b: &[u8], at: usize) -> (usize, usize) {
    let word = |c: u8| c.is_ascii_alphanumeric() || b"+-._".contains(&c);
    let (mut s, mut e) = (at, at);
    while s > 0 && word(b[s - 1]) {
        s -= 1;
    }
    while e < b.len() && word(b[e]) {
        e += 1;
    }
    (s, e)
}

fn lines(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, &c) in b.iter().enumerate() {
        if c == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < b.len() {
        out.push((s, b.len()));
    }
    out
}

fn text_op(rng: &mut Rng, b: &mut Vec<u8>) {
    let at = rng.below(b.len() + 1);
    match rng.below(5) {
        0 if !b.is_empty() => {
            let (s, e) = token_at(b, at.min(b.len() - 1));
            b.splice(s..e, text_token(rng).iter().copied());
        }
        1 => {
            b.splice(at..at, text_token(rng).iter().copied());
        }
        2 | 3 => {
            let ls = lines(b);
            if ls.is_empty() {
                return;
            }
            let (s, e) = ls[rng.below(ls.len())];
            let line = b[s..e].to_vec();
            if rng.chance(2) {
                let (t, _) = ls[rng.below(ls.len())];
                b.splice(t..t, line);
            } else {
                b.drain(s..e);
            }
        }
        _ => {
            // A long run: a huge number or a deep nesting.
            let unit = text_token(rng).to_vec();
            let n = [2usize, 16, 256, 4096][rng.below(4)];
            let run: Vec<u8> = unit.iter().copied().cycle().take(unit.len() * n).collect();
            b.splice(at..at, run);
        }
    }
}

fn byte_op(rng: &mut Rng, b: &mut Vec<u8>, seed: &Seed, others: &[Seed]) {
    let len = b.len();
    match rng.below(8) {
        0 if len > 0 => {
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
        }
        1 if len > 0 => {
            for _ in 0..1 + rng.below(4) {
                let i = rng.below(len);
                b[i] = rng.next() as u8;
            }
        }
        2 => b.truncate(rng.below(len + 1)),
        3 if len > 0 => {
            let s = rng.below(len);
            let e = (s + 1 + rng.below(64.min(len - s))).min(len);
            b.drain(s..e);
        }
        4 if len > 0 => {
            // Duplicate a chunk in place (a repeated segment or IFD entry).
            let s = rng.below(len);
            let e = (s + 1 + rng.below(256)).min(len);
            let chunk = b[s..e].to_vec();
            let at = rng.below(len + 1);
            b.splice(at..at, chunk);
        }
        5 => {
            // Splice from another seed (or this one): overwrite or insert.
            let other = &others[rng.below(others.len())].bytes;
            if other.is_empty() {
                return;
            }
            let s = rng.below(other.len());
            let e = (s + 1 + rng.below(1024)).min(other.len());
            let at = rng.below(len + 1);
            if rng.chance(2) {
                b.splice(at..at, other[s..e].iter().copied());
            } else {
                let end = (at + e - s).min(len);
                b.splice(at..end, other[s..e].iter().copied());
            }
        }
        6 if !seed.fields.is_empty() => {
            let f = seed.fields[rng.below(seed.fields.len())];
            let v = boundary(rng, f.width, len);
            put(b, f, v);
        }
        _ if len > 0 => {
            let width = [1, 2, 4, 8][rng.below(4)];
            let f = Field {
                pos: rng.below(len),
                width,
                big_endian: rng.chance(2),
            };
            let v = boundary(rng, width, len);
            put(b, f, v);
        }
        _ => b.push(rng.next() as u8),
    }
}

/// Recomputes every PNG chunk's CRC (half the time), so a mutation inside a chunk reaches the
/// decoder instead of failing the checksum.
pub fn fix_png_crcs(b: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= b.len() {
        let n = u32::from_be_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]) as usize;
        let Some(end) = (at + 8).checked_add(n).filter(|e| e + 4 <= b.len()) else {
            return;
        };
        let crc = crc32(&b[at + 4..end]);
        b[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        at = end + 4;
    }
}

fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &x in data {
        c ^= u32::from(x);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// One mutated input from `seed`: one to four operations (text seeds get token edits too).
pub fn mutate(rng: &mut Rng, seed: &Seed, others: &[Seed]) -> Vec<u8> {
    let mut b = seed.bytes.clone();
    for _ in 0..1 + rng.below(4) {
        if seed.kind.is_text() && rng.chance(2) {
            text_op(rng, &mut b);
        } else {
            byte_op(rng, &mut b, seed, others);
        }
    }
    if b.starts_with(b"\x89PNG") && rng.chance(2) {
        fix_png_crcs(&mut b);
    }
    b
}
