//! Runtime errors: a bad file, or bad input to an evaluation.

use std::fmt;

use lrr_formats::FormatError;

#[derive(Debug, Clone, PartialEq)]
pub enum RuntimeError {
    /// The operator file could not be read or is invalid.
    Format(FormatError),
    /// An argument does not fit the operator (wrong length, NaN emission…).
    Input(String),
}

impl fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RuntimeError::Format(e) => write!(f, "{e}"),
            RuntimeError::Input(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for RuntimeError {}

impl From<FormatError> for RuntimeError {
    fn from(e: FormatError) -> Self {
        RuntimeError::Format(e)
    }
}
