//! The byte layout of a cloud-optimised TIFF's header: every IFD, each followed by its own
//! out-of-line tag values, then the TileOffsets and TileByteCounts arrays of all IFDs (in IFD
//! order), then the tile data. Classic little-endian TIFF or BigTIFF. An IFD without a
//! TileWidth tag is striped: its arrays are StripOffsets and StripByteCounts (the parallel
//! strip writer, `strip_tiff`, lays out its one IFD here too).
//!
//! The header is built with zeroed offset and byte-count arrays; the writer records where
//! each array lies ([`Layout::offsets_at`], [`Layout::counts_at`]) and fills them in once the
//! tiles are written.

pub(crate) const NEW_SUBFILE_TYPE: u16 = 254;
pub(crate) const STRIP_OFFSETS: u16 = 273;
pub(crate) const STRIP_BYTE_COUNTS: u16 = 279;
pub(crate) const TILE_WIDTH: u16 = 322;
pub(crate) const TILE_OFFSETS: u16 = 324;
pub(crate) const TILE_BYTE_COUNTS: u16 = 325;

/// A tag value.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Value {
    Short(Vec<u16>),
    Long(Vec<u32>),
    Double(Vec<f64>),
    /// Numerator and denominator.
    Rational(Vec<[u32; 2]>),
    /// Written NUL-terminated.
    Ascii(String),
}

impl From<crate::geotiff::GeoTagValue> for Value {
    fn from(v: crate::geotiff::GeoTagValue) -> Self {
        use crate::geotiff::GeoTagValue as G;
        match v {
            G::Doubles(d) => Value::Double(d),
            G::Shorts(s) => Value::Short(s),
            G::Ascii(a) => Value::Ascii(a),
        }
    }
}

impl Value {
    /// TIFF field type and count.
    fn type_and_count(&self) -> (u16, u64) {
        match self {
            Value::Short(v) => (3, v.len() as u64),
            Value::Long(v) => (4, v.len() as u64),
            Value::Double(v) => (12, v.len() as u64),
            Value::Rational(v) => (5, v.len() as u64),
            Value::Ascii(s) => (2, s.len() as u64 + 1),
        }
    }

    fn bytes(&self) -> Vec<u8> {
        match self {
            Value::Short(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Value::Long(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Value::Double(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Value::Rational(v) => v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect(),
            Value::Ascii(s) => s.bytes().chain(std::iter::once(0)).collect(),
        }
    }
}

/// One IFD: its tags (TileOffsets and TileByteCounts, or StripOffsets and StripByteCounts,
/// left out) and its number of tiles (or strips).
#[derive(Debug, Clone)]
pub(crate) struct Ifd {
    pub tags: Vec<(u16, Value)>,
    pub tiles: usize,
}

impl Ifd {
    /// The tags of the offset and byte-count arrays: tiles when the IFD has a TileWidth.
    fn array_tags(&self) -> [u16; 2] {
        if self.tags.iter().any(|(t, _)| *t == TILE_WIDTH) {
            [TILE_OFFSETS, TILE_BYTE_COUNTS]
        } else {
            [STRIP_OFFSETS, STRIP_BYTE_COUNTS]
        }
    }
}

/// The header bytes and where the arrays to fill in lie in them.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub bytes: Vec<u8>,
    pub big: bool,
    /// File offset of each IFD's TileOffsets values (in its entry when they fit there).
    pub offsets_at: Vec<u64>,
    /// File offset of each IFD's TileByteCounts values.
    pub counts_at: Vec<u64>,
}

impl Layout {
    /// Bytes of one offset or count: 4 (LONG) or 8 (LONG8, BigTIFF).
    pub fn word(&self) -> usize {
        if self.big { 8 } else { 4 }
    }

    /// The array bytes of `values`; `None` when a value does not fit a classic TIFF's LONG.
    pub fn array(&self, values: &[u64]) -> Option<Vec<u8>> {
        let mut out = Vec::with_capacity(values.len() * self.word());
        for &v in values {
            if self.big {
                out.extend_from_slice(&v.to_le_bytes());
            } else {
                out.extend_from_slice(&u32::try_from(v).ok()?.to_le_bytes());
            }
        }
        Some(out)
    }
}

struct Entry {
    tag: u16,
    typ: u16,
    count: u64,
    data: Vec<u8>,
    /// The two arrays, placed after every IFD.
    deferred: bool,
}

/// Lays out `ifds` (in file order) with zeroed TileOffsets/TileByteCounts arrays.
pub(crate) fn layout(ifds: &[Ifd], big: bool) -> Layout {
    let word = if big { 8 } else { 4 };
    let (entry_len, count_len) = if big { (20, 8) } else { (12, 2) };
    let mut tables: Vec<Vec<Entry>> = ifds.iter().map(|ifd| entries(ifd, big)).collect();
    for t in &mut tables {
        t.sort_by_key(|e| e.tag);
    }
    // Positions: IFDs with their own values, then the deferred arrays.
    let mut pos = if big { 16u64 } else { 8 };
    let mut ifd_at = Vec::new();
    let mut value_at: Vec<Vec<Option<u64>>> = Vec::new();
    for t in &tables {
        ifd_at.push(pos);
        pos += (count_len + entry_len * t.len() + word) as u64;
        let mut at = Vec::new();
        for e in t {
            if e.data.len() > word && !e.deferred {
                pos += pos % 2; // word boundary
                at.push(Some(pos));
                pos += e.data.len() as u64;
            } else {
                at.push(None);
            }
        }
        value_at.push(at);
    }
    for (t, at) in tables.iter().zip(&mut value_at) {
        for (e, a) in t.iter().zip(at.iter_mut()) {
            if e.deferred && e.data.len() > word {
                *a = Some(pos);
                pos += e.data.len() as u64;
            }
        }
    }
    let mut bytes = Vec::with_capacity(pos as usize);
    if big {
        bytes.extend_from_slice(b"II");
        bytes.extend_from_slice(&43u16.to_le_bytes());
        bytes.extend_from_slice(&8u16.to_le_bytes());
        bytes.extend_from_slice(&0u16.to_le_bytes());
        bytes.extend_from_slice(&ifd_at[0].to_le_bytes());
    } else {
        bytes.extend_from_slice(b"II");
        bytes.extend_from_slice(&42u16.to_le_bytes());
        bytes.extend_from_slice(&(ifd_at[0] as u32).to_le_bytes());
    }
    let put_word = |bytes: &mut Vec<u8>, v: u64| {
        if big {
            bytes.extend_from_slice(&v.to_le_bytes());
        } else {
            bytes.extend_from_slice(&(v as u32).to_le_bytes());
        }
    };
    let (mut offsets_at, mut counts_at) = (Vec::new(), Vec::new());
    for (i, (t, at)) in tables.iter().zip(&value_at).enumerate() {
        debug_assert_eq!(bytes.len() as u64, ifd_at[i]);
        put_word_count(&mut bytes, t.len(), big);
        for (e, a) in t.iter().zip(at) {
            bytes.extend_from_slice(&e.tag.to_le_bytes());
            bytes.extend_from_slice(&e.typ.to_le_bytes());
            put_word(&mut bytes, e.count);
            let field = bytes.len() as u64;
            let data_at = match a {
                Some(off) => {
                    put_word(&mut bytes, *off);
                    *off
                }
                None => {
                    let mut inline = e.data.clone();
                    inline.resize(word, 0);
                    bytes.extend_from_slice(&inline);
                    field
                }
            };
            match (e.deferred, e.tag) {
                (true, TILE_OFFSETS | STRIP_OFFSETS) => offsets_at.push(data_at),
                (true, TILE_BYTE_COUNTS | STRIP_BYTE_COUNTS) => counts_at.push(data_at),
                _ => {}
            }
        }
        put_word(&mut bytes, ifd_at.get(i + 1).copied().unwrap_or(0));
        for (e, a) in t.iter().zip(at) {
            if let (Some(off), false) = (a, e.deferred) {
                bytes.resize(*off as usize, 0);
                bytes.extend_from_slice(&e.data);
            }
        }
    }
    for (t, at) in tables.iter().zip(&value_at) {
        for (e, a) in t.iter().zip(at) {
            if let (Some(off), true) = (a, e.deferred) {
                bytes.resize(*off as usize, 0);
                bytes.extend_from_slice(&e.data);
            }
        }
    }
    Layout {
        bytes,
        big,
        offsets_at,
        counts_at,
    }
}

fn put_word_count(bytes: &mut Vec<u8>, n: usize, big: bool) {
    if big {
        bytes.extend_from_slice(&(n as u64).to_le_bytes());
    } else {
        bytes.extend_from_slice(&(n as u16).to_le_bytes());
    }
}

fn entries(ifd: &Ifd, big: bool) -> Vec<Entry> {
    let mut out: Vec<Entry> = ifd
        .tags
        .iter()
        .map(|(tag, v)| {
            let (typ, count) = v.type_and_count();
            Entry {
                tag: *tag,
                typ,
                count,
                data: v.bytes(),
                deferred: false,
            }
        })
        .collect();
    let (typ, word) = if big { (16, 8) } else { (4, 4) };
    for tag in ifd.array_tags() {
        out.push(Entry {
            tag,
            typ,
            count: ifd.tiles as u64,
            data: vec![0; ifd.tiles * word],
            deferred: true,
        });
    }
    out
}
