//! What the fine mesh is made of: elements, and the element and patch sizes meshing works to.

use crate::error::{Error, Result};
pub(crate) use crate::geometry::within;
use crate::geometry::{Polygon, Region};
use crate::scene::Scene;

/// A fine-mesh element.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    /// The element's planar convex polygon.
    pub polygon: Polygon,
    /// Index of the scene face it came from.
    pub face: u32,
    /// Index of its surface in `Scene::surfaces`.
    pub surface: u32,
    /// Index of the patch (in `Mesh::patches`) that holds it.
    pub patch: u32,
    /// The pieces of small input faces an element of a dense mesh groups (`mesh::dense`), each
    /// with its input face, in piece order: `polygon` is then their planar proxy, and they are
    /// what is drawn. Empty for an element that is its own polygon.
    pub parts: Vec<(u32, Polygon)>,
    /// Its light is computed on `parts`, not on `polygon`: the pieces of one cell of a face
    /// under many contacts, all in the face's plane (`mesh::dense`). Its form-factor points
    /// and the patches it joins lie on the parts; `polygon` gives its plane, area and hints.
    /// False for every other element (a dense mesh's proxy stands in for its faces).
    pub on_parts: bool,
}

impl Element {
    /// What is drawn of the element: `(input face, polygon)` of each of its parts, or the
    /// element's own polygon.
    pub fn shown(&self) -> impl Iterator<Item = (u32, &Polygon)> + '_ {
        let own = self.parts.is_empty().then_some((self.face, &self.polygon));
        own.into_iter()
            .chain(self.parts.iter().map(|(f, p)| (*f, p)))
    }

    /// A polygon on the element's surface: its largest part when it is lit on its parts
    /// (its proxy may stand partly under what stands on the face), else its polygon. What the
    /// enclosure probe casts its rays from.
    pub fn on_surface(&self) -> Polygon {
        if !self.on_parts {
            return self.polygon;
        }
        let largest = self
            .parts
            .iter()
            .map(|(_, p)| p)
            .reduce(|a, b| if b.area() > a.area() { b } else { a });
        largest.copied().unwrap_or(self.polygon)
    }

    /// The polygons the element is lit on: its parts when it is lit on them
    /// ([`on_parts`](Self::on_parts)), else its own polygon.
    pub fn lit(&self) -> impl Iterator<Item = &Polygon> + '_ {
        let own = (!self.on_parts).then_some(&self.polygon);
        let parts = self.parts.iter().filter(|_| self.on_parts);
        own.into_iter().chain(parts.map(|(_, p)| p))
    }

    /// The element as a form-factor target: the region of [`lit`](Self::lit).
    pub fn lit_region(&self) -> Region {
        Region::new(self.lit().copied().collect())
    }
}

/// Mesh sizes, absolute lengths in scene units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshSizes {
    /// Target element size: faces are subdivided until their size (longest edge; a triangle's second longest) drops to it, in scene units.
    pub element_size: f64,
    /// Patch size of the 2MF cut and of cluster patches, in scene units.
    pub patch_size: f64,
}

/// Default sizes as fractions of the scene's bounding-box diagonal, so a scaled scene meshes
/// identically. For the Cornell box (diagonal ≈ 961 mm) they give n = 1 920 elements, k = 128.
pub const DEFAULT_ELEMENT_FRACTION: f64 = 1.0 / 20.0;
/// Default patch size as a fraction of the scene's bounding-box diagonal (see above).
pub const DEFAULT_PATCH_FRACTION: f64 = 1.0 / 6.0;

/// Most elements a bake may create before meshing is refused.
pub const MAX_ELEMENTS: usize = 20_000_000;

impl MeshSizes {
    /// Explicit sizes win over the scene's hints, which win over the relative defaults.
    pub fn resolve(
        scene: &Scene,
        element_size: Option<f64>,
        patch_size: Option<f64>,
    ) -> Result<Self> {
        let extent = scene.extent();
        let element_size = element_size
            .or(scene.hints.element_size)
            .unwrap_or(extent * DEFAULT_ELEMENT_FRACTION);
        let patch_size = patch_size
            .or(scene.hints.patch_size)
            .unwrap_or(extent * DEFAULT_PATCH_FRACTION);
        for (name, v) in [("element size", element_size), ("patch size", patch_size)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Settings(format!(
                    "the {name} must be a positive length, got {v}"
                )));
            }
        }
        Ok(Self {
            element_size,
            patch_size,
        })
    }
}

/// Elements of the 2×2 (or 4-way) subdivision of a face: each halving of the size multiplies
/// the count by at most 4.
pub(crate) fn face_estimate(p: &Polygon, element_size: f64) -> f64 {
    let ratio = p.size() / element_size;
    if within(p.size(), element_size) {
        1.0
    } else {
        4f64.powf(ratio.log2().ceil())
    }
}
