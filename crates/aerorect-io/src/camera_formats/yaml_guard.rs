//! YAML loading with bounds: `yaml-rust2` copies an anchored node at every alias, so a few
//! hundred bytes of nested aliases (a "billion laughs" bomb) expand to gigabytes, and a deeply
//! nested text overflows the stack when the tree is dropped. The events are walked first,
//! counting the nodes the loader would build (an alias counts as its anchor's whole node) and
//! the nesting depth, and the text is refused past either cap before anything is built.

use super::Src;
use crate::IoError;
use std::collections::HashMap;
use yaml_rust2::parser::{Event, Parser};
use yaml_rust2::{Yaml, YamlLoader};

/// The most nodes (scalars, sequences and mappings, aliases expanded) a camera YAML may build;
/// OpenCV's and Orthority's files have a few dozen.
pub(crate) const MAX_YAML_NODES: u64 = 100_000;

/// The deepest nesting of sequences and mappings a camera YAML may have (they use 3).
pub(crate) const MAX_YAML_DEPTH: usize = 64;

/// The YAML documents of `text`, refused (naming the cap) when expanding its aliases would build
/// more than [`MAX_YAML_NODES`] nodes or it nests deeper than [`MAX_YAML_DEPTH`].
pub(crate) fn load_yaml(text: &str, src: &Src) -> Result<Vec<Yaml>, IoError> {
    check_expansion(text, src)?;
    YamlLoader::load_from_str(text).map_err(|e| src.err(e))
}

fn check_expansion(text: &str, src: &Src) -> Result<(), IoError> {
    let mut parser = Parser::new_from_str(text);
    // Per open container: its anchor and the nodes it holds so far (itself included).
    let mut open: Vec<(usize, u64)> = Vec::new();
    let mut anchored: HashMap<usize, u64> = HashMap::new();
    let mut total: u64 = 0;
    loop {
        let (event, _) = parser.next_token().map_err(|e| src.err(e))?;
        let node = match event {
            Event::StreamEnd => return Ok(()),
            Event::Scalar(_, _, anchor, _) => {
                if anchor > 0 {
                    anchored.insert(anchor, 1);
                }
                1
            }
            Event::Alias(id) => anchored.get(&id).copied().unwrap_or(1),
            Event::SequenceStart(anchor, _) | Event::MappingStart(anchor, _) => {
                open.push((anchor, 1));
                if open.len() > MAX_YAML_DEPTH {
                    return Err(src.err(format!(
                        "the YAML nests deeper than {MAX_YAML_DEPTH} levels"
                    )));
                }
                total += 1;
                continue;
            }
            Event::SequenceEnd | Event::MappingEnd => {
                let Some((anchor, size)) = open.pop() else {
                    continue;
                };
                if anchor > 0 {
                    anchored.insert(anchor, size);
                }
                if let Some(parent) = open.last_mut() {
                    parent.1 = parent.1.saturating_add(size);
                }
                continue;
            }
            _ => continue,
        };
        total = total.saturating_add(node);
        if let Some(parent) = open.last_mut() {
            parent.1 = parent.1.saturating_add(node);
        }
        if total > MAX_YAML_NODES {
            return Err(src.err(format!(
                "the YAML's aliases expand to more than {MAX_YAML_NODES} nodes (an alias bomb?)"
            )));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CameraFormat;

    fn src() -> Src<'static> {
        Src {
            format: CameraFormat::Orthority,
            source: "bomb.yaml",
        }
    }

    /// `levels` anchors, each a list of ten aliases of the one before: 10^levels leaves.
    fn bomb(levels: usize) -> String {
        let mut s = "a0: &a0 [x]\n".to_string();
        for i in 1..=levels {
            let refs = vec![format!("*a{}", i - 1); 10].join(", ");
            s += &format!("a{i}: &a{i} [{refs}]\n");
        }
        s
    }

    #[test]
    fn an_alias_bomb_is_refused_before_it_expands() {
        let text = bomb(9);
        assert!(text.len() < 1000, "{}", text.len());
        let e = load_yaml(&text, &src()).unwrap_err().to_string();
        assert!(e.contains("bomb.yaml") && e.contains("100000 nodes"), "{e}");
    }

    #[test]
    fn a_few_aliases_load_as_the_plain_loader_loads_them() {
        let text = bomb(3);
        let guarded = load_yaml(&text, &src()).expect("small expansion");
        assert_eq!(guarded, YamlLoader::load_from_str(&text).expect("plain"));
    }

    #[test]
    fn deep_nesting_is_refused() {
        // Block mappings 100 deep (the scanner's own limit stops deep flow collections).
        let nested = |depth: usize| -> String {
            (0..depth)
                .map(|i| format!("{}k{i}:\n", " ".repeat(i)))
                .collect::<String>()
                + &" ".repeat(depth)
                + "leaf\n"
        };
        let e = load_yaml(&nested(100), &src()).unwrap_err().to_string();
        assert!(
            e.contains("bomb.yaml") && e.contains("deeper than 64"),
            "{e}"
        );
        assert!(load_yaml(&nested(60), &src()).is_ok());
        let flow = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
        assert!(load_yaml(&flow, &src()).is_err());
    }
}
