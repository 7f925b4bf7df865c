//! Fields of a data line: numbers (finite, within [`crate::checkpoints::MAX_TABLE_VALUE`]),
//! standard deviations, flags and delimited fields; each error names the line, the column and
//! the value.

use crate::table_error::TableError;
use std::collections::BTreeSet;

/// A field as a number, finite and within [`crate::checkpoints::MAX_TABLE_VALUE`]; the error
/// names the line, the column and the value.
pub(super) fn number(line: usize, column: &str, value: &str) -> Result<f64, TableError> {
    let v: f64 = value
        .trim()
        .parse()
        .map_err(|_| TableError::not_a_number(line, column, value))?;
    match crate::checkpoints::bad_number(v) {
        Some(why) => Err(TableError::OutOfRange {
            line,
            column: column.to_string(),
            value: value.to_string(),
            why,
        }),
        None => Ok(v),
    }
}

/// A standard deviation: a number, not negative.
pub(super) fn sigma(line: usize, column: &str, value: &str) -> Result<f64, TableError> {
    let v = number(line, column, value)?;
    if v < 0.0 {
        return Err(TableError::Negative {
            line,
            column: column.to_string(),
            value: value.to_string(),
        });
    }
    Ok(v)
}

/// `true/false/1/0/yes/no`, any case.
pub(super) fn boolean(line: usize, column: &str, value: &str) -> Result<bool, TableError> {
    match value.trim().to_ascii_lowercase().as_str() {
        "true" | "1" | "yes" => Ok(true),
        "false" | "0" | "no" => Ok(false),
        _ => Err(TableError::NotABoolean {
            line,
            column: column.to_string(),
            value: value.to_string(),
        }),
    }
}

/// A delimited line's fields, trimmed, a field in double quotes taken whole (`""` is a quote).
pub(super) fn split_fields(line: &str, delimiter: char) -> Vec<String> {
    let mut out = vec![];
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        if quoted {
            if c == '"' {
                if chars.peek() == Some(&'"') {
                    field.push('"');
                    chars.next();
                } else {
                    quoted = false;
                }
            } else {
                field.push(c);
            }
        } else if c == '"' && field.trim().is_empty() {
            field.clear();
            quoted = true;
        } else if c == delimiter {
            out.push(field.trim().to_string());
            field.clear();
        } else {
            field.push(c);
        }
    }
    out.push(field.trim().to_string());
    out
}

/// Names given twice in a header: the first repeated one.
pub(super) fn repeated<'a>(names: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let mut seen = BTreeSet::new();
    names.into_iter().find(|n| !seen.insert(*n))
}
