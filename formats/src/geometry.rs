//! Polygons as the file stores them ([`Geometry`]: GEOMETRY's one polygon per element, and the
//! display faces of section FACES, format 1.4) and the display faces every reader draws
//! ([`FacesRef`], from [`OperatorFile::faces`](crate::OperatorFile::faces)). Plain data; imports
//! nothing of the crate.

/// Planar polygons of at most 4 vertices: GEOMETRY's one polygon per element in file order (the
/// polygon its form factors were computed on), or the display faces of section FACES.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Geometry {
    /// One entry per polygon (`n` in GEOMETRY), each 3 (triangle) or 4 (quad).
    pub vertex_count: Vec<u8>,
    /// `4 * 3` per polygon: x, y, z of up to 4 vertices; the unused 4th vertex of a triangle is
    /// zeros.
    pub vertices: Vec<f32>,
    /// `3` per polygon, unit length (within 1e-3).
    pub normals: Vec<f32>,
}

impl Geometry {
    /// Number of polygons.
    pub fn len(&self) -> usize {
        self.vertex_count.len()
    }

    /// Whether there are no polygons.
    pub fn is_empty(&self) -> bool {
        self.vertex_count.is_empty()
    }

    /// Number of fan triangles: `sum(vertex_count[p] - 2)` (see `display.rs`).
    pub fn triangle_count(&self) -> usize {
        self.vertex_count
            .iter()
            .map(|&c| usize::from(c).saturating_sub(2))
            .sum()
    }

    /// The fan triangles in id order: `(polygon, [v0, v1, v2])`, the fan of each polygon
    /// (`(v_0, v_i, v_{i+1})`), polygons in order. For a file's display triangles use
    /// [`FacesRef::triangles`] (the fan of the faces, which are GEOMETRY's polygons only when
    /// the file has no section FACES).
    pub fn triangles(&self) -> impl Iterator<Item = (u32, [[f32; 3]; 3])> + '_ {
        self.vertex_count
            .iter()
            .enumerate()
            .flat_map(move |(e, &c)| {
                let corner = move |i: usize| self.vertex(e, i);
                (1..usize::from(c).saturating_sub(1))
                    .map(move |i| (e as u32, [corner(0), corner(i), corner(i + 1)]))
            })
    }

    /// Vertex `corner` (< 4) of polygon `polygon`. Panics out of range.
    pub fn vertex(&self, polygon: usize, corner: usize) -> [f32; 3] {
        let at = polygon * 12 + corner * 3;
        [
            self.vertices[at],
            self.vertices[at + 1],
            self.vertices[at + 2],
        ]
    }

    /// The unit normal of polygon `polygon`. Panics out of range.
    pub fn normal(&self, polygon: usize) -> [f32; 3] {
        let at = polygon * 3;
        [self.normals[at], self.normals[at + 1], self.normals[at + 2]]
    }
}

/// The display faces (section FACES, format 1.4): what is drawn, when an element is drawn as
/// other polygons than its GEOMETRY entry (an element of a dense mesh groups many small input
/// faces, and GEOMETRY holds the planar polygon its form factors were computed on).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Faces {
    /// Per face: the file position (< n) of the element it shows. Every file position has at
    /// least one face.
    pub element: Vec<u32>,
    /// The faces' polygons, as GEOMETRY stores elements (vertex_count 3 or 4, vertices F*12
    /// with a triangle's 4th zero, unit normals F*3).
    pub geometry: Geometry,
}

/// A file's display faces, borrowed: what every reader draws, traces, smooths and exports.
///
/// With section FACES, its faces (face `f` shows element `element(f)`); without, GEOMETRY's
/// polygons (face `f` is element `f`). SMOOTH's corners, LIGHTMAP's coordinates and the BVH's
/// triangle ids are defined on these faces (`display.rs`). Per-element quantities (area,
/// centroid, the polygon the form factors saw) stay GEOMETRY's.
#[derive(Debug, Clone, Copy)]
pub struct FacesRef<'a> {
    /// The faces' polygons: FACES' geometry, or GEOMETRY.
    pub geometry: &'a Geometry,
    element: Option<&'a [u32]>,
}

impl<'a> FacesRef<'a> {
    /// The faces `faces` (section FACES) or, when `None`, the elements of `geometry`.
    pub fn new(geometry: &'a Geometry, faces: Option<&'a Faces>) -> Self {
        match faces {
            Some(f) => FacesRef {
                geometry: &f.geometry,
                element: Some(&f.element),
            },
            None => FacesRef {
                geometry,
                element: None,
            },
        }
    }

    /// Number of faces `F` (`n` without FACES).
    pub fn len(&self) -> usize {
        self.geometry.len()
    }

    /// Whether there are no faces.
    pub fn is_empty(&self) -> bool {
        self.geometry.is_empty()
    }

    /// Whether the faces are section FACES (else GEOMETRY's elements).
    pub fn is_separate(&self) -> bool {
        self.element.is_some()
    }

    /// The file position of the element face `face` shows (`face` itself without FACES).
    /// Panics when `face` is out of range with FACES (a caller's bug).
    pub fn element(&self, face: usize) -> usize {
        match self.element {
            Some(e) => e[face] as usize,
            None => face,
        }
    }

    /// FACES' per-face file positions, `None` without FACES (the identity).
    pub fn elements(&self) -> Option<&'a [u32]> {
        self.element
    }

    /// Number of display triangles (the BVH's `T`).
    pub fn triangle_count(&self) -> usize {
        self.geometry.triangle_count()
    }

    /// The display triangles in id order: `(face, [v0, v1, v2])`, the fan of each face, faces
    /// in order (see `display.rs`); [`element`](Self::element) maps a face to its element.
    pub fn triangles(&self) -> impl Iterator<Item = (u32, [[f32; 3]; 3])> + 'a {
        self.geometry.triangles()
    }
}
