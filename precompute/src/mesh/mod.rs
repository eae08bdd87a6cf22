//! The fine mesh (DESIGN.md §2–3): the elements every output reports a radiosity for.
//!
//! Coplanar faces of one surface are first grouped into planar regions (`region`): a group of
//! quads, a lone face and a group whose union is one convex quad stay faces; other groups with
//! triangles are meshed afresh as a grid clipped to the region, so the count follows the area
//! (docs/MESHING.md). Faces are then split where others stand on or pass through them
//! (`imprint`), and every face piece is the root of a subdivision hierarchy (quads split 2×2,
//! or 1×2 when one side is twice the other; triangles into 4 by edge midpoints; `subdivide`).
//! The fine mesh is the set of nodes whose size (longest edge; a triangle's second-longest)
//! first drops to the element size; each grid element is a piece of its own. The coarse mesh is
//! cut from the same hierarchy later ([`crate::patches`]), so the fine mesh is the same whatever
//! the patch method.
//!
//! Elements are numbered in generation order (depth-first, region by region in order of their
//! first face): that is the *original element id* every output reports.

mod element;
mod imprint;
mod region;
pub(crate) mod subdivide;

use std::time::Instant;

use crate::error::{Error, Result};
use crate::scene::Scene;

pub use element::{
    DEFAULT_ELEMENT_FRACTION, DEFAULT_PATCH_FRACTION, Element, MAX_ELEMENTS, MeshSizes,
};
pub use region::PlanCounts;
pub use subdivide::{MeshReport, estimate_elements};

/// The fine mesh (independent of the patch method), refused when it would be too large, and
/// what meshing found.
pub(crate) fn fine_mesh(
    scene: &Scene,
    sizes: MeshSizes,
) -> Result<(Vec<Element>, Vec<subdivide::Piece>, MeshReport)> {
    let t = Instant::now();
    let (roots, regions) = region::plan(scene, sizes.element_size);
    let mut report = MeshReport {
        regions,
        ..MeshReport::default()
    };
    report.stages.push(("regions", t.elapsed().as_secs_f64()));
    let limit = MAX_ELEMENTS as f64;
    let per_surface = subdivide::per_surface_estimate(scene, &roots, sizes.element_size, limit);
    let estimate: f64 = per_surface.iter().sum();
    if estimate > limit {
        return Err(refusal(scene, sizes.element_size, &per_surface));
    }
    let (elements, pieces) = subdivide::fine(scene, roots, sizes.element_size, &mut report);
    Ok((elements, pieces, report))
}

/// The refusal of a mesh over the element limit: the surface with the most elements, its area,
/// and the smallest element size (found by bisection on the estimate) that fits.
fn refusal(scene: &Scene, element_size: f64, per_surface: &[f64]) -> Error {
    let limit = MAX_ELEMENTS as f64;
    let (worst, count) =
        per_surface.iter().enumerate().fold(
            (0, 0.0),
            |best, (s, &e)| if e > best.1 { (s, e) } else { best },
        );
    let area: f64 = scene
        .faces
        .iter()
        .filter(|f| f.surface == worst)
        .map(|f| f.polygon.area())
        .sum();
    let fits = |h: f64| {
        let (roots, _) = region::plan(scene, h);
        subdivide::per_surface_estimate(scene, &roots, h, limit)
            .iter()
            .sum::<f64>()
            <= limit
    };
    let (mut lo, mut hi) = (element_size, element_size * 2.0);
    while !fits(hi) && hi < scene.extent() * 1e3 {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..20 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) { hi = mid } else { lo = mid }
    }
    let name = scene.surfaces.get(worst).map_or("?", |s| s.as_str());
    Error::Limits(format!(
        "the element size {element_size:.4} would create more than {limit:.0} elements (the limit); \
         surface '{name}' (area {area:.4}) accounts for at least {count:.0} of them; \
         use --element-size {hi:.4} or larger",
    ))
}
