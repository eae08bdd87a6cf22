//! Runtime errors, by who must act: the file is bad, or the call cannot be done as asked.

use std::fmt;

use lrr_formats::FormatError;

/// An error of the runtime. `Display` prints what went wrong, where, and how to fix it.
///
/// Two variants on purpose (the C interface maps them to its codes): the file, or the call.
#[derive(Debug, Clone, PartialEq)]
pub enum RuntimeError {
    /// The operator file could not be read or is invalid.
    Format(FormatError),
    /// The call cannot be done as asked: an argument does not fit the operator (wrong length,
    /// NaN emission, reflectance >= 1), the operation needs the other layout (an albedo edit of
    /// a plain `Y_k` file), an albedo edit makes the system numerically singular (the message
    /// holds the condition number), or the evaluator's threads could not start.
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

// No `source()`: `Display` already prints the wrapped message, and error-chain printers would
// print it twice.
impl std::error::Error for RuntimeError {}

impl From<FormatError> for RuntimeError {
    fn from(e: FormatError) -> Self {
        RuntimeError::Format(e)
    }
}

pub(crate) fn input(message: impl Into<String>) -> RuntimeError {
    RuntimeError::Input(message.into())
}
