//! Status codes, the thread-local last error, and the guard that keeps panics inside Rust.
//!
//! Every entry point runs its body through [`status`] or [`guard`]: an error becomes a negative
//! code plus a message in the calling thread's last-error slot, and a panic (a bug in lrr) is
//! caught with `catch_unwind` and reported as [`LRR_ERROR_PANIC`] instead of unwinding into C.
//!
//! The codes are duplicated in `include/lrr.h` (`#define LRR_…`); `tests/header.rs` checks both
//! sides agree.

use std::cell::RefCell;
use std::ffi::{CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

use lrr_formats::{ErrorKind, FormatError};
use lrr_runtime::RuntimeError;

/// Success.
pub const LRR_OK: i32 = 0;
/// A required pointer argument is null.
pub const LRR_ERROR_NULL: i32 = -1;
/// The path is not valid UTF-8.
pub const LRR_ERROR_UTF8: i32 = -2;
/// A buffer length does not match the operator (it must be 3 × the element count).
pub const LRR_ERROR_LENGTH: i32 = -3;
/// A buffer is misaligned for `float`, or the input and output buffers overlap.
pub const LRR_ERROR_BUFFER: i32 = -4;
/// The file could not be read (missing, permissions).
pub const LRR_ERROR_IO: i32 = -5;
/// The bytes are not a valid operator file (wrong magic or version, truncated, corrupt).
pub const LRR_ERROR_FORMAT: i32 = -6;
/// An input value is refused: negative or non-finite emission, a non-finite point or normal.
pub const LRR_ERROR_INPUT: i32 = -7;
/// A bug in lrr: a panic was caught at the C boundary.
pub const LRR_ERROR_PANIC: i32 = -8;

/// An error on its way to C: a status code and a message.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Error {
    pub code: i32,
    pub message: String,
}

impl Error {
    pub fn new(code: i32, message: impl Into<String>) -> Self {
        Error {
            code,
            message: message.into(),
        }
    }

    pub fn null(argument: &str) -> Self {
        Error::new(LRR_ERROR_NULL, format!("{argument} is a null pointer"))
    }
}

impl From<RuntimeError> for Error {
    fn from(e: RuntimeError) -> Self {
        let code = match &e {
            RuntimeError::Format(f) => format_code(f),
            RuntimeError::Input(_) => LRR_ERROR_INPUT,
        };
        Error::new(code, e.to_string())
    }
}

fn format_code(e: &FormatError) -> i32 {
    match e.kind {
        ErrorKind::Io => LRR_ERROR_IO,
        _ => LRR_ERROR_FORMAT,
    }
}

thread_local! {
    /// The message of the last failed call on this thread (`None` before the first failure).
    static LAST_ERROR: RefCell<Option<CString>> = const { RefCell::new(None) };
}

/// Stores `message` as this thread's last error. Interior NULs (impossible in the messages lrr
/// writes, but a path could be made of anything) become U+FFFD so C sees the whole message.
fn set_last_error(message: &str) {
    let text = CString::new(message.replace('\0', "\u{fffd}")).unwrap_or_default();
    // `try_with`: during thread teardown the slot may be gone; the code still reaches C.
    let _ = LAST_ERROR.try_with(|slot| *slot.borrow_mut() = Some(text));
}

/// This thread's last error message: a NUL-terminated string owned by the thread-local slot,
/// valid until the next failing call on this thread (or the thread's exit); `""` if none.
pub(crate) fn last_error() -> *const c_char {
    LAST_ERROR
        .try_with(|slot| slot.borrow().as_ref().map(|s| s.as_ptr()))
        .ok()
        .flatten()
        .unwrap_or(c"".as_ptr())
}

/// Runs `body` at the C boundary: an error, or a panic turned into one, is recorded as this
/// thread's last error and returned.
fn run<T>(body: impl FnOnce() -> Result<T, Error>) -> Result<T, Error> {
    // AssertUnwindSafe: after a panic nothing the closure captured is used again; the only state
    // that outlives the call is the caller's memory, which the documentation of each function
    // declares unspecified after LRR_ERROR_PANIC.
    let outcome = catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".to_string());
        Err(Error::new(
            LRR_ERROR_PANIC,
            format!("internal error (a bug in lrr, please report it): {what}"),
        ))
    });
    outcome.inspect_err(|e| set_last_error(&e.message))
}

/// [`run`] for functions whose return value is not a status: `on_error` stands for any error.
pub(crate) fn guard<T>(on_error: T, body: impl FnOnce() -> Result<T, Error>) -> T {
    run(body).unwrap_or(on_error)
}

/// [`run`] for functions that return a status: `LRR_OK` or the error's negative code.
pub(crate) fn status(body: impl FnOnce() -> Result<(), Error>) -> i32 {
    match run(body) {
        Ok(()) => LRR_OK,
        Err(e) => e.code,
    }
}

#[cfg(test)]
mod tests {
    use std::ffi::CStr;

    use super::*;

    fn last() -> String {
        // SAFETY: last_error returns a valid NUL-terminated string that lives until the next
        // failing call on this thread; it is copied out at once.
        unsafe { CStr::from_ptr(last_error()) }
            .to_string_lossy()
            .into_owned()
    }

    #[test]
    fn errors_and_panics_become_codes_and_messages() {
        assert_eq!(status(|| Ok(())), LRR_OK);
        assert_eq!(
            status(|| Err(Error::new(LRR_ERROR_INPUT, "bad\0value"))),
            LRR_ERROR_INPUT
        );
        assert_eq!(last(), "bad\u{fffd}value");
        assert_eq!(status(|| panic!("boom")), LRR_ERROR_PANIC);
        assert!(last().contains("boom"), "{}", last());
        assert_eq!(guard(7usize, || Err(Error::null("op"))), 7);
        assert_eq!(last(), "op is a null pointer");
        // A success leaves the last error as it was.
        assert_eq!(status(|| Ok(())), LRR_OK);
        assert_eq!(last(), "op is a null pointer");
    }

    #[test]
    fn a_fresh_thread_has_an_empty_last_error() {
        let text = std::thread::spawn(last).join().unwrap();
        assert_eq!(text, "");
    }
}
