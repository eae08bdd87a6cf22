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

mod dense;
mod element;
mod imprint;
mod region;
pub mod smooth;
pub(crate) mod subdivide;

use std::time::Instant;

use crate::error::{Error, Result};
use crate::scene::Scene;

pub(crate) use dense::{shown_faces, split_group};
pub(crate) use element::within;
pub use element::{
    DEFAULT_ELEMENT_FRACTION, DEFAULT_PATCH_FRACTION, Element, MAX_ELEMENTS, MeshSizes,
};
pub(crate) use imprint::ContactIndex;
pub use region::PlanCounts;
pub(crate) use region::occluder_faces;
pub use subdivide::Grouped;
pub use subdivide::{MeshReport, estimate_elements};

/// Bytes meshing holds per input face while its pieces are cut: its root (a polygon and an
/// index, 160) and the contact index's box, place and grid entries (up to 8: about 90; while
/// the grid is built, its (cell, box) pairs, up to 8 × 32 = 256), and the contact lines the
/// index keeps for the smooth weights (at most [`imprint::KEPT_BYTES_PER_FACE`], 256). A
/// face's own lines, before the index takes them, are held for a chunk of faces at a time
/// (`subdivide::fine`), as its search's contacts were. The planar groups (about 100 a face)
/// are gone by then. The pieces cut from it count apart ([`MESH_BYTES_PER_PIECE`]).
pub(crate) const MESH_BYTES_PER_FACE: u128 = 800;

/// Bytes meshing holds per estimated piece (the subdivision's leaves, before small pieces are
/// grouped): the piece (a polygon and indices, 160) and its element (176; a grouped piece is
/// a part of its element instead, 144), the grouping's unit and index (about 80), 2MSC's copy
/// of the elements with their parts (176), and the 2MF patches it probes with (about 300 an
/// element where each element is its own patch). About 900.
/// Measured with `--report`: the mesh stage's rise of the peak (2MSC's probes included)
/// divided by the estimated pieces: zdm2's 110 000 pieces (57 644 faces) 100–112 MB, 1.0
/// KiB; `lrr scene dense-sphere --subdivisions 5` and `6` (20 964 and 82 404 pieces, as many
/// faces) 25 and 88 MB, 1.2 and 1.1 KiB, where these constants plan 1.5 KiB (a face and a
/// piece, probes left out); CornellBox-Water (9 144 pieces, 7 088 faces) 33–35 MB, most of it
/// 2MSC's views of its probes ([`crate::patches::probe_bytes`], planned beside these).
pub(crate) const MESH_BYTES_PER_PIECE: u128 = 1024;

/// [`fine_mesh_within`] without a memory limit.
#[cfg(test)]
pub(crate) fn fine_mesh(
    scene: &Scene,
    sizes: MeshSizes,
) -> Result<(Vec<Element>, Vec<subdivide::Piece>, MeshReport)> {
    fine_mesh_within(scene, sizes, None).map(|(e, p, r, _)| (e, p, r))
}

/// The fine mesh (independent of the patch method), refused when it would be too large, and
/// what meshing found. Its buffers are planned before they exist: refused over `max_memory`
/// (or 80% of what is available) with advice; `MeshReport::planned_bytes` says what was
/// planned. Also the faces' contact index, with the contacts meshing searched, for the smooth
/// weights to search no face again.
pub(crate) fn fine_mesh_within(
    scene: &Scene,
    sizes: MeshSizes,
    max_memory: Option<u64>,
) -> Result<(
    Vec<Element>,
    Vec<subdivide::Piece>,
    MeshReport,
    ContactIndex,
)> {
    let t = Instant::now();
    let h = sizes.element_size;
    let faces = scene.faces.len();
    crate::memory::check_then(
        faces as u128 * MESH_BYTES_PER_FACE,
        max_memory,
        || format!("meshing's planar regions and contact searches ({faces} faces)"),
        |_| "simplify the model (fewer triangles), or raise --max-memory".to_string(),
    )?;
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
    // Under the element limit, so the product stays far from overflowing.
    let planned = mesh_bytes(faces, estimate);
    crate::memory::check_then(
        planned,
        max_memory,
        || {
            format!(
                "meshing ({faces} faces, about {estimate:.0} pieces at element size {})",
                length(h)
            )
        },
        // The size named leaves a quarter of the memory to what meshing holds it for: 2MSC's
        // probes (checked together with meshing) and the passes after.
        |usable| match larger_size_that_fits(scene, h, usable / 4 * 3) {
            Some(fits) => format!(
                "use --element-size {} or larger (fewer pieces), or raise --max-memory",
                length_up(fits)
            ),
            // Merged faces and grid cells have a floor of pieces whatever the size.
            None => "simplify the model (fewer triangles), or raise --max-memory".to_string(),
        },
    )?;
    report.planned_bytes = planned;
    let index = ContactIndex::new(&scene.faces);
    let (elements, pieces) = subdivide::fine(scene, roots, sizes.element_size, &index, &mut report);
    let t = Instant::now();
    let (elements, pieces, grouped) = dense::group(scene, elements, pieces, sizes.element_size);
    if grouped.elements > 0 {
        report.min_angle = elements
            .iter()
            .map(|e| region::min_angle(&e.polygon))
            .fold(180.0, f64::min);
    }
    report.grouped = grouped;
    report.stages.push(("group", t.elapsed().as_secs_f64()));
    Ok((elements, pieces, report, index))
}

/// Bytes meshing plans for `faces` input faces cut into about `pieces` pieces.
fn mesh_bytes(faces: usize, pieces: f64) -> u128 {
    faces as u128 * MESH_BYTES_PER_FACE + pieces.ceil() as u128 * MESH_BYTES_PER_PIECE
}

/// The smallest element size from `h` up (doubling, then bisection on the estimate) whose
/// meshing fits in `usable` bytes; `None` when none up to a thousand times the scene's extent
/// does (the planar merges and grid cells keep a floor of pieces per face).
fn larger_size_that_fits(scene: &Scene, h: f64, usable: u128) -> Option<f64> {
    let fits = |h: f64| mesh_bytes(scene.faces.len(), estimate_elements(scene, h)) <= usable;
    let cap = scene.extent() * 1e3;
    let (mut lo, mut hi) = (h, h * 2.0);
    while !fits(hi) {
        if hi >= cap {
            return None;
        }
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..12 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) { hi = mid } else { lo = mid }
    }
    Some(hi)
}

/// A length for a message: four decimals, or four significant digits where those would hide
/// it (under 0.001 or over a million scene units).
fn length(h: f64) -> String {
    if (1e-3..1e6).contains(&h.abs()) {
        format!("{h:.4}")
    } else {
        format!("{h:.4e}")
    }
}

/// [`length`] of the smallest four-significant-digit value at or above `h`: an element size to
/// advise, which must not be printed smaller than the size that fits.
fn length_up(h: f64) -> String {
    if !(h.is_finite() && h > 0.0) {
        return length(h);
    }
    let step = 10f64.powi(h.log10().floor() as i32 - 3);
    let up = (h / step).ceil() * step;
    if (1e-3..1e6).contains(&up) {
        let decimals = (-(up.log10().floor() as i32) + 3).max(0) as usize;
        format!("{up:.decimals$}")
    } else {
        format!("{up:.3e}")
    }
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
        "the element size {} would create more than {limit:.0} elements (the limit); \
         surface '{name}' (area {area:.4}) accounts for at least {count:.0} of them; \
         use --element-size {} or larger",
        length(element_size),
        length(hi),
    ))
}

/// A 5 × 5 furnace floor under 400 boxes of 0.08 × 0.08 × 0.3, 16 in each unit cell (for
/// `h = 1`), off the cell lines: a face under many contacts (`subdivide::face_cut`).
#[cfg(test)]
pub(crate) fn boxes_on_floor() -> Scene {
    boxes_on_floor_and(&[])
}

/// [`boxes_on_floor`] with more boxes (min and max corners) standing on the floor, 0.3 high.
#[cfg(test)]
pub(crate) fn boxes_on_floor_and(more: &[([f64; 2], [f64; 2])]) -> Scene {
    let mut d = crate::scene::procedural::furnace(0.5, 1.0);
    d.boxes[0].max = [5.0, 5.0, 2.0];
    for i in 0..20 {
        for j in 0..20 {
            // Off the cell lines, each a little off the others' rows (no shared lines).
            let x = 0.25 * i as f64 + 0.1 + 0.001 * j as f64;
            let y = 0.25 * j as f64 + 0.05 + 0.0007 * i as f64;
            d.boxes.push(crate::scene::description::BoxDesc {
                name: format!("box{i}.{j}"),
                material: "wall".into(),
                min: [x, y, 0.0],
                max: [x + 0.08, y + 0.08, 0.3],
                inward: false,
                omit: vec![],
            });
        }
    }
    for (k, (lo, hi)) in more.iter().enumerate() {
        d.boxes.push(crate::scene::description::BoxDesc {
            name: format!("more{k}"),
            material: "wall".into(),
            min: [lo[0], lo[1], 0.0],
            max: [hi[0], hi[1], 0.3],
            inward: false,
            omit: vec![],
        });
    }
    d.build("t", std::path::Path::new(".")).unwrap()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::Polygon;
    use crate::scene::{Face, Material};
    use glam::DVec3;

    /// Triangles of an axis-aligned box `lo`..`hi`, outward.
    pub(crate) fn cuboid(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
        let c = |i: usize| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        quads
            .iter()
            .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
            .collect()
    }

    /// A scene named `name` of one surface of that name and one grey material, made of the
    /// triangles (those with no area left out), as the tests of meshing and of the smooth
    /// weights build them.
    pub(crate) fn one_surface(name: &str, triangles: &[[DVec3; 3]]) -> Scene {
        let mut s = Scene::default();
        s.name = name.into();
        s.materials.push(Material {
            name: "m".into(),
            reflectance: [0.5; 3],
            emission: [0.0; 3],
            optics: Default::default(),
            texture: None,
        });
        s.surfaces.push(name.into());
        for t in triangles {
            if let Some(polygon) = Polygon::new(t) {
                s.faces.push(Face {
                    polygon,
                    material: 0,
                    surface: 0,
                    uv: [None, None],
                });
            }
        }
        s
    }

    /// A scene of one triangle (base `b` along x, apex above its middle, area 1) in a room-less
    /// void: what a new user tries first.
    fn needle(b: f64) -> Scene {
        let v = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(b, 0.0, 0.0),
            DVec3::new(0.5 * b, 2.0 / b, 0.0),
        ];
        one_surface("needle", &[v])
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
            // a triangle has an angle of at most 60°; grouped cells are rectangles (90°)
            assert!(angle > 0.0 && angle <= 90.0);
            // inside a cell of sides at most h: edges at most its diagonal
            assert!(
                elements
                    .iter()
                    .all(|e| e.polygon.max_edge() <= h * 2f64.sqrt() * (1.0 + 1e-9))
            );
        }
    }

    /// A 5 × 5 floor under 400 boxes of 0.08 (16 in each unit cell, at h = 1): cut at the
    /// boxes' feet, the floor's strips would each cross it and subdivide along their length;
    /// as a grid it is its cells, each cut by the boxes standing in it and grouped into two
    /// elements lit on their parts, the floor about the feet and the floor under them
    /// (`subdivide::face_cut`, `dense`). They keep the floor's area and plane.
    #[test]
    fn a_floor_under_many_boxes_meshes_by_area_and_cuts() {
        let scene = boxes_on_floor();
        let sizes = MeshSizes {
            element_size: 1.0,
            patch_size: 3.0,
        };
        let (elements, _, report) = fine_mesh(&scene, sizes).unwrap();
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let on_floor: Vec<&Element> = (elements.iter())
            .filter(|e| e.surface as usize == floor)
            .collect();
        let area: f64 = on_floor.iter().map(|e| e.polygon.area()).sum();
        assert!((area - 25.0).abs() < 1e-9, "area {area}");
        assert_eq!(report.sliver_faces, 1);
        // Each unit cell cut by its 16 feet is two elements lit on their parts: the floor
        // about the feet and the floor under them. A part is under a foot when its centroid
        // is inside one (the parts do not cross the feet's outlines).
        let under = |p: &Polygon| {
            let c = p.centroid();
            let (i, j) = ((c.x - 0.1) / 0.25, (c.y - 0.05) / 0.25);
            let (i, j) = (i.floor(), j.floor());
            if !(0.0..20.0).contains(&i) || !(0.0..20.0).contains(&j) {
                return false;
            }
            let x = 0.25 * i + 0.1 + 0.001 * j;
            let y = 0.25 * j + 0.05 + 0.0007 * i;
            (x..x + 0.08).contains(&c.x) && (y..y + 0.08).contains(&c.y)
        };
        let mut covered = 0.0;
        for e in &on_floor {
            assert!(e.on_parts && e.parts.len() >= 2, "{e:?}");
            let below = under(&e.parts[0].1);
            for (_, p) in &e.parts {
                assert_eq!(under(p), below, "a part {p:?} on the wrong side");
                let n = e.polygon.normal;
                assert!(p.normal.dot(n) > 1.0 - 1e-12, "{p:?}");
                assert!(e.polygon.height(p.centroid()).abs() < 1e-12, "{p:?}");
            }
            let parts: f64 = e.parts.iter().map(|(_, p)| p.area()).sum();
            assert!((parts - e.polygon.area()).abs() < 1e-12 * parts.max(1.0));
            if below {
                covered += parts;
            }
        }
        assert!((covered - 400.0 * 0.08 * 0.08).abs() < 1e-9, "{covered}");
        // 25 cells, each one element about the feet and one under them.
        assert_eq!(on_floor.len(), 50);
    }

    /// The floor of [`boxes_on_floor`] with a thin wall across it (y 2.45 to 2.47, x 0.3 to
    /// 4.7: across the three cells between x = 1 and 4, into two more), a box flush against
    /// the room's wall (x 0 to 0.06) and two boxes side by side (touching at x = 0.05). In
    /// the cells the wall crosses, no element holds floor from both of its sides (its light
    /// would leak under the wall; in the cells of its ends the floor meets round them), and
    /// the floor under every box, the flush and touching ones included, is in elements of
    /// floor under boxes only.
    #[test]
    fn grouped_floor_keeps_to_one_side_of_what_stands_on_it() {
        let feet = [
            ([0.3, 2.45], [4.7, 2.47]),
            ([0.0, 3.1], [0.06, 3.16]),
            ([0.01, 1.1], [0.05, 1.14]),
            ([0.05, 1.1], [0.09, 1.14]),
        ];
        let scene = boxes_on_floor_and(&feet);
        let sizes = MeshSizes {
            element_size: 1.0,
            patch_size: 3.0,
        };
        let (elements, _, report) = fine_mesh(&scene, sizes).unwrap();
        assert_eq!(report.sliver_faces, 1);
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let mut rects: Vec<([f64; 2], [f64; 2])> = feet.to_vec();
        for i in 0..20 {
            for j in 0..20 {
                let x = 0.25 * i as f64 + 0.1 + 0.001 * j as f64;
                let y = 0.25 * j as f64 + 0.05 + 0.0007 * i as f64;
                rects.push(([x, y], [x + 0.08, y + 0.08]));
            }
        }
        let under = |p: &Polygon| {
            let c = p.centroid();
            (rects.iter())
                .any(|(lo, hi)| (lo[0]..hi[0]).contains(&c.x) && (lo[1]..hi[1]).contains(&c.y))
        };
        let (mut covered, mut grouped) = (0.0, 0);
        for e in elements.iter().filter(|e| e.surface as usize == floor) {
            let parts: Vec<&Polygon> = if e.on_parts {
                e.parts.iter().map(|(_, p)| p).collect()
            } else {
                vec![&e.polygon]
            };
            grouped += usize::from(e.on_parts);
            let below = under(parts[0]);
            assert!(parts.iter().all(|p| under(p) == below), "{e:?}");
            if below {
                covered += parts.iter().map(|p| p.area()).sum::<f64>();
                continue;
            }
            let crossed = parts.iter().all(|p| (1.0..4.0).contains(&p.centroid().x));
            let south = parts.iter().any(|p| p.centroid().y < 2.45);
            let north = parts.iter().any(|p| p.centroid().y > 2.47);
            assert!(
                !(crossed && south && north),
                "floor from both sides of the wall: {e:?}"
            );
        }
        let feet_area: f64 = rects
            .iter()
            .map(|(lo, hi)| (hi[0] - lo[0]) * (hi[1] - lo[1]))
            .sum();
        assert!(
            (covered - feet_area).abs() < 1e-9,
            "{covered} of {feet_area}"
        );
        assert!(grouped >= 50, "{grouped} elements lit on their parts");
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

    /// Hostile geometry, generated (a fixed seed, 48 scenes): needles, slivers, fans of up to
    /// 1 000 triangles round a vertex, coincident and duplicated faces, zero-area faces, and
    /// whole scenes scaled by 1e-6 to 1e6, with an emitter. Each one is imported (repairs
    /// counted), meshed at its default sizes and given patches by 2MF and by 2MSC's merge
    /// rule, or refused with an error: no panic, every mesh valid, every smooth weight set
    /// summing to one as the file's check wants.
    #[test]
    fn hostile_geometry_meshes_or_is_refused() {
        use crate::patches::{CoherenceRule, Mesh, PatchMethod};
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for case in 0..48 {
            let scale = 10f64.powi((case % 13) - 6);
            let mut scene = Scene::new("hostile");
            let grey = Material {
                name: "grey".into(),
                reflectance: [0.7; 3],
                emission: [0.0; 3],
                optics: Default::default(),
                texture: None,
            };
            let lamp = Material {
                name: "lamp".into(),
                reflectance: [0.0; 3],
                emission: [5.0; 3],
                ..grey.clone()
            };
            let g = scene.add_material(grey, "t").unwrap();
            let l = scene.add_material(lamp, "t").unwrap();
            let (sg, sl) = (scene.surface("things"), scene.surface("lamp"));
            let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z) * scale;
            // a floor and a lamp above it, facing each other
            scene
                .add_polygon(
                    &[p(0., 0., 0.), p(1., 0., 0.), p(1., 1., 0.), p(0., 1., 0.)],
                    g,
                    sg,
                    "t",
                )
                .unwrap();
            scene
                .add_polygon(
                    &[
                        p(0.4, 0.4, 1.),
                        p(0.4, 0.6, 1.),
                        p(0.6, 0.6, 1.),
                        p(0.6, 0.4, 1.),
                    ],
                    l,
                    sl,
                    "t",
                )
                .unwrap();
            let kinds = 1 + (next() * 6.0) as usize;
            for _ in 0..kinds {
                let c = [next(), next(), 0.05 + 0.9 * next()];
                match (next() * 5.0) as usize {
                    0 => {
                        // a needle of aspect up to 1e6
                        let len = 0.01 + next();
                        let thin = len * 10f64.powf(-1.0 - 5.0 * next());
                        scene
                            .add_polygon(
                                &[
                                    p(c[0], c[1], c[2]),
                                    p(c[0] + len, c[1], c[2]),
                                    p(c[0] + 0.5 * len, c[1] + thin, c[2] + thin),
                                ],
                                g,
                                sg,
                                "t",
                            )
                            .unwrap();
                    }
                    1 => {
                        // a fan round a vertex, slightly non-planar
                        let m = 3 + (next() * 1000.0) as usize;
                        let r = 0.05 + 0.2 * next();
                        for i in 0..m {
                            let a = std::f64::consts::TAU * i as f64 / m as f64;
                            let b = std::f64::consts::TAU * (i + 1) as f64 / m as f64;
                            let h = |i: usize| if i.is_multiple_of(2) { 0.0 } else { 1e-4 * r };
                            scene
                                .add_polygon(
                                    &[
                                        p(c[0], c[1], c[2] + 0.2 * r),
                                        p(c[0] + r * a.cos(), c[1] + r * a.sin(), c[2] + h(i)),
                                        p(c[0] + r * b.cos(), c[1] + r * b.sin(), c[2] + h(i + 1)),
                                    ],
                                    g,
                                    sg,
                                    "t",
                                )
                                .unwrap();
                        }
                    }
                    2 => {
                        // the same quad three times, and once reversed
                        let q = [
                            p(c[0], c[1], c[2]),
                            p(c[0] + 0.1, c[1], c[2]),
                            p(c[0] + 0.1, c[1] + 0.1, c[2]),
                            p(c[0], c[1] + 0.1, c[2]),
                        ];
                        for _ in 0..3 {
                            scene.add_polygon(&q, g, sg, "t").unwrap();
                        }
                        let r: Vec<DVec3> = q.iter().rev().copied().collect();
                        scene.add_polygon(&r, g, sg, "t").unwrap();
                    }
                    3 => {
                        // zero-area and nearly coincident vertices
                        scene
                            .add_polygon(
                                &[
                                    p(c[0], c[1], c[2]),
                                    p(c[0], c[1], c[2]),
                                    p(c[0] + 0.1, c[1], c[2]),
                                ],
                                g,
                                sg,
                                "t",
                            )
                            .unwrap();
                        let e = 1e-12;
                        scene
                            .add_polygon(
                                &[
                                    p(c[0], c[1], c[2]),
                                    p(c[0] + e, c[1], c[2]),
                                    p(c[0], c[1] + 0.2, c[2] + 0.1),
                                ],
                                g,
                                sg,
                                "t",
                            )
                            .unwrap();
                    }
                    _ => {
                        // a dense patch of random small triangles
                        for _ in 0..200 {
                            let d = [next(), next(), next()].map(|x| 0.02 * x);
                            let o = [c[0] + 0.2 * next(), c[1] + 0.2 * next(), c[2]];
                            scene
                                .add_polygon(
                                    &[
                                        p(o[0], o[1], o[2]),
                                        p(o[0] + d[0], o[1], o[2] + d[2]),
                                        p(o[0], o[1] + d[1], o[2]),
                                    ],
                                    g,
                                    sg,
                                    "t",
                                )
                                .unwrap();
                        }
                    }
                }
            }
            let sizes = MeshSizes::resolve(&scene, None, None).unwrap();
            for method in [
                PatchMethod::TwoFixed,
                PatchMethod::SpatialCoherence {
                    threshold: 7e-5,
                    min_patch_area: None,
                    rule: CoherenceRule::Merge,
                },
            ] {
                let mesh = match Mesh::build(&scene, sizes, method, None) {
                    Ok(m) => m,
                    Err(e) => {
                        let text = e.to_string();
                        assert!(!text.contains('\n'), "case {case}: {text}");
                        continue;
                    }
                };
                mesh.validate()
                    .unwrap_or_else(|e| panic!("case {case}: {e}"));
                let refs: Vec<&Element> = (0..mesh.n()).map(|i| mesh.element_at(i)).collect();
                let w = smooth::weights(&scene, &refs, None);
                for v in 0..w.vertex_count() {
                    let r = w.offsets[v] as usize..w.offsets[v + 1] as usize;
                    let sum: f64 = w.weights[r.clone()].iter().map(|&x| f64::from(x)).sum();
                    assert!(
                        (sum - 1.0).abs() < 1e-5,
                        "case {case} (scale {scale:e}): vertex {v} sums to {sum}"
                    );
                    assert!(
                        w.weights[r].iter().all(|&x| x != 0.0 && x.abs() <= 8.0),
                        "case {case}"
                    );
                }
            }
        }
    }
}
