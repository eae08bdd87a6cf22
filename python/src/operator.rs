//! `lrr.Operator`: a loaded operator file, its sizes and element geometry as numpy arrays,
//! and the per-point queries (locate, probe).

use std::path::PathBuf;
use std::sync::OnceLock;

use lrr_runtime::{Operator, Reconstruction, Rgb, RgbMut};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::arrays;
use crate::errors::{self, OrRaise};
use crate::evaluator::PyEvaluator;
use crate::trace;

/// A baked operator, loaded and validated. Immutable: albedo edits live in evaluators.
#[pyclass(module = "lrr", name = "Operator", frozen)]
pub struct PyOperator {
    pub op: Operator,
    /// The file it was read from (`export` hands it to the command line as is).
    pub path: Option<PathBuf>,
    centroids: OnceLock<Py<PyAny>>,
    normals: OnceLock<Py<PyAny>>,
    areas: OnceLock<Py<PyAny>>,
}

impl PyOperator {
    pub fn new(op: Operator, path: Option<PathBuf>) -> Self {
        PyOperator {
            op,
            path,
            centroids: OnceLock::new(),
            normals: OnceLock::new(),
            areas: OnceLock::new(),
        }
    }

    /// Vertices of the element at file position `s`: its own polygon (GEOMETRY, what its form
    /// factors were computed on; for its centroid, normal and area), not its display faces.
    fn corners(&self, s: usize) -> Vec<[f64; 3]> {
        let g = &self.op.file().geometry;
        (0..usize::from(g.vertex_count[s]))
            .map(|i| {
                let b = 12 * s + 3 * i;
                [0, 1, 2].map(|c| f64::from(g.vertices[b + c]))
            })
            .collect()
    }

    /// `f(corners, file position)` for every element, in original id order, as an
    /// `(n, width)` read-only array cached in `cell`.
    fn per_element<'py, T: numpy::Element + Copy + Default>(
        &self,
        py: Python<'py>,
        cell: &OnceLock<Py<PyAny>>,
        width: usize,
        f: impl Fn(&[[f64; 3]], usize) -> Vec<T>,
    ) -> PyResult<Bound<'py, PyAny>> {
        if let Some(a) = cell.get() {
            return Ok(a.bind(py).clone());
        }
        let n = self.op.n();
        let mut values = vec![T::default(); n * width];
        for (s, &id) in self.op.file().order.iter().enumerate() {
            let v = f(&self.corners(s), s);
            values[id as usize * width..(id as usize + 1) * width].copy_from_slice(&v);
        }
        let dims: Vec<usize> = if width == 1 { vec![n] } else { vec![n, width] };
        let array = arrays::readonly_array(py, values, &dims)?;
        Ok(cell.get_or_init(|| array.clone().unbind()).bind(py).clone())
    }

    /// Light-group intensities from a dict `{name: a}` (others 1) or a sequence (one each).
    pub fn intensities(&self, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f32>> {
        let py = obj.py();
        let names: Vec<&str> = self.op.light_groups().collect();
        if let Ok(d) = obj.cast::<PyDict>() {
            let mut a = vec![1.0f32; names.len()];
            for (key, value) in d.iter() {
                let name: String = key.extract()?;
                let g = self.op.light_group(&name).ok_or_else(|| {
                    errors::input(
                        py,
                        format!(
                            "no light group '{name}' (the file has: {})",
                            names.join(", ")
                        ),
                    )
                })?;
                a[g] = value.extract()?;
            }
            return Ok(a);
        }
        let a: Vec<f32> = obj.extract().map_err(|_| {
            errors::input(
                py,
                "intensities: a dict {group name: intensity} or one number per light group",
            )
        })?;
        Ok(a)
    }

    /// The radiosity a query shows: `radiosity` given (n values), else the baked frame's.
    fn radiosity(
        &self,
        py: Python<'_>,
        radiosity: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Vec<[f32; 3]>> {
        let n = self.op.n();
        let Some(r) = radiosity else {
            return Ok(py.detach(|| self.op.evaluate_baked()));
        };
        let (array, o) = arrays::rgb_input(r, n, "radiosity")?;
        let mut scratch = vec![0.0f32; 3 * n];
        let source = array.source(o);
        let rgb = source.rgb(&mut scratch);
        Ok((0..n)
            .map(|i| match rgb {
                Rgb::Interleaved(s) => [s[3 * i], s[3 * i + 1], s[3 * i + 2]],
                Rgb::Planar([r, g, b]) => [r[i], g[i], b[i]],
            })
            .collect())
    }

    /// Whether a query shades smooth: `reconstruct` "smooth", "flat", or None (smooth when the
    /// file has the weights).
    pub fn smooth(&self, py: Python<'_>, reconstruct: Option<&str>) -> PyResult<bool> {
        let has = self.op.file().display.smooth.is_some();
        match reconstruct {
            None => Ok(has),
            Some("flat") => Ok(false),
            Some("smooth") if has => Ok(true),
            Some("smooth") => Err(errors::input(
                py,
                "reconstruct='smooth' needs the smooth weights (section SMOOTH) that bakes of \
                 format 1.2 carry; re-bake the file with this lrr, or use reconstruct='flat'",
            )),
            Some(other) => Err(errors::input(
                py,
                format!("reconstruct: 'smooth' or 'flat', got '{other}'"),
            )),
        }
    }
}

/// `(m, 3)` float32 points from any array-like, finite.
fn points(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f32; 3]>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let a = np
        .call_method1("ascontiguousarray", (obj, "float32"))
        .map_err(|e| errors::input(py, format!("{what}: not an array of numbers: {e}")))?;
    let a = a
        .cast_into::<PyArray2<f32>>()
        .map_err(|_| errors::input(py, format!("{what}: expected an array of shape (m, 3)")))?;
    let ro = a.readonly();
    let view = ro.as_array();
    if view.shape()[1] != 3 {
        return Err(errors::input(
            py,
            format!("{what}: expected shape (m, 3), got {:?}", view.shape()),
        ));
    }
    let out: Vec<[f32; 3]> = view.outer_iter().map(|r| [r[0], r[1], r[2]]).collect();
    if let Some(i) = out.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(errors::input(
            py,
            format!("{what}: point {i} is not finite"),
        ));
    }
    Ok(out)
}

/// `(n, 3)` float32 rows as a new, writable array.
fn rows<'py>(py: Python<'py>, values: Vec<[f32; 3]>) -> PyResult<Bound<'py, PyAny>> {
    let n = values.len();
    let flat: Vec<f32> = values.into_iter().flatten().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([n, 3])?.into_any())
}

/// Points (or normals) of a query.
type Points = Vec<[f32; 3]>;

/// Points and normals of one query, same length.
fn query(
    points_obj: &Bound<'_, PyAny>,
    normals_obj: &Bound<'_, PyAny>,
) -> PyResult<(Points, Points)> {
    let (p, nrm) = (
        points(points_obj, "points")?,
        points(normals_obj, "normals")?,
    );
    if p.len() != nrm.len() {
        return Err(errors::input(
            points_obj.py(),
            format!("{} points but {} normals", p.len(), nrm.len()),
        ));
    }
    Ok((p, nrm))
}

#[pymethods]
impl PyOperator {
    /// Reads and validates an operator file (``lrr.FormatError`` if it is missing, not an lrr
    /// file, of another version, truncated or corrupt).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let op = py.detach(|| Operator::load(&path)).or_raise(py)?;
        Ok(PyOperator::new(op, Some(path)))
    }

    /// Parses an operator file held in memory (``bytes``, ``bytearray`` or ``memoryview``).
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &Bound<'_, PyAny>) -> PyResult<Self> {
        let bytes: Vec<u8>;
        let slice: &[u8] = match data.cast::<PyBytes>() {
            Ok(b) => b.as_bytes(),
            Err(_) => {
                // Anything with the buffer protocol; an int or a str is a TypeError.
                bytes = py
                    .import("builtins")?
                    .getattr("memoryview")?
                    .call1((data,))?
                    .call_method0("tobytes")?
                    .extract()?;
                &bytes
            }
        };
        let op = py.detach(|| Operator::from_bytes(slice)).or_raise(py)?;
        Ok(PyOperator::new(op, None))
    }

    /// The file's bytes as written (``Operator.from_bytes(op.to_bytes())`` is the same operator).
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = py
            .detach(|| self.op.file().to_bytes())
            .map_err(|e| errors::runtime(py, e.into()))?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// Number of elements (fine mesh).
    #[getter]
    fn n(&self) -> usize {
        self.op.n()
    }

    /// Number of patches (coarse mesh).
    #[getter]
    fn k(&self) -> usize {
        self.op.k()
    }

    /// Channels of the operator: 1 (grey reflectance) or 3.
    #[getter]
    fn channels(&self) -> usize {
        self.op.channels()
    }

    /// ``"factored"`` (F_k and k×k cores) or ``"plain"`` (Y_k per channel).
    #[getter]
    fn layout(&self) -> &'static str {
        match self.op.layout() {
            lrr_runtime::Layout::Factored => "factored",
            lrr_runtime::Layout::PlainYk => "plain",
        }
    }

    /// ``"f32"`` or ``"f16"``: how the n×k matrix is stored.
    #[getter]
    fn precision(&self) -> &'static str {
        match self.op.precision() {
            lrr_runtime::Precision::F32 => "f32",
            lrr_runtime::Precision::F16 => "f16",
        }
    }

    /// Bytes of the stored matrix a frame reads.
    #[getter]
    fn matrix_bytes(&self) -> usize {
        self.op.matrix_bytes()
    }

    /// The file this operator was loaded from (None: from bytes).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    /// Names of the light groups, in the order ``evaluate_groups`` takes intensities.
    #[getter]
    fn light_groups(&self) -> Vec<String> {
        self.op.light_groups().map(str::to_string).collect()
    }

    /// The bake's metadata (a dict parsed from the file's JSON).
    #[getter]
    fn metadata<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        py.import("json")?
            .call_method1("loads", (self.op.metadata_json(),))
    }

    /// Named surfaces: ``{name: element ids (int64 array)}``, in the bake's order.
    #[getter]
    fn surfaces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dict = PyDict::new(py);
        let meta: serde_json::Value =
            serde_json::from_str(self.op.metadata_json()).unwrap_or_default();
        let Some(list) = meta.get("surfaces").and_then(|s| s.as_array()) else {
            return Ok(dict);
        };
        for s in list {
            let name = s.get("name").and_then(|v| v.as_str()).unwrap_or_default();
            let mut ids: Vec<i64> = Vec::new();
            for r in s
                .get("elements")
                .and_then(|v| v.as_array())
                .into_iter()
                .flatten()
            {
                let (a, b) = (r[0].as_i64().unwrap_or(0), r[1].as_i64().unwrap_or(0));
                ids.extend(a..b);
            }
            dict.set_item(name, PyArray1::from_vec(py, ids))?;
        }
        Ok(dict)
    }

    /// Element centroids (mean of the corners), ``(n, 3)`` float64, scene units, element ids.
    /// Computed once, read-only.
    #[getter]
    fn element_centroids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_element(py, &self.centroids, 3, |c, _| {
            let m = c.len() as f64;
            (0..3)
                .map(|j| c.iter().map(|v| v[j]).sum::<f64>() / m)
                .collect()
        })
    }

    /// Unit normals (the side that receives and emits light), ``(n, 3)`` float32, element ids.
    /// Computed once, read-only.
    #[getter]
    fn element_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let normals = &self.op.file().geometry.normals;
        self.per_element(py, &self.normals, 3, |_, s| {
            normals[3 * s..3 * s + 3].to_vec()
        })
    }

    /// Element areas, ``(n,)`` float64, scene units². Computed once, read-only.
    #[getter]
    fn element_areas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.per_element(py, &self.areas, 1, |c, _| {
            let mut sum = [0.0f64; 3];
            for i in 0..c.len() {
                let (a, b) = (c[i], c[(i + 1) % c.len()]);
                sum[0] += a[1] * b[2] - a[2] * b[1];
                sum[1] += a[2] * b[0] - a[0] * b[2];
                sum[2] += a[0] * b[1] - a[1] * b[0];
            }
            vec![0.5 * (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt()]
        })
    }

    /// The emission the scene was baked with: ``(n, 3)`` float32 exitance per unit area (the
    /// scene's units), element ids; a new array.
    #[getter]
    fn baked_emission<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows(py, self.op.baked_emission())
    }

    /// Reflectance per element, ``(n, 3)`` float32 in [0, 1), element ids; a new array.
    #[getter]
    fn reflectance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows(py, self.op.reflectance())
    }

    /// A persistent evaluator with ``threads`` threads in all (0: one per core). Its buffers
    /// are allocated here; a frame allocates nothing.
    #[pyo3(signature = (threads = 0))]
    fn evaluator(slf: &Bound<'_, Self>, threads: usize) -> PyResult<PyEvaluator> {
        PyEvaluator::new(slf, threads)
    }

    /// The element under each surface point: ``(m,)`` int64 element ids. ``points`` and
    /// ``normals`` are ``(m, 3)``; the normal tells coincident surfaces apart.
    fn locate<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let (p, nrm) = query(points, normals)?;
        let ids: Vec<i64> = py.detach(|| {
            p.iter()
                .zip(&nrm)
                .map(|(p, n)| self.op.locate(*p, *n).map_or(-1, i64::from))
                .collect()
        });
        Ok(PyArray1::from_vec(py, ids))
    }

    /// Radiosity (exitance, W/m²) at surface points, ``(m, 3)`` float32, as ``lrr probe``
    /// computes it: of ``radiosity`` (an ``(n, 3)`` or ``(3, n)`` frame, e.g. from
    /// ``Evaluator.evaluate``) or, by default, of the baked emission; ``reconstruct``:
    /// ``"smooth"`` (interpolated, the default when the file has smooth weights) or ``"flat"``
    /// (the value of the element the point falls in).
    #[pyo3(signature = (points, normals, radiosity = None, reconstruct = None))]
    fn probe<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        normals: &Bound<'py, PyAny>,
        radiosity: Option<&Bound<'py, PyAny>>,
        reconstruct: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (p, nrm) = query(points, normals)?;
        let smooth = self.smooth(py, reconstruct)?;
        let b = self.radiosity(py, radiosity)?;
        let values: Vec<[f32; 3]> = py
            .detach(|| -> Result<_, lrr_runtime::RuntimeError> {
                let rec = if smooth {
                    Some(Reconstruction::new(self.op.file())?)
                } else {
                    None
                };
                let mut vertices = Vec::new();
                if let Some(r) = &rec {
                    vertices = vec![[0.0f32; 3]; r.vertex_count()];
                    r.vertex_values(&b, &mut vertices)?;
                }
                Ok(p.iter()
                    .zip(&nrm)
                    .map(|(p, n)| {
                        // The display face under the point, and its element.
                        let face = self
                            .op
                            .locate_face(*p, *n)
                            .expect("an operator has at least one element");
                        match &rec {
                            Some(r) => r.at(&vertices, face, *p),
                            None => {
                                let s = self.op.file().faces().element(face);
                                b[self.op.file().order[s] as usize]
                            }
                        }
                    })
                    .collect())
            })
            .or_raise(py)?;
        let flat: Vec<f32> = values.into_iter().flatten().collect();
        numpy::PyArray1::from_vec(py, flat).reshape([p.len(), 3])
    }

    /// Ray traces a frame (the runtime's CPU tracer, all cores by default): ``(height, width,
    /// 3)`` float32 linear radiance ``B/π`` per pixel plus highlights, mirrors and glass as the
    /// file's materials and point lights call for. The camera: the file's camera ``camera``
    /// (default: its first), fields overridden by ``eye``, ``target``, ``up`` (scene units) and
    /// ``fov_y`` (degrees). The frame: ``radiosity`` (``(n, 3)``, e.g. from
    /// ``Evaluator.evaluate``), else the light groups at ``groups`` (dict or sequence; they also
    /// scale the point lights), else the baked emission. Needs a file with a BVH (format 1.2).
    #[pyo3(signature = (width = 640, height = 480, *, camera = None, eye = None, target = None,
                        up = None, fov_y = None, radiosity = None, groups = None,
                        reconstruct = None, max_depth = 8, threads = 0))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        width: u32,
        height: u32,
        camera: Option<String>,
        eye: Option<[f32; 3]>,
        target: Option<[f32; 3]>,
        up: Option<[f32; 3]>,
        fov_y: Option<f32>,
        radiosity: Option<&Bound<'py, PyAny>>,
        groups: Option<&Bound<'py, PyAny>>,
        reconstruct: Option<&str>,
        max_depth: u32,
        threads: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let smooth = self.smooth(py, reconstruct)?;
        let intensities = match groups {
            Some(g) => self.intensities(g)?,
            None => vec![1.0; self.op.light_groups().len()],
        };
        let b = match (radiosity, groups) {
            (Some(r), _) => self.radiosity(py, Some(r))?,
            (None, Some(_)) => {
                let mut out = vec![[0.0f32; 3]; self.op.n()];
                py.detach(|| {
                    self.op
                        .evaluate_groups(&intensities, RgbMut::triples(&mut out))
                })
                .or_raise(py)?;
                out
            }
            (None, None) => self.radiosity(py, None)?,
        };
        let args = trace::RenderArgs {
            width,
            height,
            camera: lrr_runtime::trace::CameraFields {
                name: camera,
                eye,
                target,
                up,
                fov_y_deg: fov_y,
            },
            smooth,
            max_depth,
            threads,
        };
        let pixels = py
            .detach(|| trace::render(&self.op, &b, &intensities, &args))
            .or_raise(py)?;
        let flat: Vec<f32> = pixels.into_iter().flatten().collect();
        Ok(PyArray1::from_vec(py, flat)
            .reshape([height as usize, width as usize, 3])?
            .into_any())
    }

    /// Writes a frame as files other tools read, through ``lrr export`` (the format from the
    /// extension of ``output``: ``.exr`` lightmap atlas, ``.glb``/``.gltf`` scene). ``groups``
    /// (dict) or ``emission`` (``(n, 3)``) choose the frame; other keyword arguments are the
    /// command's flags (``size=1024``, ``uv="generated"``, ``layers="groups"``,
    /// ``lightmap=True``, ...). Returns what the command printed.
    #[pyo3(signature = (output, **flags))]
    fn export(
        slf: &Bound<'_, Self>,
        output: PathBuf,
        flags: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        let commands = slf.py().import("lrr._commands")?;
        commands
            .call_method("export", (slf, output), flags)?
            .extract()
    }

    fn __repr__(&self) -> String {
        format!(
            "<lrr.Operator n={} k={} channels={} {} {} light_groups={:?}>",
            self.op.n(),
            self.op.k(),
            self.op.channels(),
            self.layout(),
            self.precision(),
            self.light_groups()
        )
    }
}
