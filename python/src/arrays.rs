//! numpy arrays in and out. RGB values per element (original ids) are `(n, 3)` rows or
//! `(3, n)` planes; C-contiguous float32 is read and written in place, anything else
//! (float64, strided views) is converted into a buffer the caller allocated once, so a frame
//! allocates nothing on the Python side either.

use lrr_runtime::{Rgb, RgbMut};
use numpy::ndarray::ArrayView2;
use numpy::{
    PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadwriteArray2, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors;

/// Which axis holds the elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Orientation {
    /// `(n, 3)`: a row `[r, g, b]` per element.
    Rows,
    /// `(3, n)`: a plane of `n` values per channel.
    Planes,
}

impl Orientation {
    /// The orientation of `shape` for `n` elements (`(3, 3)` is rows).
    fn of(shape: &[usize], n: usize) -> Option<Self> {
        match shape {
            [a, 3] if *a == n => Some(Orientation::Rows),
            [3, b] if *b == n => Some(Orientation::Planes),
            _ => None,
        }
    }

    /// The numpy shape of `n` elements.
    pub fn dims(self, n: usize) -> [usize; 2] {
        match self {
            Orientation::Rows => [n, 3],
            Orientation::Planes => [3, n],
        }
    }
}

/// An RGB array borrowed read-only from Python (numpy's borrow flags keep writers out).
pub enum RgbArray<'py> {
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

/// `obj` as RGB values of `n` elements: a float32 or float64 numpy array of shape `(n, 3)` or
/// `(3, n)`, or anything `numpy.asarray` makes into one (lists: float64). `what` names the
/// argument in errors.
pub fn rgb_input<'py>(
    obj: &Bound<'py, PyAny>,
    n: usize,
    what: &str,
) -> PyResult<(RgbArray<'py>, Orientation)> {
    let py = obj.py();
    let array = match obj.cast::<PyUntypedArray>() {
        Ok(a) => a.clone(),
        Err(_) => {
            let np = py.import("numpy")?;
            let converted = np.call_method1("asarray", (obj,)).map_err(|e| {
                errors::input(py, format!("{what}: not convertible to an array: {e}"))
            })?;
            converted
                .cast_into::<PyUntypedArray>()
                .map_err(|_| errors::input(py, format!("{what}: not convertible to an array")))?
        }
    };
    let shape = array.shape().to_vec();
    let Some(orientation) = Orientation::of(&shape, n) else {
        return Err(errors::input(
            py,
            format!(
                "{what}: expected shape ({n}, 3) or (3, {n}) (n = {n} elements), got {shape:?}"
            ),
        ));
    };
    let readonly = |e: numpy::BorrowError| errors::input(py, format!("{what}: {e}"));
    if let Ok(a) = array.cast::<PyArray2<f32>>() {
        return Ok((
            RgbArray::F32(a.try_readonly().map_err(readonly)?),
            orientation,
        ));
    }
    if let Ok(a) = array.cast::<PyArray2<f64>>() {
        return Ok((
            RgbArray::F64(a.try_readonly().map_err(readonly)?),
            orientation,
        ));
    }
    let dtype = array.dtype().to_string();
    if obj.cast::<PyUntypedArray>().is_ok() {
        return Err(errors::input(
            py,
            format!("{what}: expected a float32 or float64 array, got dtype {dtype}"),
        ));
    }
    // A list of ints, say: numpy chose an integer dtype; read it as float64.
    let np = py.import("numpy")?;
    let as_f64 = np.call_method1("asarray", (array, "float64"))?;
    rgb_input(&as_f64, n, what)
}

/// The values in memory order when C-contiguous (an F-contiguous array is a slice too, in the
/// other order: converted like a strided view).
fn contiguous<'a>(a: &'a PyReadonlyArray2<'_, f32>) -> Result<&'a [f32], ()> {
    if a.is_c_contiguous() {
        a.as_slice().map_err(|_| ())
    } else {
        Err(())
    }
}

/// What a frame reads, borrowed without the GIL: a slice numpy holds, or a view to convert.
pub enum Source<'a> {
    Ready(Rgb<'a>),
    F32(ArrayView2<'a, f32>, Orientation),
    F64(ArrayView2<'a, f64>, Orientation),
}

impl<'py> RgbArray<'py> {
    /// The values as a [`Source`]: in place when C-contiguous float32.
    pub fn source(&self, orientation: Orientation) -> Source<'_> {
        match self {
            RgbArray::F32(a) => match (contiguous(a), orientation) {
                (Ok(s), Orientation::Rows) => Source::Ready(Rgb::Interleaved(s)),
                (Ok(s), Orientation::Planes) => {
                    let n = s.len() / 3;
                    Source::Ready(Rgb::Planar([&s[..n], &s[n..2 * n], &s[2 * n..]]))
                }
                (Err(_), o) => Source::F32(a.as_array(), o),
            },
            RgbArray::F64(a) => Source::F64(a.as_array(), orientation),
        }
    }
}

impl<'a> Source<'a> {
    /// The values as the runtime reads them; a conversion fills `scratch` (3n f32,
    /// interleaved) first. Runs without the GIL.
    pub fn rgb<'s>(&'s self, scratch: &'s mut [f32]) -> Rgb<'s> {
        match self {
            Source::Ready(rgb) => *rgb,
            Source::F32(view, o) => fill(view, *o, scratch, |v| v),
            Source::F64(view, o) => fill(view, *o, scratch, |v| v as f32),
        }
    }
}

/// `view` (rows or planes) into `scratch` as interleaved f32.
fn fill<'s, T: Copy>(
    view: &ArrayView2<'_, T>,
    orientation: Orientation,
    scratch: &'s mut [f32],
    convert: impl Fn(T) -> f32,
) -> Rgb<'s> {
    let rows = match orientation {
        Orientation::Rows => view.view(),
        Orientation::Planes => view.t(),
    };
    for (i, row) in rows.outer_iter().enumerate() {
        for c in 0..3 {
            scratch[3 * i + c] = convert(row[c]);
        }
    }
    Rgb::Interleaved(scratch)
}

/// The output array: `out` checked (float32, C-contiguous, writable, `(n, 3)` or `(3, n)`,
/// not the input) or a new `(n, 3)`/`(3, n)` array in `orientation`.
pub fn rgb_output<'py>(
    py: Python<'py>,
    out: Option<&Bound<'py, PyAny>>,
    n: usize,
    orientation: Orientation,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let Some(out) = out else {
        return Ok(PyArray2::<f32>::zeros(py, orientation.dims(n), false));
    };
    let array = out.cast::<PyArray2<f32>>().map_err(|_| {
        errors::input(
            py,
            format!("out: expected a float32 numpy array of shape ({n}, 3) or (3, {n})"),
        )
    })?;
    if Orientation::of(array.shape(), n).is_none() {
        return Err(errors::input(
            py,
            format!(
                "out: expected shape ({n}, 3) or (3, {n}), got {:?}",
                array.shape()
            ),
        ));
    }
    if !array.is_c_contiguous() {
        return Err(errors::input(py, "out: must be C-contiguous"));
    }
    Ok(array.clone())
}

/// Borrows `out` for writing (an error when it is read-only or is also an input).
pub fn writable<'py>(out: &Bound<'py, PyArray2<f32>>) -> PyResult<PyReadwriteArray2<'py, f32>> {
    out.try_readwrite().map_err(|e| {
        errors::input(
            out.py(),
            format!("out: cannot write to it ({e}: read-only, or also passed as an input)"),
        )
    })
}

/// The writable array as the runtime writes it.
pub fn rgb_mut<'a>(out: &'a mut PyReadwriteArray2<'_, f32>) -> RgbMut<'a> {
    let planes = out.shape()[0] == 3 && out.shape()[1] != 3;
    let s = out.as_slice_mut().expect("checked C-contiguous");
    if planes {
        let n = s.len() / 3;
        let (r, rest) = s.split_at_mut(n);
        let (g, b) = rest.split_at_mut(n);
        RgbMut::Planar([r, g, b])
    } else {
        RgbMut::Interleaved(s)
    }
}

/// A read-only numpy array of `values` (a copy computed once; numpy owns it).
pub fn readonly_array<'py, T: numpy::Element>(
    py: Python<'py>,
    values: Vec<T>,
    dims: &[usize],
) -> PyResult<Bound<'py, PyAny>> {
    let a = numpy::PyArray1::from_vec(py, values).reshape(dims.to_vec())?;
    let kwargs = pyo3::types::PyDict::new(py);
    kwargs.set_item("write", false)?;
    a.call_method("setflags", (), Some(&kwargs))?;
    Ok(a.into_any())
}
