//! The one error type of the crate: a category that says who is at fault, and a message for people.

use std::fmt;

/// What went wrong, by who is at fault.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The file system refused (missing file, permissions, full disk). The message names the path.
    Io,
    /// The bytes do not start with [`MAGIC`](crate::MAGIC): not an lrr operator file at all.
    NotLrr,
    /// A different major version, or a required section / layout / precision this reader does not
    /// know: written by another version of lrr.
    UnsupportedVersion,
    /// The data ends before something the file itself announces (a cut-off download or copy).
    Truncated,
    /// The structure is damaged: checksum mismatch, overlapping or misaligned sections, lengths that
    /// disagree with the dimensions, a missing section.
    Corrupt,
    /// The structure is sound but the values break an invariant (an index that decreases, a NaN
    /// form factor), or the writer was handed an inconsistent [`OperatorFile`](crate::OperatorFile).
    Invalid,
    /// A size that cannot be addressed on this machine (a product of dimensions that overflows).
    Limits,
}

impl ErrorKind {
    /// A short lower-case name, e.g. `"corrupt"`.
    pub fn as_str(self) -> &'static str {
        match self {
            ErrorKind::Io => "i/o",
            ErrorKind::NotLrr => "not an lrr file",
            ErrorKind::UnsupportedVersion => "unsupported version",
            ErrorKind::Truncated => "truncated",
            ErrorKind::Corrupt => "corrupt",
            ErrorKind::Invalid => "invalid",
            ErrorKind::Limits => "limits",
        }
    }
}

impl fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// An error reading, writing or validating an operator file.
///
/// `Display` prints the message alone; match on [`kind`](FormatError::kind) to react.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FormatError {
    /// Who is at fault.
    pub kind: ErrorKind,
    /// What happened, naming the section, the index and the values involved.
    pub message: String,
}

impl FormatError {
    /// An error of `kind` with `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        FormatError {
            kind,
            message: message.into(),
        }
    }

    /// The same error with `prefix: ` in front of the message (e.g. the path of the file).
    pub fn context(self, prefix: impl fmt::Display) -> Self {
        FormatError {
            kind: self.kind,
            message: format!("{prefix}: {}", self.message),
        }
    }

    pub(crate) fn truncated(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Truncated, message)
    }

    pub(crate) fn corrupt(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Corrupt, message)
    }

    pub(crate) fn invalid(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Invalid, message)
    }

    pub(crate) fn limits(message: impl Into<String>) -> Self {
        Self::new(ErrorKind::Limits, message)
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for FormatError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_the_message() {
        let e = FormatError::new(ErrorKind::Corrupt, "section FK: checksum mismatch");
        assert_eq!(e.to_string(), "section FK: checksum mismatch");
        let e = e.context("scene.lrr");
        assert_eq!(e.to_string(), "scene.lrr: section FK: checksum mismatch");
        assert_eq!(e.kind, ErrorKind::Corrupt);
    }
}
