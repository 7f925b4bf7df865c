use std::path::PathBuf;

use thiserror::Error;

/// Errors of the pipelines; each carries the file or option it is about.
///
/// The typed errors of the layers below are carried as they are (their own variant, or under
/// [`Error::Context`] with the file or step they happened in), never flattened into text, so
/// `std::error::Error::source` walks to the cause. A variant's `Display` is its own message
/// only; the causes follow in the chain: [`Error::full_message`], anyhow's `{:#}` and the CLI
/// print "context: cause: ...".
#[derive(Debug, Error)]
pub enum Error {
    #[error(transparent)]
    Io(#[from] aerorect_io::IoError),
    #[error(transparent)]
    Geometry(#[from] aerorect_core::GeometryError),
    #[error(transparent)]
    Raster(#[from] aerorect_raster::RasterError),
    #[error(transparent)]
    Shift(#[from] aerorect_raster::shift::ShiftError),
    #[error(transparent)]
    Chessboard(#[from] aerorect_raster::chessboard::ChessboardError),
    #[error(transparent)]
    Features(#[from] aerorect_raster::features::FeatureError),
    #[error(transparent)]
    Geo(#[from] aerorect_geo::GeoError),
    #[error(transparent)]
    Crs(#[from] aerorect_geo::CrsError),
    /// A fit of aerorect-solve (homography, polynomial, flight adjustment).
    #[error(transparent)]
    Solve(#[from] aerorect_solve::SolveError),
    #[error(transparent)]
    Calibration(#[from] aerorect_solve::calib::CalibrationError),
    #[error(transparent)]
    Pairs(#[from] aerorect_solve::pairs::PairError),
    #[error(transparent)]
    Matching(#[from] aerorect_solve::matching::MatchError),
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A noise level that no normal distribution has.
    #[error(transparent)]
    Noise(#[from] rand_distr::NormalError),
    /// A file the pipeline itself reads or writes (not through aerorect-io).
    #[error("{}", path.display())]
    File {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An error with the file, frame or step it happened in.
    #[error("{context}")]
    Context {
        context: String,
        #[source]
        source: Box<Error>,
    },
    /// An option a front end passed, refused before any work ([`Error::spelled`] writes its
    /// name as that front end does).
    #[error(transparent)]
    Option(#[from] crate::options::OptionError),
    /// A request that cannot be carried out as asked.
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// Wraps an error with what it was about: `map_err(Error::context(file))`.
    pub fn context<E: Into<Error>>(context: impl ToString) -> impl FnOnce(E) -> Error {
        move |e| Error::Context {
            context: context.to_string(),
            source: Box::new(e.into()),
        }
    }

    /// Wraps a geometry error with what it was about.
    pub fn geometry(context: impl ToString) -> impl FnOnce(aerorect_core::GeometryError) -> Error {
        Self::context(context)
    }

    /// An I/O error on `path`, read or written by the pipeline itself.
    pub fn file(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> Error {
        move |source| Error::File {
            path: path.into(),
            source,
        }
    }

    /// The message with all its causes, "context: cause: ...", as the CLI prints it.
    pub fn full_message(&self) -> String {
        full_message(self)
    }

    /// Whether the root of the problem is a file that could not be read or written (as opposed
    /// to a bad value in it or a bad request).
    pub fn is_file_error(&self) -> bool {
        match self {
            Error::File { .. } => true,
            Error::Io(e) => e.is_file_error(),
            Error::Context { source, .. } => source.is_file_error(),
            Error::Option(crate::options::OptionError::Value { source, .. }) => {
                source.is_file_error()
            }
            _ => false,
        }
    }
}

/// An error's message followed by those of its causes, joined by ": " (anyhow's `{:#}`).
pub fn full_message(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_prints_once_in_the_chain() {
        let inner = aerorect_solve::SolveError::Degenerate;
        let e = Error::context("flight adjustment")(inner.clone());
        assert_eq!(e.to_string(), "flight adjustment");
        assert_eq!(e.full_message(), format!("flight adjustment: {inner}"));
        let file = Error::file("out/x.txt")(std::io::Error::other("disk full"));
        let outer = Error::context("step")(file);
        assert_eq!(outer.full_message(), "step: out/x.txt: disk full");
        assert!(outer.is_file_error());
        assert!(!e.is_file_error());
    }
}
