//! `lrr.Evaluator`: frames of one operator on a persistent pool, numpy in and out, the GIL
//! released while a frame runs.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard, PoisonError};

use lrr_runtime::Evaluator;
use numpy::PyArray2;
use pyo3::prelude::*;

use crate::arrays::{self, Orientation};
use crate::errors::OrRaise;
use crate::operator::PyOperator;

/// What a frame mutates: the runtime's evaluator and the conversion buffer (3n f32) of
/// emissions that are not C-contiguous float32. Both allocated once.
pub struct State {
    pub eval: Evaluator,
    pub scratch: Vec<f32>,
}

/// Frames running now in this process, and the most seen at once (`lrr._lrr._testing`: the
/// proof that frames of two Python threads overlap). Two atomic adds per frame.
static IN_FLIGHT: AtomicUsize = AtomicUsize::new(0);
static MOST_IN_FLIGHT: AtomicUsize = AtomicUsize::new(0);

/// Counts a frame in flight while alive.
pub struct InFlight;

impl InFlight {
    pub fn start() -> Self {
        let now = IN_FLIGHT.fetch_add(1, Ordering::SeqCst) + 1;
        MOST_IN_FLIGHT.fetch_max(now, Ordering::SeqCst);
        InFlight
    }

    /// The most frames in flight at once since the last call.
    pub fn take_most() -> usize {
        MOST_IN_FLIGHT.swap(0, Ordering::SeqCst)
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        IN_FLIGHT.fetch_sub(1, Ordering::SeqCst);
    }
}

/// A persistent evaluator (``Operator.evaluator(threads)``). Calls from several Python threads
/// are serialised on this evaluator; make one evaluator per thread to run frames concurrently.
#[pyclass(module = "lrr", name = "Evaluator", frozen)]
pub struct PyEvaluator {
    operator: Py<PyOperator>,
    n: usize,
    state: Mutex<State>,
}

impl PyEvaluator {
    pub fn new(op: &Bound<'_, PyOperator>, threads: usize) -> PyResult<Self> {
        let py = op.py();
        let inner = op.get();
        let eval = py.detach(|| inner.op.evaluator(threads)).or_raise(py)?;
        let n = inner.op.n();
        Ok(PyEvaluator {
            operator: op.clone().unbind(),
            n,
            state: Mutex::new(State {
                eval,
                scratch: vec![0.0; 3 * n],
            }),
        })
    }

    /// The state, waiting without the GIL when another thread holds it.
    pub fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn n(&self) -> usize {
        self.n
    }
}

#[pymethods]
impl PyEvaluator {
    /// Radiosity ``B`` (exitance) for the per-element emission ``emission``: ``(n, 3)`` or
    /// ``(3, n)``, float32 (read in place when C-contiguous) or float64, finite and
    /// non-negative, element ids. Returns ``out`` when given (float32, C-contiguous, ``(n, 3)``
    /// or ``(3, n)``), else a new array shaped like ``emission``. The GIL is released while the
    /// frame runs; on an error nothing is written.
    #[pyo3(signature = (emission, out = None))]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        emission: &Bound<'py, PyAny>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (input, orientation) = arrays::rgb_input(emission, self.n, "emission")?;
        let result = arrays::rgb_output(py, out, self.n, orientation)?;
        {
            let mut w = arrays::writable(&result)?;
            let source = input.source(orientation);
            let dst = arrays::rgb_mut(&mut w);
            py.detach(|| {
                let _frame = InFlight::start();
                let mut guard = self.lock();
                let State { eval, scratch } = &mut *guard;
                eval.evaluate(source.rgb(scratch), dst)
            })
            .or_raise(py)?;
        }
        Ok(result)
    }

    /// Radiosity for light-group intensities: a dict ``{group: intensity}`` (groups not named
    /// stay at 1, as baked) or one intensity per ``Operator.light_groups`` entry; finite and
    /// non-negative. No O(n) pass over an emission. ``out`` as in ``evaluate`` (default: a new
    /// ``(n, 3)`` array).
    #[pyo3(signature = (intensities, out = None))]
    fn evaluate_groups<'py>(
        &self,
        py: Python<'py>,
        intensities: &Bound<'py, PyAny>,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let a = self.operator.get().intensities(intensities)?;
        let result = arrays::rgb_output(py, out, self.n, Orientation::Rows)?;
        {
            let mut w = arrays::writable(&result)?;
            let dst = arrays::rgb_mut(&mut w);
            py.detach(|| {
                let _frame = InFlight::start();
                self.lock().eval.evaluate_groups(&a, dst)
            })
            .or_raise(py)?;
        }
        Ok(result)
    }

    /// Changes the reflectance this evaluator uses (``(n, 3)`` or ``(3, n)``, each value in
    /// [0, 1), element ids) and rebuilds its k×k cores, O(nk + k³), no re-bake. The operator
    /// and other evaluators keep theirs. ``lrr.InputError`` for a plain-layout file, a value
    /// out of range or a singular system; on an error nothing changes.
    fn set_reflectance(&self, py: Python<'_>, rho: &Bound<'_, PyAny>) -> PyResult<()> {
        let (input, orientation) = arrays::rgb_input(rho, self.n, "reflectance")?;
        let mut scratch = vec![0.0f32; 3 * self.n];
        let rgb = input.source(orientation);
        let values: Vec<[f32; 3]> = match rgb.rgb(&mut scratch) {
            lrr_runtime::Rgb::Interleaved(s) => {
                s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
            }
            lrr_runtime::Rgb::Planar([r, g, b]) => {
                (0..self.n).map(|i| [r[i], g[i], b[i]]).collect()
            }
        };
        py.detach(|| self.lock().eval.set_reflectance(&values))
            .or_raise(py)
    }

    /// The operator this evaluator evaluates.
    #[getter]
    fn operator(&self, py: Python<'_>) -> Py<PyOperator> {
        self.operator.clone_ref(py)
    }

    /// Threads in all, the caller's included.
    #[getter]
    fn threads(&self) -> usize {
        self.lock().eval.threads()
    }

    /// The kernels' instruction set, e.g. ``"Avx2"`` or ``"Scalar"``.
    #[getter]
    fn simd(&self) -> String {
        format!("{:?}", self.lock().eval.simd())
    }

    /// Bytes allocated once and reused by every frame (the runtime's and the conversion
    /// buffer's).
    #[getter]
    fn scratch_bytes(&self) -> usize {
        let s = self.lock();
        s.eval.scratch_bytes() + 4 * s.scratch.len()
    }

    fn __repr__(&self) -> String {
        let s = self.lock();
        format!(
            "<lrr.Evaluator n={} threads={} simd={:?}>",
            self.n,
            s.eval.threads(),
            s.eval.simd()
        )
    }
}
