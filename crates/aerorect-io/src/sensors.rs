//! Camera sensor widths from OpenSfM's sensor database (`data/sensors/sensor_data.json`,
//! Simplified BSD, see `data/README.md`): 3,709 cameras keyed "MAKE MODEL", width in mm.
//!
//! The key is built as OpenSfM's `exif.sensor_string` builds it: "make model", lower-cased,
//! with the make dropped from the model when the model already carries it (EXIF often says
//! Make "Canon", Model "Canon EOS 1000D"). Two deliberate differences, both only widening
//! what matches: the make is removed from the model case-insensitively and only as a leading
//! word (OpenSfM removes every case-sensitive occurrence), and runs of whitespace collapse to
//! one space on both sides (some database keys have double or trailing spaces, which
//! OpenSfM's exact lookup can never hit). Normalised keys are unique, a test pins that.

use std::collections::HashMap;
use std::sync::OnceLock;

/// The database, embedded at compile time.
const SENSOR_DATA_JSON: &str = include_str!("../../../data/sensors/sensor_data.json");

/// A database hit: the key as the database spells it and the sensor width.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorMatch {
    /// The database key, e.g. "DJI FC220".
    pub key: String,
    /// Sensor width in millimetres (the long side, as the database gives it).
    pub width_mm: f64,
}

/// Normalised key -> (database key, width in mm), parsed once.
fn database() -> &'static HashMap<String, (String, f64)> {
    static DB: OnceLock<HashMap<String, (String, f64)>> = OnceLock::new();
    DB.get_or_init(|| {
        // The file is embedded and its parse is pinned by a test, so an error cannot reach a
        // user; an empty table (every lookup None) is the safe answer if it ever did.
        let raw: HashMap<String, f64> = serde_json::from_str(SENSOR_DATA_JSON).unwrap_or_default();
        raw.into_iter()
            .map(|(key, width)| (normalise(&key), (key, width)))
            .collect()
    })
}

/// Lower case, whitespace trimmed and runs of whitespace collapsed to one space.
fn normalise(s: &str) -> String {
    s.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_lowercase()
}

/// The lookup key for an EXIF Make and Model: "make model" normalised, the make not repeated
/// when the model starts with it as a whole word. An empty or "unknown" make is left out.
pub fn sensor_key(make: &str, model: &str) -> String {
    let make = normalise(make);
    let model = normalise(model);
    if make.is_empty() || make == "unknown" {
        return model;
    }
    let rest = match model.strip_prefix(&make) {
        Some(rest) if rest.is_empty() || rest.starts_with(' ') => rest.trim_start(),
        _ => model.as_str(),
    };
    if rest.is_empty() {
        make
    } else {
        format!("{make} {rest}")
    }
}

/// The sensor width of a camera by its EXIF Make and Model; `None` when the database does not
/// know it. Tries the key of [`sensor_key`] first, then "make model" as given (for the rare
/// database key that itself repeats the make).
pub fn sensor_width_mm(make: &str, model: &str) -> Option<SensorMatch> {
    let db = database();
    let hit = db
        .get(&sensor_key(make, model))
        .or_else(|| db.get(&normalise(&format!("{make} {model}"))))?;
    Some(SensorMatch {
        key: hit.0.clone(),
        width_mm: hit.1,
    })
}

/// The number of cameras in the database.
pub fn sensor_count() -> usize {
    database().len()
}
