//! The precompute's error type: each variant says who is at fault.

use std::fmt;
use std::path::PathBuf;

/// What went wrong in a bake, by who is at fault.
#[derive(Debug)]
pub enum Error {
    /// Reading or writing a file failed.
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// The scene input is wrong: `location` is "file:line" (or "file" alone).
    Scene {
        /// Where: "file:line" or "file".
        location: String,
        /// What is wrong and, where possible, how to fix it.
        message: String,
    },
    /// A setting or argument is out of range.
    Settings(String),
    /// The system cannot be solved as asked (e.g. numerically singular).
    Numerical(String),
    /// The job would exceed a resource limit (memory); the message says what to change.
    Limits(String),
    /// The operator file could not be written or read.
    Format(lrr_formats::FormatError),
    /// The parts of a sharded bake do not make one bake (missing, repeated, truncated,
    /// damaged or foreign parts); `path` names the part (or the first one) concerned.
    Part {
        /// The part file concerned.
        path: PathBuf,
        /// What is wrong and how to fix it.
        message: String,
    },
}

/// `Result` with the precompute's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A scene input error at `location` ("file:line" or "file").
    pub fn scene(location: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Scene {
            location: location.into(),
            message: message.into(),
        }
    }
    /// A part of a sharded bake at `path` that does not fit.
    pub fn part(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Part {
            path: path.into(),
            message: message.into(),
        }
    }
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Scene { location, message } => write!(f, "{location}: {message}"),
            Error::Settings(m) | Error::Numerical(m) | Error::Limits(m) => f.write_str(m),
            Error::Format(e) => write!(f, "{e}"),
            Error::Part { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl From<lrr_formats::FormatError> for Error {
    fn from(e: lrr_formats::FormatError) -> Self {
        Error::Format(e)
    }
}
