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
pub mod smooth;
pub(crate) mod subdivide;

use std::time::Instant;

use crate::error::{Error, Result};
use crate::scene::Scene;

pub use element::{
    DEFAULT_ELEMENT_FRACTION, DEFAULT_PATCH_FRACTION, Element, MAX_ELEMENTS, MeshSizes,
};
pub use region::PlanCounts;
pub(crate) use region::occluder_faces;
pub use subdivide::{MeshReport, estimate_elements};

/// The fine mesh (independent of the patch method), refused when it would be too large, and
/// what meshing found.
pub(crate) fn fine_mesh(
    scene: &Scene,
    sizes: MeshSizes,
) -> Result<(Vec<Element>, Vec<subdivide::Piece>, MeshReport)> {
    let t = Instant::now();
    let h = sizes.element_size;
    let (roots, regions) = region::plan(scene, h, &|p| subdivide::leaf_count(*p, h) as f64);
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
        let (roots, _) = region::plan(scene, h, &|p| subdivide::leaf_count(*p, h) as f64);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Polygon;
    use crate::scene::{Face, Material};
    use glam::DVec3;

    /// A scene of one triangle (base `b` along x, apex above its middle, area 1) in a room-less
    /// void: what a new user tries first.
    fn needle(b: f64) -> Scene {
        let mut s = Scene::default();
        s.name = "needle".into();
        s.materials.push(Material {
            name: "m".into(),
            reflectance: [0.5; 3],
            emission: [0.0; 3],
            optics: Default::default(),
            texture: None,
        });
        s.surfaces.push("needle".into());
        let v = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(b, 0.0, 0.0),
            DVec3::new(0.5 * b, 2.0 / b, 0.0),
        ];
        s.faces.push(Face {
            polygon: Polygon::new(&v).unwrap(),
            material: 0,
            surface: 0,
            uv: [None, None],
        });
        s
    }

    /// Needles of area 1, aspect (base / height) 1 to 10⁶ at h = 0.1: `A / h² ≤ n ≤
    /// 2 (A / h² + P / h)` (full cells plus the cells the perimeter `P` crosses), the estimate
    /// at least n, the area kept, every element within the element size, and the smallest
    /// angle reported.
    #[test]
    fn needle_triangles_mesh_in_proportion_to_area() {
        let h = 0.1;
        for aspect in [1.0, 10.0, 100.0, 1e3, 1e4, 1e5, 1e6] {
            let b = (2.0f64 * aspect).sqrt();
            let scene = needle(b);
            let sizes = MeshSizes {
                element_size: h,
                patch_size: 0.5,
            };
            let (elements, _, report) = fine_mesh(&scene, sizes).unwrap();
            let n = elements.len() as f64;
            let p = scene.faces[0].polygon;
            let v = p.vertices();
            let perimeter: f64 = (0..3).map(|i| (v[(i + 1) % 3] - v[i]).length()).sum();
            let expected = 1.0 / (h * h) + perimeter / h;
            let area: f64 = elements.iter().map(|e| e.polygon.area()).sum();
            let angle = elements
                .iter()
                .map(|e| region::min_angle(&e.polygon))
                .fold(180.0, f64::min);
            println!(
                "aspect {aspect:e}: n = {n}, A/h² + P/h = {expected:.0}, ratio {:.2}, \
                 estimate {:.0}, smallest angle {angle:.2}°",
                n / expected,
                estimate_elements(&scene, h)
            );
            assert!(
                n <= 2.0 * expected && n >= 1.0 / (h * h),
                "aspect {aspect}: n = {n}"
            );
            assert!(estimate_elements(&scene, h) >= n, "aspect {aspect}");
            assert!((area - 1.0).abs() < 1e-9, "aspect {aspect}: area {area}");
            assert_eq!(report.min_angle, angle);
            assert!(angle > 0.0 && angle <= 60.0);
            // inside a cell of sides at most h: edges at most its diagonal
            assert!(
                elements
                    .iter()
                    .all(|e| e.polygon.max_edge() <= h * 2f64.sqrt() * (1.0 + 1e-9))
            );
        }
    }

    #[test]
    fn a_refusal_names_the_surface_its_area_and_a_size_that_fits() {
        let scene = needle(2000.0);
        let sizes = MeshSizes {
            element_size: 1e-4,
            patch_size: 0.5,
        };
        let e = fine_mesh(&scene, sizes).unwrap_err().to_string();
        assert!(e.contains("'needle'") && e.contains("area 1.0000"), "{e}");
        let fits: f64 = e
            .rsplit("--element-size ")
            .next()
            .and_then(|s| s.split_whitespace().next())
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            estimate_elements(&scene, fits) <= MAX_ELEMENTS as f64,
            "{e}"
        );
        assert!(
            estimate_elements(&scene, 0.9 * fits) > MAX_ELEMENTS as f64,
            "{e}"
        );
    }
}
