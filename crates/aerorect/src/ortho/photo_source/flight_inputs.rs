//! The checks and first orientations that need the whole flight: photos given twice, photos an
//! external-orientation file misses (and the ones it lists that were not given), and the
//! GPS-track headings of photos without attitude.

use super::{track_headings, with_geo_record};
use crate::Error;
use crate::drone_options::DroneOptions;
use aerorect_io::PhotoMetadata;
use std::path::PathBuf;
use std::sync::Arc;

/// At most this many names in a message; the rest are counted.
const NAMED: usize = 5;

fn some_names(names: &[String]) -> String {
    let mut s = names
        .iter()
        .take(NAMED)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > NAMED {
        s.push_str(&format!(" and {} more", names.len() - NAMED));
    }
    s
}

/// Fills `opts.track_headings` for `inputs` and checks them; returns warnings. Errors name
/// the photos: one given twice, photos the `--geo` file does not list.
pub fn prepare_flight(opts: &mut DroneOptions, inputs: &[PathBuf]) -> Result<Vec<String>, Error> {
    // The one rule for a photo given twice (same file, or identical bytes).
    aerorect_io::refuse_duplicate_photos(inputs)?;
    let mut warnings = vec![];
    if let Some(t) = opts.geo.as_deref() {
        let missing: Vec<String> = inputs
            .iter()
            .filter(|p| t.record_for(p).is_none())
            .map(|p| p.display().to_string())
            .collect();
        if !missing.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: {} of the {} photos are not listed: {}",
                t.path,
                missing.len(),
                inputs.len(),
                some_names(&missing)
            )));
        }
        let given: std::collections::BTreeSet<&str> = inputs
            .iter()
            .filter_map(|p| t.record_for(p).map(|r| r.name.as_str()))
            .collect();
        let extra: Vec<String> = t
            .records
            .keys()
            .filter(|k| !given.contains(k.as_str()))
            .cloned()
            .collect();
        if !extra.is_empty() {
            warnings.push(format!(
                "{}: {} listed photos are not among the inputs (not used): {}",
                t.path,
                extra.len(),
                some_names(&extra)
            ));
        }
    }
    if opts.poses.is_none() {
        // A photo whose metadata cannot be read fails on its own later (batch goes on).
        let metas: Vec<(PathBuf, PhotoMetadata)> = inputs
            .iter()
            .filter_map(|p| {
                let m = aerorect_io::read_photo_metadata(p).ok()?;
                let m = with_geo_record(&m, opts, &p.display().to_string()).ok()?;
                Some((p.clone(), m))
            })
            .collect();
        opts.track_headings = Some(Arc::new(track_headings(&metas)));
        warnings.extend(camera_warning(&metas));
    }
    Ok(warnings)
}

/// A warning naming each camera (EXIF make, model and image size) and its photos when a
/// flight has more than one: each gets its own intrinsics (from its own tags, and its own
/// parameter block in an adjustment).
fn camera_warning(metas: &[(PathBuf, PhotoMetadata)]) -> Option<String> {
    let mut groups: std::collections::BTreeMap<String, Vec<String>> = Default::default();
    for (p, m) in metas {
        let key = format!(
            "'{} {}' {} x {} px",
            m.make.as_deref().unwrap_or("?").trim(),
            m.model.as_deref().unwrap_or("?").trim(),
            m.width.map_or("?".into(), |w| w.to_string()),
            m.height.map_or("?".into(), |h| h.to_string())
        );
        let name = p
            .file_name()
            .map_or(p.display().to_string(), |n| n.to_string_lossy().into());
        groups.entry(key).or_default().push(name);
    }
    (groups.len() > 1).then(|| {
        let each: Vec<String> = groups
            .iter()
            .map(|(k, v)| format!("{k} ({} photos: {})", v.len(), some_names(v)))
            .collect();
        format!(
            "{} cameras in one flight, each with its own intrinsics: {}",
            groups.len(),
            each.join("; ")
        )
    })
}
