//! How a front end writes an option's name: `--gsd-m 1e308` in the CLI, `gsd_m=1e308` in
//! Python. The library names options by their keys (Python's keyword names); a front end says
//! once, at start, how it spells them ([`Spelling::use_for_process`]), and every message that
//! names an option, in any crate, is written that way.

use std::sync::OnceLock;

/// How a front end writes an option's key and value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Spelling {
    /// Before the key: `--` for flags.
    pub prefix: &'static str,
    /// Underscores written as dashes (`gsd-m`).
    pub dashes: bool,
    /// Between the name and its value: `" "` for flags, `"="` for keyword arguments.
    pub before_value: &'static str,
}

impl Spelling {
    /// The facade's own spelling (its keys, as Python names its keyword arguments), with the
    /// value after a space.
    pub const KEY: Spelling = Spelling {
        prefix: "",
        dashes: false,
        before_value: " ",
    };

    /// The spelling every option message of this process is written in: the one given to
    /// [`Spelling::use_for_process`], else [`Spelling::KEY`].
    pub fn current() -> Spelling {
        PROCESS_SPELLING.get().copied().unwrap_or(Spelling::KEY)
    }

    /// Writes every option message of this process in this spelling. A front end calls it once,
    /// before any work; a later call is ignored, so the first front end keeps its spelling.
    pub fn use_for_process(self) {
        let _ = PROCESS_SPELLING.set(self);
    }

    /// `text` with each option key in backticks (`` `gsd_m` ``) replaced by its name; other
    /// text as it is.
    pub fn keys_in(&self, text: &str) -> String {
        let parts: Vec<&str> = text.split('`').collect();
        let mut out = String::with_capacity(text.len());
        for (i, part) in parts.iter().enumerate() {
            let closed = i + 1 < parts.len();
            if i % 2 == 0 {
                out.push_str(part);
            } else if closed && is_key(part) {
                out.push_str(&self.name(part));
            } else {
                out.push('`');
                out.push_str(part);
                if closed {
                    out.push('`');
                }
            }
        }
        out
    }

    /// The option's name.
    pub fn name(&self, key: &str) -> String {
        let key = if self.dashes {
            key.replace('_', "-")
        } else {
            key.to_string()
        };
        format!("{}{key}", self.prefix)
    }

    /// The option's name and its value (the name alone for an empty value).
    pub fn with_value(&self, key: &str, value: &str) -> String {
        if value.is_empty() {
            return self.name(key);
        }
        format!("{}{}{value}", self.name(key), self.before_value)
    }
}

static PROCESS_SPELLING: OnceLock<Spelling> = OnceLock::new();

/// Whether `text` is an option key (lower-case words joined by underscores).
fn is_key(text: &str) -> bool {
    !text.is_empty()
        && text
            .bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
}

#[cfg(test)]
mod tests {
    use super::*;

    const FLAG: Spelling = Spelling {
        prefix: "--",
        dashes: true,
        before_value: " ",
    };

    #[test]
    fn keys_in_backticks_are_spelled_and_other_text_kept() {
        let t = "give `image_size` or `fix` (`Not a key`, `a b`) and `x";
        assert_eq!(
            FLAG.keys_in(t),
            "give --image-size or --fix (`Not a key`, `a b`) and `x"
        );
        assert_eq!(
            Spelling::KEY.keys_in(t),
            "give image_size or fix (`Not a key`, `a b`) and `x"
        );
        assert_eq!(FLAG.with_value("gsd_m", "-1"), "--gsd-m -1");
        assert_eq!(FLAG.with_value("force", ""), "--force");
    }
}
