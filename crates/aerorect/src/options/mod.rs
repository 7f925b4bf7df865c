//! What a front end asks for, as plain values, and the checks that turn it into the options a
//! run takes. The CLI fills these requests from its flags and Python from its keyword
//! arguments; neither checks a value itself.
//!
//! A request names its options by the facade's keys (Python's keyword names: `gsd_m`,
//! `attitude_sigma_deg`), and a refused value is an [`OptionError`] naming the key and the
//! value. Each front end spells the key its own way ([`Spelling`]: `--gsd-m 1e308` for the CLI,
//! `gsd_m=1e308` for Python): it says how once, at start ([`Spelling::use_for_process`]), and
//! every message that names an option is written that way, however deep it was raised.
//! [`crate::Error::spelled`] spells one error explicitly. Values are checked before any photo
//! is decoded.
//!
//! A message whose remedy is an option (`give camera`) names it in backticks in the text it is
//! built from ([`crate::Error::advice`]); the library's messages never hold a front end's
//! spelling of an option.

mod flight;
mod ortho;

pub use flight::FlightRequest;
pub use ortho::{PhotoRequest, parse_interp, projected_crs};

use crate::Error;
use aerorect_core::error::Num;
pub use aerorect_core::spelling::Spelling;

/// An option refused before any work: its key, the value as given, and why.
#[derive(Debug, thiserror::Error)]
pub enum OptionError {
    /// `{option} {value}: {source}` (`{option}: {source}` for an empty value).
    #[error("{}", Spelling::current().with_value(option, value))]
    Value {
        option: &'static str,
        value: String,
        #[source]
        source: Box<Error>,
    },
    /// A problem whose remedy is an option, or options that cannot be given together: `text`
    /// names each option key in backticks ("no focal length ...; give `camera`", "`geo` and
    /// `poses` ..."), written as the front end spells it.
    #[error("{}", Spelling::current().keys_in(text))]
    Advice { text: String },
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
            OptionError::Advice { text } => Error::Invalid(spelling.keys_in(&text)),
        }
    }
}

impl Error {
    /// A problem whose remedy is an option: `text` names each option key in backticks
    /// (`"...; give `camera`"`), which every front end writes its own way.
    pub fn advice(text: impl Into<String>) -> Error {
        Error::Option(OptionError::Advice { text: text.into() })
    }

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
        let pair = || Error::advice("`hold_positions` and `adjust_positions_m` exclude each other");
        assert_eq!(
            pair().spelled(&FLAG).to_string(),
            "--hold-positions and --adjust-positions-m exclude each other"
        );
        let advice =
            || Error::advice("no focal length; give `camera` or `image_size` (`Not a key`)");
        assert_eq!(
            advice().spelled(&FLAG).to_string(),
            "no focal length; give --camera or --image-size (`Not a key`)"
        );
        assert_eq!(
            advice().to_string(),
            "no focal length; give camera or image_size (`Not a key`)"
        );
        assert_eq!(Spelling::KEY.keys_in("a `b"), "a `b");
        let under = Error::context("flight")(pair()).spelled(&KEYWORD);
        assert_eq!(
            under.full_message(),
            "flight: hold_positions and adjust_positions_m exclude each other"
        );
    }
}
