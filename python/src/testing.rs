//! `lrr._testing`: what the tests and the benchmark need beside the public API: synthetic
//! operators (the runtime's testkit), frames timed in Rust on the same evaluator, and a frame
//! that keeps the GIL (the control of the GIL test).

use std::time::Instant;

use lrr_runtime::testkit::synthetic;
use lrr_runtime::{Layout, Precision, Rgb, RgbMut};
use numpy::{PyArray2, PyArrayMethods};
use pyo3::prelude::*;

use crate::arrays;
use crate::errors::OrRaise;
use crate::evaluator::{InFlight, PyEvaluator, State};
use crate::operator::PyOperator;

/// The testkit's synthetic operator (what ``lrr bench runtime`` measures): n elements, k
/// patches, RGB, f32 or f16, factored or plain, deterministic in ``seed``.
#[pyfunction]
#[pyo3(signature = (n, k, precision = "f32", layout = "factored", seed = 7))]
fn synthetic_operator(
    py: Python<'_>,
    n: usize,
    k: usize,
    precision: &str,
    layout: &str,
    seed: u64,
) -> PyResult<PyOperator> {
    let precision = if precision == "f16" {
        Precision::F16
    } else {
        Precision::F32
    };
    let layout = if layout == "plain" {
        Layout::PlainYk
    } else {
        Layout::Factored
    };
    let op = py
        .detach(|| synthetic::operator(n, k, 3, precision, layout, seed))
        .or_raise(py)?;
    Ok(PyOperator::new(op, None))
}

/// The emission of ``lrr bench runtime``: every 97th element at (1, 0.8, 0.6).
fn bench_emission(n: usize) -> Vec<[f32; 3]> {
    (0..n)
        .map(|i| {
            if i % 97 == 0 {
                [1.0, 0.8, 0.6]
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Seconds of each of ``frames`` frames of ``evaluator`` called from Rust (Rust-owned
/// buffers, the bench's emission, the GIL released): the baseline of ``bench/evaluate.py``.
#[pyfunction]
fn rust_frame_seconds(
    py: Python<'_>,
    evaluator: &PyEvaluator,
    frames: usize,
) -> PyResult<Vec<f64>> {
    let n = evaluator.n();
    let emission = bench_emission(n);
    let mut out = vec![[0.0f32; 3]; n];
    py.detach(|| {
        let mut guard = evaluator.lock();
        let mut seconds = Vec::with_capacity(frames);
        for _ in 0..frames {
            let start = Instant::now();
            guard
                .eval
                .evaluate(Rgb::triples(&emission), RgbMut::triples(&mut out))?;
            seconds.push(start.elapsed().as_secs_f64());
        }
        Ok(seconds)
    })
    .or_raise(py)
}

/// The radiosity of the bench emission evaluated from Rust (Rust-owned buffers), copied out:
/// what ``evaluate`` from Python must equal.
#[pyfunction]
fn rust_bench_frame<'py>(
    py: Python<'py>,
    evaluator: &PyEvaluator,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let n = evaluator.n();
    let emission = bench_emission(n);
    let mut out = vec![[0.0f32; 3]; n];
    py.detach(|| {
        evaluator
            .lock()
            .eval
            .evaluate(Rgb::triples(&emission), RgbMut::triples(&mut out))
    })
    .or_raise(py)?;
    let flat: Vec<f32> = out.into_iter().flatten().collect();
    numpy::PyArray1::from_vec(py, flat).reshape([n, 3])
}

/// ``evaluator.evaluate(emission, out)`` without releasing the GIL (float32 ``(n, 3)`` only):
/// the control that shows the concurrency test can fail.
#[pyfunction]
fn evaluate_holding_gil<'py>(
    evaluator: &PyEvaluator,
    emission: &Bound<'py, PyAny>,
    out: &Bound<'py, PyAny>,
) -> PyResult<()> {
    let py = emission.py();
    let (input, o) = arrays::rgb_input(emission, evaluator.n(), "emission")?;
    let result: Bound<'py, PyArray2<f32>> = arrays::rgb_output(py, Some(out), evaluator.n(), o)?;
    let mut w = arrays::writable(&result)?;
    let source = input.source(o);
    let _frame = InFlight::start();
    let mut guard = evaluator.lock();
    let State { eval, scratch } = &mut *guard;
    eval.evaluate(source.rgb(scratch), arrays::rgb_mut(&mut w))
        .or_raise(py)
}

/// The most frames (``evaluate``, ``evaluate_groups``, ``evaluate_holding_gil``) that ran at
/// the same moment since the last call.
#[pyfunction]
fn most_frames_at_once() -> usize {
    InFlight::take_most()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(synthetic_operator, m)?)?;
    m.add_function(wrap_pyfunction!(rust_frame_seconds, m)?)?;
    m.add_function(wrap_pyfunction!(rust_bench_frame, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_holding_gil, m)?)?;
    m.add_function(wrap_pyfunction!(most_frames_at_once, m)?)?;
    Ok(())
}
