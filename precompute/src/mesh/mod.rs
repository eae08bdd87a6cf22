//! The fine mesh (DESIGN.md §2–3): the elements every output reports a radiosity for.
//!
//! Every input face is the root of a subdivision hierarchy (quads split 2×2, or 1×2 when one
//! side is twice the other; triangles into 4 by edge midpoints; `subdivide`), after faces are
//! split where others stand on them (`imprint`). The fine mesh is the set of nodes whose size
//! (longest edge; a triangle's second-longest) first drops to the element size. The coarse mesh
//! is cut from the same hierarchy later ([`crate::patches`]), so the fine mesh is the same
//! whatever the patch method.
//!
//! Elements are numbered in generation order (depth-first, face by face): that is the
//! *original element id* every output reports.

mod element;
mod imprint;
pub(crate) mod subdivide;

use crate::error::{Error, Result};
use crate::scene::Scene;

pub use element::{
    DEFAULT_ELEMENT_FRACTION, DEFAULT_PATCH_FRACTION, Element, MAX_ELEMENTS, MeshSizes,
};
pub use subdivide::estimate_elements;

/// The fine mesh (independent of the patch method), refused when it would be too large.
pub(crate) fn fine_mesh(
    scene: &Scene,
    sizes: MeshSizes,
) -> Result<(Vec<Element>, Vec<subdivide::Piece>)> {
    let estimate = estimate_elements(scene, sizes.element_size);
    if estimate > MAX_ELEMENTS as f64 {
        return Err(Error::Limits(format!(
            "the element size {:.4} would create about {estimate:.0} elements (limit {MAX_ELEMENTS}); \
             use a larger --element-size",
            sizes.element_size
        )));
    }
    Ok(subdivide::fine(scene, sizes.element_size))
}
