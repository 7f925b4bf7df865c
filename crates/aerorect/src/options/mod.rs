//! What a front end asks for, as plain values, and the checks that turn it into the options a
//! run takes. The CLI fills these requests from its flags and Python from its keyword
//! arguments; neither checks a value itself.
//!
//! A request names its options by the facade's keys (Python's keyword names: `gsd_m`,
//! `attitude_sigma_deg`), and a refused value is an [`OptionError`] naming the key and the
//! value. Each front end spells the key its own way ([`Spelling`]: `--gsd-m 1e308` for the CLI,
//! `gsd_m=1e308` for Python) with [`crate::Error::spelled`]. Values are checked before any
//! photo is decoded.

mod flight;
mod ortho;

pub use flight::FlightRequest;
pub use ortho::{PhotoRequest, parse_interp, projected_crs};

use crate::Error;
use aerorect_core::error::Num;

/// An option refused before any work: its key, the value as given, and why.
#[derive(Debug, thiserror::Error)]
pub enum OptionError {
    /// `{option} {value}: {source}` (`{option}: {source}` for an empty value).
    #[error("{}", Spelling::KEY.with_value(option, value))]
    Value {
        option: &'static str,
        value: String,
        #[source]
        source: Box<Error>,
    },
    /// Two options that cannot be given together: `{a} {why} {b}...`, as `text` says with
    /// `{a}` and `{b}` standing for their names.
    #[error("{}", fill(text, a, b))]
    Pair {
        a: &'static str,
        b: &'static str,
        text: String,
    },
}

/// `text` with `{a}` and `{b}` replaced by the names.
fn fill(text: &str, a: &str, b: &str) -> String {
    text.replace("{a}", a).replace("{b}", b)
}

impl OptionError {
    /// The option `option` refused at `value` (a number shown as [`Num`] shows it).
    pub fn value(option: &'static str, value: impl ToString, why: impl Into<Error>) -> Self {
        OptionError::Value {
            option,
            value: value.to_string(),
            source: Box::new(why.into()),
        }
    }

    /// A number refused: `why` is the reason, said after the value.
    pub fn number(option: &'static str, v: f64, why: impl ToString) -> Self {
        Self::value(option, Num(v), Error::Invalid(why.to_string()))
    }

    /// The same error with each key in `spelling`.
    fn spelled(self, spelling: &Spelling) -> Error {
        match self {
            OptionError::Value {
                option,
                value,
                source,
            } => Error::Context {
                context: spelling.with_value(option, &value),
                source,
            },
            OptionError::Pair { a, b, text } => {
                Error::Invalid(fill(&text, &spelling.name(a), &spelling.name(b)))
            }
        }
    }
}

/// How a front end writes an option's key and value.
#[derive(Debug, Clone, Copy)]
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

impl Error {
    /// This error with the options it names spelled as a front end writes them (at the top or
    /// under contexts); other errors are returned as they are.
    pub fn spelled(self, spelling: &Spelling) -> Error {
        match self {
            Error::Option(o) => o.spelled(spelling),
            Error::Context { context, source } => Error::Context {
                context,
                source: Box::new(source.spelled(spelling)),
            },
            e => e,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The CLI's spelling, for the tests.
    pub(crate) const FLAG: Spelling = Spelling {
        prefix: "--",
        dashes: true,
        before_value: " ",
    };
    const KEYWORD: Spelling = Spelling {
        prefix: "",
        dashes: false,
        before_value: "=",
    };

    #[test]
    fn each_front_end_spells_the_key_and_the_cause_follows() {
        let e = || Error::from(OptionError::number("gsd_m", 1e308, "too coarse"));
        assert_eq!(
            e().spelled(&FLAG).full_message(),
            "--gsd-m 1e308: too coarse"
        );
        assert_eq!(
            e().spelled(&KEYWORD).full_message(),
            "gsd_m=1e308: too coarse"
        );
        let pair = || {
            Error::from(OptionError::Pair {
                a: "hold_positions",
                b: "adjust_positions_m",
                text: "{a} and {b} exclude each other".into(),
            })
        };
        assert_eq!(
            pair().spelled(&FLAG).to_string(),
            "--hold-positions and --adjust-positions-m exclude each other"
        );
        let under = Error::context("flight")(pair()).spelled(&KEYWORD);
        assert_eq!(
            under.full_message(),
            "flight: hold_positions and adjust_positions_m exclude each other"
        );
    }
}
