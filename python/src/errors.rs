//! Rust errors as the Python exceptions of `lrr/_errors.py` (defined in Python so that
//! `InputError` can be both an `lrr.LrrError` and a `ValueError`).

use lrr_runtime::RuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyType;

/// An exception of class `name` from `lrr._errors` with `message`.
fn raise(py: Python<'_>, name: &str, message: String) -> PyErr {
    let class = py
        .import("lrr._errors")
        .and_then(|m| m.getattr(name))
        .and_then(|c| Ok(c.cast_into::<PyType>()?));
    match class.and_then(|c| c.call1((message,))) {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

/// `lrr.InputError(message)`: the call cannot be done as asked.
pub fn input(py: Python<'_>, message: impl Into<String>) -> PyErr {
    raise(py, "InputError", message.into())
}

/// `lrr.CommandError(message)`: a command of the command line failed.
pub fn command(py: Python<'_>, message: impl Into<String>) -> PyErr {
    raise(py, "CommandError", message.into())
}

/// The runtime's error as `lrr.FormatError` (with its kind) or `lrr.InputError`.
pub fn runtime(py: Python<'_>, e: RuntimeError) -> PyErr {
    match e {
        RuntimeError::Format(f) => {
            let class = py
                .import("lrr._errors")
                .and_then(|m| m.getattr("FormatError"));
            match class.and_then(|c| c.call1((f.to_string(), f.kind.as_str()))) {
                Ok(e) => PyErr::from_value(e),
                Err(e) => e,
            }
        }
        RuntimeError::Input(m) => input(py, m),
    }
}

/// `Result<T, RuntimeError>` → `PyResult<T>`.
pub trait OrRaise<T> {
    /// The value, or the error as a Python exception.
    fn or_raise(self, py: Python<'_>) -> PyResult<T>;
}

impl<T> OrRaise<T> for Result<T, RuntimeError> {
    fn or_raise(self, py: Python<'_>) -> PyResult<T> {
        self.map_err(|e| runtime(py, e))
    }
}
