//! The errors of text tables (GCP files, exterior-orientation files) before the file's name is
//! known (`IoError::Table` adds it): the line, the column and the value concerned, and why.

use aerorect_geo::CrsError;
use thiserror::Error;

/// What is wrong in a text table; each names the line (1-based) and, for a field, its column
/// and value as written.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TableError {
    /// A field that must be a number is not one.
    #[error("line {line}: {column} '{value}' is not a number")]
    NotANumber {
        line: usize,
        column: String,
        value: String,
    },
    /// A number no table may hold (not finite, or beyond the tables' magnitude limit).
    #[error("line {line}: {column} '{value}': {why}")]
    OutOfRange {
        line: usize,
        column: String,
        value: String,
        why: String,
    },
    /// A standard deviation below zero.
    #[error("line {line}: {column} '{value}' is negative")]
    Negative {
        line: usize,
        column: String,
        value: String,
    },
    #[error("line {line}: {column} '{value}' is not true/false/1/0/yes/no")]
    NotABoolean {
        line: usize,
        column: String,
        value: String,
    },
    #[error("line {line}: the header names column '{column}' twice")]
    RepeatedColumn { line: usize, column: String },
    /// A header without a column the format needs.
    #[error("line {line}: the header has no column '{column}'")]
    MissingColumn { line: usize, column: String },
    /// A CRS line naming a CRS that does not build (the CRS error is shown, not chained).
    #[error("line {line}: CRS '{text}': {error}")]
    Crs {
        line: usize,
        text: String,
        error: CrsError,
    },
    /// A CRS line that is none of the forms a CRS is written in.
    #[error(
        "line {line}: the CRS line '{text}' is not a CRS (EPSG:<code>, a +proj= string, WKT or WGS84 UTM <zone>N|S): {error}"
    )]
    NotACrs {
        line: usize,
        text: String,
        error: CrsError,
    },
    /// A line that does not hold what its format needs (too few fields, an empty name, half a
    /// group of columns, a value out of its range), or that contradicts another line.
    #[error("line {line}: {what}")]
    Line { line: usize, what: String },
    /// The table as a whole: empty, without a header, or two lines that disagree.
    #[error("{0}")]
    Table(String),
}

impl TableError {
    /// A line's problem, `what` said after the line's number.
    pub(crate) fn line(line: usize, what: impl Into<String>) -> Self {
        TableError::Line {
            line,
            what: what.into(),
        }
    }

    /// A field's problem: column and value as written.
    pub(crate) fn not_a_number(line: usize, column: &str, value: &str) -> Self {
        TableError::NotANumber {
            line,
            column: column.to_string(),
            value: value.to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texts the tables' messages had as strings, kept word for word.
    #[test]
    fn texts_name_the_line_column_and_value() {
        assert_eq!(
            TableError::not_a_number(3, "x", "abc").to_string(),
            "line 3: x 'abc' is not a number"
        );
        assert_eq!(
            TableError::RepeatedColumn {
                line: 1,
                column: "u".into()
            }
            .to_string(),
            "line 1: the header names column 'u' twice"
        );
        assert_eq!(
            TableError::line(7, "the label is empty").to_string(),
            "line 7: the label is empty"
        );
    }
}
