//! # lrr from Python
//!
//! The extension module `lrr._lrr` of the Python package `lrr` (PyO3, one abi3 wheel for
//! CPython >= 3.9): [`operator`] the loaded file and its per-point queries, [`evaluator`] frames
//! with numpy in and out and the GIL released, [`arrays`] the numpy conversions (float32 read
//! and written in place), [`trace`] rendering into an array, [`cli`] the `lrr` command line
//! in-process (the bake's child process, exports), [`errors`] the exceptions, [`testing`] what
//! the tests and benchmark need. The Python side (`lrr/`) adds `bake`, the exceptions and the
//! stubs. See python/README.md.

mod arrays;
mod cli;
mod errors;
mod evaluator;
mod operator;
mod testing;
mod trace;

use pyo3::prelude::*;

#[pymodule]
fn _lrr(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<operator::PyOperator>()?;
    m.add_class::<evaluator::PyEvaluator>()?;
    m.add_function(wrap_pyfunction!(cli::main, m)?)?;
    m.add_function(wrap_pyfunction!(cli::run, m)?)?;
    let testing = PyModule::new(m.py(), "_testing")?;
    testing::register(&testing)?;
    m.add_submodule(&testing)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
