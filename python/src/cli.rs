//! The `lrr` command line in-process: `python -m lrr ...` (the bake's child process) and the
//! commands `Operator.export` runs, byte for byte what the `lrr` binary does.

use std::ffi::OsString;
use std::io::Write;

use pyo3::prelude::*;

use crate::errors;

/// The error chain on one line, as the binary prints it after `lrr: error: `.
fn chain(e: &anyhow::Error) -> String {
    e.chain()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(": ")
}

fn argv(args: Vec<OsString>) -> Vec<OsString> {
    std::iter::once(OsString::from("lrr")).chain(args).collect()
}

/// Runs ``lrr ARGS...`` as the binary does: output on this process's stdout, an error as one
/// line ``lrr: error: what: why`` on stderr. Returns the exit status (0 or 1). The GIL is
/// released; SIGINT ends the process only if the caller restored its default handler
/// (``python -m lrr`` does).
#[pyfunction]
pub fn main(py: Python<'_>, args: Vec<OsString>) -> i32 {
    py.detach(|| {
        let mut stdout = std::io::stdout().lock();
        let result = lrr_cli::run(argv(args), &mut stdout);
        let _ = stdout.flush();
        match result {
            Ok(()) => 0,
            Err(e) => {
                eprintln!("lrr: error: {}", chain(&e));
                1
            }
        }
    })
}

/// Runs ``lrr ARGS...`` and returns what it printed; a failure raises ``lrr.CommandError``
/// with the command's one-line message. The GIL is released.
#[pyfunction]
pub fn run(py: Python<'_>, args: Vec<OsString>) -> PyResult<String> {
    let mut out = Vec::new();
    let result = py.detach(|| lrr_cli::run(argv(args), &mut out));
    match result {
        Ok(()) => Ok(String::from_utf8_lossy(&out).into_owned()),
        Err(e) => Err(errors::command(py, chain(&e))),
    }
}
