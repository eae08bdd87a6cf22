//! Smooth reconstruction: radiosity at any surface point from the element values, through the
//! file's SMOOTH weights (`lrr_formats::Smooth`; made by the bake, `precompute/src/mesh/smooth.rs`).
//!
//! Two steps, so that per-point work is small:
//! 1. once per frame, [`Reconstruction::vertex_values`]: each smooth vertex's value, the
//!    weighted sum of its elements' `B` (O(size of SMOOTH)), clamped at zero (a vertex on a
//!    surface's boundary extrapolates, with negative weights);
//! 2. per point, [`Reconstruction::at`]: the corner values of the display face holding the
//!    point interpolated by mean value coordinates (Floater 2003; on a triangle these are the
//!    barycentric coordinates), O(corners) with no allocation. Mean value coordinates reproduce
//!    linear fields exactly and reduce to linear interpolation along each edge, so the value is
//!    continuous across every edge two faces share. A point off its face (a probe a little
//!    outside) takes the value at the nearest point of the face's boundary.
//!
//! SMOOTH is defined on the file's display faces
//! ([`OperatorFile::faces`](lrr_formats::OperatorFile::faces): section FACES, or GEOMETRY's
//! elements when the file has none, a face then being its element's file position).
//! [`Reconstruction::corner_value`] gives per-corner values for exports (vertex colours).
//!
//! ```
//! # use lrr_runtime::{Operator, Reconstruction};
//! # fn show(op: &Operator) -> Result<(), lrr_runtime::RuntimeError> {
//! let smooth = Reconstruction::new(op.file())?; // an error when the file has no SMOOTH
//! let b = op.evaluate_baked(); // per element, original ids
//! let mut vertices = vec![[0.0f32; 3]; smooth.vertex_count()];
//! smooth.vertex_values(&b, &mut vertices)?; // once per frame
//! let value = smooth.at(&vertices, 0, [0.1, 0.2, 0.3]); // per point: display face, point
//! # Ok(()) }
//! ```

use lrr_formats::{Geometry, OperatorFile, Smooth};

use crate::error::{RuntimeError, input};

/// The smooth reconstruction of one operator file (borrowed; building it checks SMOOTH's
/// shape once, so that no call below can index out of bounds).
#[derive(Debug, Clone, Copy)]
pub struct Reconstruction<'f> {
    /// The display faces' polygons (SMOOTH's corners are theirs).
    geometry: &'f Geometry,
    smooth: &'f Smooth,
    order: &'f [u32],
}

impl<'f> Reconstruction<'f> {
    /// The reconstruction of `file`; an error when it has no SMOOTH section (files baked before
    /// format 1.2) or a damaged one.
    pub fn new(file: &'f OperatorFile) -> Result<Self, RuntimeError> {
        let smooth = file.display.smooth.as_ref().ok_or_else(|| {
            input(
                "the operator file has no smooth reconstruction weights (section SMOOTH, \
                 format 1.2): re-bake it with this lrr, or use the flat reconstruction",
            )
        })?;
        Self::from_parts(file.faces().geometry, smooth, &file.order)
    }

    /// The reconstruction over a file's parts (a copy of them, e.g. the ray tracer's: the
    /// display faces' polygons, SMOOTH, the order), checked as [`new`](Self::new) checks them.
    pub(crate) fn from_parts(
        geometry: &'f Geometry,
        smooth: &'f Smooth,
        order: &'f [u32],
    ) -> Result<Self, RuntimeError> {
        check(smooth, order.len(), &geometry.vertex_count)?;
        Ok(Self {
            geometry,
            smooth,
            order,
        })
    }

    /// Number of smooth vertices (the length of [`vertex_values`](Self::vertex_values)' output).
    pub fn vertex_count(&self) -> usize {
        self.smooth.vertex_count()
    }

    /// Each smooth vertex's value from `b`, the radiosity per element in *original ids* (what
    /// the evaluators write), into `out` (`vertex_count()` entries).
    pub fn vertex_values(&self, b: &[[f32; 3]], out: &mut [[f32; 3]]) -> Result<(), RuntimeError> {
        let n = self.order.len();
        if b.len() != n || out.len() != self.vertex_count() {
            return Err(input(format!(
                "smooth reconstruction: {} element values for {n} elements and {} vertex slots \
                 for {} smooth vertices",
                b.len(),
                out.len(),
                self.vertex_count()
            )));
        }
        let s = self.smooth;
        for (v, value) in out.iter_mut().enumerate() {
            let mut sum = [0.0f64; 3];
            for j in s.offsets[v] as usize..s.offsets[v + 1] as usize {
                let e = &b[self.order[s.positions[j] as usize] as usize];
                let w = f64::from(s.weights[j]);
                for c in 0..3 {
                    sum[c] += w * f64::from(e[c]);
                }
            }
            // Boundary vertices extrapolate (negative weights): never below zero.
            *value = sum.map(|x| x.max(0.0) as f32);
        }
        Ok(())
    }

    /// Number of display faces (what [`at`](Self::at) and
    /// [`corner_value`](Self::corner_value) take).
    pub fn face_count(&self) -> usize {
        self.geometry.len()
    }

    /// The value at corner `corner` of display face `face` (the file position of its element
    /// when the file has no section FACES), from [`vertex_values`](Self::vertex_values)'
    /// output. Panics when `face` or `corner` is out of range (a caller's bug).
    pub fn corner_value(&self, vertices: &[[f32; 3]], face: usize, corner: usize) -> [f32; 3] {
        assert!(corner < usize::from(self.geometry.vertex_count[face]));
        vertices[self.smooth.corners[4 * face + corner] as usize]
    }

    /// The value at `point` on display face `face` (e.g. a ray's hit on one of its triangles;
    /// the file position of its element when the file has no section FACES), from
    /// [`vertex_values`](Self::vertex_values)' output. Panics when `face` is out of range (a
    /// caller's bug).
    pub fn at(&self, vertices: &[[f32; 3]], face: usize, point: [f32; 3]) -> [f32; 3] {
        let count = usize::from(self.geometry.vertex_count[face]);
        let g = &self.geometry;
        let mut v = [[0.0f64; 3]; 4];
        for (i, vi) in v.iter_mut().enumerate().take(count) {
            let at = 12 * face + 3 * i;
            *vi = [0, 1, 2].map(|c| f64::from(g.vertices[at + c]));
        }
        let normal = [0, 1, 2].map(|c| f64::from(g.normals[3 * face + c]));
        let w = mean_value_weights(&v[..count], normal, point.map(f64::from));
        let mut sum = [0.0f64; 3];
        for (i, &wi) in w.iter().enumerate().take(count) {
            let value = vertices[self.smooth.corners[4 * face + i] as usize];
            for c in 0..3 {
                sum[c] += wi * f64::from(value[c]);
            }
        }
        sum.map(|x| x as f32)
    }
}

/// SMOOTH's shape against the file (`n` elements, the display faces' vertex `counts`): what
/// [`Reconstruction`] indexes (the format's validation checks the rest: weights finite and
/// summing to one).
fn check(s: &Smooth, n: usize, counts: &[u8]) -> Result<(), RuntimeError> {
    let vertices = s.vertex_count();
    let bad = |what: &str| {
        Err(input(format!(
            "the operator file's SMOOTH section is damaged: {what}; re-bake the file"
        )))
    };
    if s.corners.len() != 4 * counts.len() {
        return bad("its corners do not match the display faces");
    }
    for (k, &c) in s.corners.iter().enumerate() {
        let used = k % 4 < usize::from(counts[k / 4]);
        if used && c as usize >= vertices {
            return bad(&format!(
                "corner {} of face {} names no vertex",
                k % 4,
                k / 4
            ));
        }
    }
    let offsets_ok = s.offsets.first() == Some(&0)
        && s.offsets.windows(2).all(|w| w[0] <= w[1])
        && s.offsets.last().map(|&l| l as usize) == Some(s.positions.len())
        && s.weights.len() == s.positions.len();
    if !offsets_ok {
        return bad("its offsets do not cover its positions and weights");
    }
    if s.positions.iter().any(|&p| p as usize >= n) {
        return bad("a weight names no element");
    }
    Ok(())
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Mean value coordinates of `x` (projected onto the plane of the convex polygon `v` with unit
/// normal `n`), in the stable form of Hormann and Floater (2006): `w_i ∝ (t_{i-1} + t_i) / r_i`
/// with `t_i = tan(α_i / 2) = (r_i r_{i+1} − d_i·d_{i+1}) / ((d_i × d_{i+1})·n)`. On a vertex:
/// that vertex; on or beyond an edge's line: linear interpolation at the nearest boundary point.
pub(crate) fn mean_value_weights(v: &[[f64; 3]], n: [f64; 3], x: [f64; 3]) -> [f64; 4] {
    let m = v.len();
    let mut d = [[0.0f64; 3]; 4];
    let mut r = [0.0f64; 4];
    let mut scale = 0.0f64;
    for i in 0..m {
        let e = sub(v[i], x);
        let h = dot(e, n);
        d[i] = [e[0] - h * n[0], e[1] - h * n[1], e[2] - h * n[2]];
        r[i] = dot(d[i], d[i]).sqrt();
        scale = scale.max(dot(sub(v[(i + 1) % m], v[i]), sub(v[(i + 1) % m], v[i])).sqrt());
    }
    let mut w = [0.0f64; 4];
    let eps = 1e-12 * scale;
    if let Some(i) = (0..m).find(|&i| r[i] <= eps) {
        w[i] = 1.0;
        return w;
    }
    let mut t = [0.0f64; 4];
    for i in 0..m {
        let j = (i + 1) % m;
        let area = dot(cross(d[i], d[j]), n);
        if area <= 1e-12 * r[i] * r[j] {
            return nearest_edge_weights(v, x);
        }
        t[i] = (r[i] * r[j] - dot(d[i], d[j])) / area;
    }
    let mut total = 0.0;
    for i in 0..m {
        w[i] = (t[(i + m - 1) % m] + t[i]) / r[i];
        total += w[i];
    }
    w.map(|x| x / total)
}

/// Linear interpolation along the polygon edge nearest `x`, at `x`'s nearest point on it.
fn nearest_edge_weights(v: &[[f64; 3]], x: [f64; 3]) -> [f64; 4] {
    let m = v.len();
    let mut best = (f64::INFINITY, 0, 0.0);
    for i in 0..m {
        let ab = sub(v[(i + 1) % m], v[i]);
        let len2 = dot(ab, ab);
        let s = if len2 > 0.0 {
            (dot(sub(x, v[i]), ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let p = [0, 1, 2].map(|c| v[i][c] + s * ab[c]);
        let dist = dot(sub(x, p), sub(x, p));
        if dist < best.0 {
            best = (dist, i, s);
        }
    }
    let (_, i, s) = best;
    let mut w = [0.0f64; 4];
    w[i] = 1.0 - s;
    w[(i + 1) % m] += s;
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use lrr_formats::{OperatorData, Precision, StoredMatrix};

    /// A flat `nx × ny` grid of unit squares in z = 0 (or each square split into two triangles
    /// along a diagonal), in file order, with smooth weights by shared position (equal areas:
    /// equal weights), and `order` the identity.
    fn grid(nx: usize, ny: usize, triangles: bool) -> (Geometry, Smooth) {
        let mut g = Geometry {
            vertex_count: Vec::new(),
            vertices: Vec::new(),
            normals: Vec::new(),
        };
        let mut push = |corners: &[[f32; 2]]| {
            g.vertex_count.push(corners.len() as u8);
            for i in 0..4 {
                let [x, y] = corners.get(i).copied().unwrap_or([0.0; 2]);
                g.vertices.extend([x, y, 0.0]);
            }
            g.normals.extend([0.0, 0.0, 1.0]);
        };
        for j in 0..ny {
            for i in 0..nx {
                let (x, y) = (i as f32, j as f32);
                let (a, b, c, d) = ([x, y], [x + 1.0, y], [x + 1.0, y + 1.0], [x, y + 1.0]);
                if triangles {
                    push(&[a, b, c]);
                    push(&[a, c, d]);
                } else {
                    push(&[a, b, c, d]);
                }
            }
        }
        let smooth = crate::testkit::faces::smooth_by_position(&g, &|e| e as u32);
        (g, smooth)
    }

    fn file(g: Geometry, smooth: Smooth) -> OperatorFile {
        let n = g.vertex_count.len();
        OperatorFile {
            metadata_json: "{}".into(),
            n: n as u32,
            k: 1,
            channels: 1,
            precision: Precision::F32,
            order: (0..n as u32).collect(),
            index: vec![0, n as u32],
            weights: vec![1.0 / n as f32; n],
            operator: OperatorData::Factored {
                fk: StoredMatrix::F32(vec![0.0; n]),
                cores: vec![1.0],
            },
            reflectance: vec![0.5; 3 * n],
            emission: vec![0.0; 3 * n],
            geometry: g,
            lights: Vec::new(),
            display: lrr_formats::Display {
                smooth: Some(smooth),
                ..Default::default()
            },
        }
    }

    fn centroid(g: &Geometry, e: usize) -> [f64; 2] {
        let c = usize::from(g.vertex_count[e]);
        let mut s = [0.0; 2];
        for i in 0..c {
            s[0] += f64::from(g.vertices[12 * e + 3 * i]) / c as f64;
            s[1] += f64::from(g.vertices[12 * e + 3 * i + 1]) / c as f64;
        }
        s
    }

    /// Deterministic points in [0, 1)² (R2 sequence).
    fn points(count: usize) -> impl Iterator<Item = [f64; 2]> {
        (0..count).map(|i| {
            let i = i as f64 + 0.5;
            [(i * 0.754_877_666).fract(), (i * 0.569_840_291).fract()]
        })
    }

    /// The element of the grid holding (x, y) and the file positions of the grid.
    fn element_at(nx: usize, triangles: bool, x: f64, y: f64) -> usize {
        let (i, j) = (x.floor() as usize, y.floor() as usize);
        let cell = j * nx + i;
        if !triangles {
            cell
        } else if x - x.floor() >= y - y.floor() {
            2 * cell
        } else {
            2 * cell + 1
        }
    }

    #[test]
    fn constant_radiosity_reconstructs_exactly() {
        for triangles in [false, true] {
            let (g, s) = grid(4, 3, triangles);
            let f = file(g, s);
            let r = Reconstruction::new(&f).unwrap();
            let b = vec![[0.25f32, 1.5, 3.0]; f.n as usize];
            let mut v = vec![[0.0; 3]; r.vertex_count()];
            r.vertex_values(&b, &mut v).unwrap();
            for p in points(200) {
                let (x, y) = (p[0] * 4.0, p[1] * 3.0);
                let e = element_at(4, triangles, x, y);
                let got = r.at(&v, e, [x as f32, y as f32, 0.0]);
                for c in 0..3 {
                    assert!((got[c] - b[0][c]).abs() <= 1e-6 * b[0][c], "{got:?}");
                }
            }
        }
    }

    /// B of each element = a linear field at its centroid: inside (elements whose corners are
    /// all interior vertices) the reconstruction is that field, within f32 rounding.
    #[test]
    fn a_linear_field_reconstructs_exactly_inside() {
        let field = |x: f64, y: f64| 1.0 + 0.3 * x - 0.2 * y;
        for triangles in [false, true] {
            let (g, s) = grid(6, 5, triangles);
            let f = file(g, s);
            let g = &f.geometry;
            let r = Reconstruction::new(&f).unwrap();
            let b: Vec<[f32; 3]> = (0..f.n as usize)
                .map(|e| {
                    let [x, y] = centroid(g, e);
                    [field(x, y) as f32, 2.0 * field(x, y) as f32, 0.5]
                })
                .collect();
            let mut v = vec![[0.0; 3]; r.vertex_count()];
            r.vertex_values(&b, &mut v).unwrap();
            let mut checked = 0;
            for p in points(400) {
                // the interior cells: [1, 5) × [1, 4)
                let (x, y) = (1.0 + 4.0 * p[0], 1.0 + 3.0 * p[1]);
                let e = element_at(6, triangles, x, y);
                let got = r.at(&v, e, [x as f32, y as f32, 0.0]);
                let want = field(x, y);
                assert!((f64::from(got[0]) - want).abs() < 2e-6, "{got:?} vs {want}");
                assert!((f64::from(got[1]) - 2.0 * want).abs() < 4e-6);
                assert!((got[2] - 0.5).abs() < 1e-6);
                checked += 1;
            }
            assert_eq!(checked, 400);
        }
    }

    /// Arbitrary element values: the value on an edge is the same from both elements.
    #[test]
    fn values_are_continuous_across_shared_edges() {
        for triangles in [false, true] {
            let (g, s) = grid(3, 3, triangles);
            let f = file(g, s);
            let r = Reconstruction::new(&f).unwrap();
            let b: Vec<[f32; 3]> = (0..f.n as usize)
                .map(|e| [(e * 37 % 11) as f32, 1.0 + e as f32, 0.0])
                .collect();
            let mut v = vec![[0.0; 3]; r.vertex_count()];
            r.vertex_values(&b, &mut v).unwrap();
            for p in points(50) {
                // on the vertical line x = 1 (between cells 0 and 1 of each row)
                let y = 3.0 * p[0];
                let left = element_at(3, triangles, 0.999_999, y);
                let right = element_at(3, triangles, 1.000_001, y);
                let a = r.at(&v, left, [1.0, y as f32, 0.0]);
                let c = r.at(&v, right, [1.0, y as f32, 0.0]);
                for k in 0..3 {
                    assert!(
                        (a[k] - c[k]).abs() <= 1e-5 * (1.0 + a[k].abs()),
                        "{a:?} {c:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn mean_value_coordinates_reproduce_position_and_clamp_outside() {
        let n = [0.0, 0.0, 1.0];
        let quad = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.5, 1.0, 0.0],
            [-0.5, 1.5, 0.0],
        ];
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        for p in points(100) {
            let x = [0.2 + 1.6 * p[0], 0.1 + 0.9 * p[1], 0.3]; // inside the quad, off its plane
            let w = mean_value_weights(&quad, n, x);
            let back: [f64; 3] = [0, 1, 2].map(|c| (0..4).map(|i| w[i] * quad[i][c]).sum());
            assert!((back[0] - x[0]).abs() < 1e-12 && (back[1] - x[1]).abs() < 1e-12);
            assert!(w.iter().all(|&x| x > 0.0));
            let x = [0.9 * p[0] * (1.0 - p[1]), 0.9 * p[1], 0.0];
            let w = mean_value_weights(&tri, n, x);
            let bary = [1.0 - x[0] - x[1], x[0], x[1], 0.0];
            assert!(
                (0..4).all(|i| (w[i] - bary[i]).abs() < 1e-12),
                "{w:?} {bary:?}"
            );
        }
        // on a vertex, on an edge, beyond an edge
        assert_eq!(
            mean_value_weights(&tri, n, [1.0, 0.0, 0.0]),
            [0.0, 1.0, 0.0, 0.0]
        );
        let on = mean_value_weights(&tri, n, [0.25, 0.0, 0.0]);
        assert!((on[0] - 0.75).abs() < 1e-12 && (on[1] - 0.25).abs() < 1e-12 && on[2] == 0.0);
        let out = mean_value_weights(&tri, n, [0.25, -0.1, 0.0]);
        assert!((out[0] - 0.75).abs() < 1e-12 && (out[1] - 0.25).abs() < 1e-12);
    }

    /// A boundary vertex extrapolates with a negative weight: its value follows the weights,
    /// and never goes below zero.
    #[test]
    fn extrapolated_vertex_values_are_clamped_at_zero() {
        let (g, mut s) = grid(2, 1, false);
        // vertex 0 (corner (0, 0) of element 0): 1.5 B_0 - 0.5 B_1
        let end = s.offsets[1] as usize;
        s.positions.splice(0..end, [0, 1]);
        s.weights.splice(0..end, [1.5, -0.5]);
        let shift = 2 - end as i64;
        for o in s.offsets.iter_mut().skip(1) {
            *o = (*o as i64 + shift) as u32;
        }
        let f = file(g, s);
        let r = Reconstruction::new(&f).unwrap();
        let mut v = vec![[0.0; 3]; r.vertex_count()];
        r.vertex_values(&[[1.0, 1.0, 0.2], [0.5, 3.0, 0.2]], &mut v)
            .unwrap();
        assert_eq!(v[0], [1.25, 0.0, 0.2]);
        assert_eq!(r.at(&v, 0, [0.0, 0.0, 0.0]), v[0]);
    }

    /// A file drawn through display faces (section FACES): SMOOTH's corners are the faces',
    /// `at` takes a face, and the values come from the faces' elements (original ids through
    /// the order).
    #[test]
    fn the_reconstruction_follows_the_display_faces() {
        use crate::testkit::faces::{EMISSION, ORDER, face_at, interleaved};
        let f = interleaved();
        let r = Reconstruction::new(&f).unwrap();
        assert_eq!((r.face_count(), r.vertex_count()), (4, 6));
        let mut b = vec![[0.0f32; 3]; 2];
        for p in 0..2 {
            b[ORDER[p] as usize] = EMISSION[p];
        }
        let mut v = vec![[0.0; 3]; r.vertex_count()];
        r.vertex_values(&b, &mut v).unwrap();
        let [e0, e1] = EMISSION.map(|e| e.map(f64::from));
        let mix = |a: f64, c: f64| [0, 1, 2].map(|i| a * e0[i] + c * e1[i]);
        // (2, 0) is a corner of face 2 only (element 0); (0, 1) of face 1 only (element 1).
        assert_eq!(r.corner_value(&v, 2, 1), EMISSION[0]);
        assert_eq!(r.corner_value(&v, 1, 2), EMISSION[1]);
        // Face centroids: two shared corners (the mean of both elements) and one of its own.
        for (x, y, want) in [
            (5.0 / 3.0, 1.0 / 3.0, mix(2.0 / 3.0, 1.0 / 3.0)),
            (1.0 / 3.0, 2.0 / 3.0, mix(1.0 / 3.0, 2.0 / 3.0)),
        ] {
            let face = face_at(x as f32, y as f32);
            let got = r.at(&v, face, [x as f32, y as f32, 0.0]);
            for c in 0..3 {
                assert!(
                    (f64::from(got[c]) - want[c]).abs() < 1e-6,
                    "{got:?} {want:?}"
                );
            }
        }
        // Continuous across the diagonal faces 2 and 3 share.
        for t in [0.1f32, 0.5, 0.9] {
            let p = [1.0 + t, t, 0.0];
            let (a, c) = (r.at(&v, 2, p), r.at(&v, 3, p));
            assert!((0..3).all(|i| (a[i] - c[i]).abs() < 1e-6), "{a:?} {c:?}");
        }
        // SMOOTH of the elements' corners (n * 4) does not fit the faces.
        let mut bad = f.clone();
        let s = bad.display.smooth.as_mut().unwrap();
        s.corners.truncate(8);
        let e = Reconstruction::new(&bad).unwrap_err().to_string();
        assert!(e.contains("do not match the display faces"), "{e}");
    }

    #[test]
    fn files_without_smooth_or_with_a_damaged_one_are_errors() {
        let (g, s) = grid(2, 2, false);
        let mut f = file(g, s);
        f.display.smooth = None;
        let e = Reconstruction::new(&f).unwrap_err().to_string();
        assert!(e.contains("SMOOTH") && e.contains("re-bake"), "{e}");
        let (g, mut s) = grid(2, 2, false);
        s.corners[5] = 99;
        let f = file(g, s);
        let e = Reconstruction::new(&f).unwrap_err().to_string();
        assert!(e.contains("corner 1 of face 1"), "{e}");
        let (g, s) = grid(2, 2, false);
        let f = file(g, s);
        let r = Reconstruction::new(&f).unwrap();
        let mut v = vec![[0.0; 3]; r.vertex_count()];
        assert!(r.vertex_values(&[[1.0; 3]; 3], &mut v).is_err());
    }
}
