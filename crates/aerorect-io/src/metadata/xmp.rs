//! The XMP packet of a photo and its tags, matched by namespace URI (roxmltree resolves the
//! prefixes): `drone-dji:`, `sensefly:` or `Camera:` are only the usual prefixes, a file may
//! bind any prefix to the namespace.

use super::MetadataError;
use std::collections::BTreeMap;

/// The XMP packet of a file: the text from `<x:xmpmeta` to `</x:xmpmeta>`.
pub fn xmp_packet(bytes: &[u8]) -> Option<&str> {
    let find = |needle: &[u8], from: usize| {
        bytes[from..]
            .windows(needle.len())
            .position(|w| w == needle)
            .map(|p| p + from)
    };
    let start = find(b"<x:xmpmeta", 0)?;
    let end = find(b"</x:xmpmeta>", start)? + b"</x:xmpmeta>".len();
    std::str::from_utf8(&bytes[start..end]).ok()
}

/// Every namespaced tag of an XMP packet, written as an attribute or as an element with text,
/// keyed by (namespace URI, local name). An error when the packet is not XML.
pub fn xmp_tags(xmp: &str) -> Result<BTreeMap<(String, String), String>, MetadataError> {
    let doc = roxmltree::Document::parse(xmp).map_err(MetadataError::Xml)?;
    let mut out = BTreeMap::new();
    for node in doc.descendants() {
        for a in node.attributes() {
            if let Some(ns) = a.namespace() {
                out.insert(
                    (ns.to_string(), a.name().to_string()),
                    a.value().to_string(),
                );
            }
        }
        if node.is_element()
            && let Some(ns) = node.tag_name().namespace()
            && let Some(t) = node.text()
            && !t.trim().is_empty()
        {
            out.insert(
                (ns.to_string(), node.tag_name().name().to_string()),
                t.trim().to_string(),
            );
        }
    }
    Ok(out)
}

/// The tags of the first namespace of `uris` that has any, by local name, with the URI.
pub fn tags_in<'a>(
    tags: &BTreeMap<(String, String), String>,
    uris: &[&'a str],
) -> Option<(&'a str, BTreeMap<String, String>)> {
    uris.iter().find_map(|uri| {
        let found: BTreeMap<String, String> = tags
            .iter()
            .filter(|((ns, _), _)| ns == uri)
            .map(|((_, name), v)| (name.clone(), v.clone()))
            .collect();
        (!found.is_empty()).then_some((*uri, found))
    })
}

/// An XMP number: "+37.10", "-19.00", " 5 "; an error names `prefix:tag` and the value.
pub fn xmp_number(prefix: &str, tag: &str, value: &str) -> Result<f64, MetadataError> {
    let t = value.trim();
    let t = t.strip_prefix('+').unwrap_or(t);
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(MetadataError::XmpNumber {
            prefix: prefix.to_string(),
            tag: tag.to_string(),
            value: value.to_string(),
        }),
    }
}

/// The first of `names` present in `tags`, as a number.
pub(super) fn first_number(
    prefix: &str,
    tags: &BTreeMap<String, String>,
    names: &[&str],
) -> Result<Option<f64>, MetadataError> {
    for n in names {
        if let Some(v) = tags.get(*n) {
            return xmp_number(prefix, n, v).map(Some);
        }
    }
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_are_matched_by_namespace_not_by_prefix() {
        // Two prefixes bound to one URI, and one prefix bound to another URI.
        let x = r#"<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">
  <rdf:Description xmlns:cam="http://pix4d.com/camera/1.0/" cam:Yaw="12.5"/>
  <rdf:Description xmlns:Camera="http://example.com/not-pix4d/" Camera:Yaw="99"/>
  <rdf:Description xmlns:p4="http://pix4d.com/camera/1.0/"><p4:Pitch>3</p4:Pitch></rdf:Description>
  </rdf:RDF></x:xmpmeta>"#;
        let tags = xmp_tags(x).expect("xml");
        let (uri, p4) = tags_in(&tags, &["http://pix4d.com/camera/1.0/"]).expect("found");
        assert_eq!(uri, "http://pix4d.com/camera/1.0/");
        assert_eq!(p4.get("Yaw").map(String::as_str), Some("12.5"));
        assert_eq!(p4.get("Pitch").map(String::as_str), Some("3"));
        assert!(tags_in(&tags, &["http://pix4d.com/camera/2.0/"]).is_none());
    }
}
