//! Elements of dense meshes: input faces smaller than the element size, grouped (issue #31).
//!
//! Subdivision makes every input face at least one element, so a finely tessellated surface
//! (a scanned statue, a sphere at subdivision 7, a game level's trim) would have as many
//! elements as triangles, and the bake's cost would follow the triangulation instead of the
//! light. Here the pieces that are one element each, of input faces no larger than the
//! element size (whole, or cut by imprinting where others touch them), and the pieces of
//! planar regions meshed as grids (a grid cell clipped to each of the region's faces) are
//! grouped per surface and material by the bisection of patch clustering (`geometry::cluster`): a group's
//! area is at most h² (h the element size), its vertex bounding box has no side longer than
//! 2h and its normals lie within [`ELEMENT_CONE_DEGREES`] of their area-weighted mean. A group of two or more faces becomes
//! one element (DESIGN.md §10):
//!
//! - its light is computed on a planar **proxy**: the rectangle of the group's area, centred
//!   on its area centroid, oriented by the principal axes of its vertices projected on the
//!   plane of the mean normal, with the sides in the ratio of their extents, and lifted along
//!   the normal to the highest vertex, so that no point of it lies behind the surface it
//!   stands for (rays leaving it are not blocked by the faces themselves);
//! - its faces are what is drawn ([`Element::parts`]; the file's FACES section), their smooth
//!   weights and lightmap coordinates those of the input vertices;
//! - its reflectance is the area-weighted mean of its faces'.
//!
//! The pieces of one cell of a face under many contacts (`PieceKind::FaceGrid`) are grouped
//! apart, per side of what stands on the face: one element of the pieces about it, one of
//! those under it. Such an element is lit on its parts (`Element::on_parts`: its form-factor
//! points, its patch's shape and its views lie on them), all in the face's plane; its proxy
//! gives only that plane, its area and the occluder's hints.
//!
//! A group of parallel faces that do not lie in one plane (faces of separate objects side by
//! side: the tops of boxes of several heights, their sides one behind another) is lit on its
//! parts too: its proxy, standing on the highest, would hide what lies between the others
//! (`visible::base`; a hall of boxes was 9–16 % too dark, docs/MESHING.md).
//!
//! The grouping is what Enlighten calls lighting a detail mesh through a simplified target:
//! n ≈ area / h² whatever the tessellation. Occlusion still uses the input faces. A lone small
//! piece keeps its own polygon, so scenes without dense parts mesh exactly as before.
//!
//! The refinement where light changes (`crate::refine`) splits a group as it splits a quad 2×2:
//! [`split_group`] shares its faces among up to four groups, each with its own proxy.

use glam::DVec3;

use super::element::{Element, within};
use super::subdivide::{Grouped, Piece, PieceKind};
use crate::geometry::Polygon;
use crate::geometry::cluster::{Unit, bisect, by_size_within};
use crate::scene::Scene;

/// Largest angle between a grouped face's normal and its group's mean normal. Narrower than
/// patch clustering's 45°: the proxy stands in for the faces' own form factors.
pub(crate) const ELEMENT_CONE_DEGREES: f64 = 30.0;

/// A group's vertex bounding box may have sides up to this multiple of the element size, and
/// its area be up to the element size squared: the faces of a tessellation near the element
/// size pair up as the faces of a much finer one gather, so that both give about area / h²
/// elements. On a unit icosphere at h = 0.35: 142, 128 and 128 elements at 320, 5 120 and
/// 81 920 triangles; a bound of h on the sides alone left the coarse sphere's faces single
/// and gathered the fine one's into groups twice their area (320, 358, 276 at h = 0.3);
/// √2·h gave 194, 128, 128.
const SIDE_FACTOR: f64 = 2.0;

/// The fine mesh with the small whole faces of each surface and material grouped into
/// elements of about `element_size` (module docs). Element ids stay in generation order: a
/// group takes the place of its first face.
pub(crate) fn group(
    scene: &Scene,
    elements: Vec<Element>,
    pieces: Vec<Piece>,
    element_size: f64,
) -> (Vec<Element>, Vec<Piece>, Grouped) {
    // Candidates: a piece that is one element, of an input face no larger than an element
    // (whole or cut by imprinting, not a sliver cut from a large face), or a piece of a
    // planar region meshed as a grid (a cell clipped to one of its faces).
    let whole = |p: &Piece| {
        p.count == 1
            && match p.kind {
                PieceKind::RegionGrid => true,
                PieceKind::FaceGrid { .. } => false, // grouped by cell below
                PieceKind::Subdivided => {
                    within(scene.faces[p.face as usize].polygon.size(), element_size)
                }
            }
    };
    let mut sets: std::collections::BTreeMap<(u32, usize), Vec<usize>> = Default::default();
    for (i, p) in pieces.iter().enumerate() {
        if whole(p) {
            let material = scene.faces[p.face as usize].material;
            sets.entry((p.surface, material)).or_default().push(i);
        }
    }
    let units: Vec<Unit> = pieces.iter().map(|p| Unit::of(&p.polygon)).collect();
    // Per piece: the group it leads (its members, its polygon, whether it is lit on its
    // parts), or that it is a later member.
    let mut lead: Vec<Option<(Vec<usize>, Polygon, bool)>> = vec![None; pieces.len()];
    let mut member = vec![false; pieces.len()];
    let mut grouped = Grouped::default();
    // Group `g` (two or more pieces) becomes one element, its proxy's sides at most
    // `max_side`, lit on its parts or not; a group whose proxy is degenerate stays apart.
    let mut take = |g: Vec<usize>, max_side: f64, on_parts: bool| {
        let polygons: Vec<&Polygon> = g.iter().map(|&i| &pieces[i].polygon).collect();
        let Some(polygon) = proxy(&polygons, max_side) else {
            return;
        };
        grouped.faces += g.len();
        grouped.elements += 1;
        for &i in &g {
            member[i] = true;
        }
        let first = g[0];
        lead[first] = Some((g, polygon, on_parts));
    };
    for set in sets.into_values().filter(|s| s.len() >= 2) {
        let (size, area) = (SIDE_FACTOR * element_size, element_size * element_size);
        for g in by_size_within(&units, set, size, area, ELEMENT_CONE_DEGREES) {
            if g.len() >= 2 {
                let polygons: Vec<&Polygon> = g.iter().map(|&i| &pieces[i].polygon).collect();
                let stacked = stacked(&polygons, element_size);
                take(g, element_size, stacked);
            }
        }
    }
    // The pieces of one cell of a face under many contacts, on either side of what stands on
    // it, that meet freely (`PieceKind::FaceGrid`): one element a group, lit on its parts,
    // which lie in the face's plane. Its proxy gives that plane, its area and its hints; a
    // proxy lit in their place stood under the boxes and darkened the floor by 4 %, the
    // ceiling by 11 % (docs/MESHING.md).
    let mut cells: std::collections::BTreeMap<(u32, u32), Vec<usize>> = Default::default();
    for (i, p) in pieces.iter().enumerate() {
        if let PieceKind::FaceGrid { group, .. } = p.kind {
            cells.entry((p.face, group)).or_default().push(i);
        }
    }
    for g in cells.into_values().filter(|g| g.len() >= 2) {
        take(g, f64::INFINITY, true);
    }
    if grouped.elements == 0 {
        return (elements, pieces, grouped);
    }
    let mut out_elements = Vec::with_capacity(elements.len());
    let mut out_pieces = Vec::with_capacity(pieces.len());
    for (i, piece) in pieces.iter().enumerate() {
        let first = out_elements.len() as u32;
        if let Some((g, polygon, on_parts)) = &lead[i] {
            let polygon = *polygon;
            let parts: Vec<(u32, Polygon)> = g
                .iter()
                .map(|&j| (pieces[j].face, pieces[j].polygon))
                .collect();
            out_elements.push(Element {
                polygon,
                face: piece.face,
                surface: piece.surface,
                patch: u32::MAX,
                parts,
                on_parts: *on_parts,
            });
            out_pieces.push(Piece {
                polygon,
                face: piece.face,
                surface: piece.surface,
                first,
                count: 1,
                kind: PieceKind::Subdivided,
            });
            continue;
        }
        if member[i] {
            continue;
        }
        let range = piece.first as usize..(piece.first + piece.count) as usize;
        out_elements.extend(elements[range].iter().cloned());
        out_pieces.push(Piece {
            first,
            ..piece.clone()
        });
    }
    (out_elements, out_pieces, grouped)
}

/// The part sets of one refinement split of a grouped element (`parts`, two or more): the
/// parts bisected at the median of their centroids along the widest axis
/// (`cluster::bisect`, decided on a grid relative to their extent, so a scaled scene splits
/// alike), and each half of two or more parts bisected again: up to four sets, as a quad's
/// 2×2 split, each sorted by part. `None` for an element with fewer than two parts.
fn split_sets(e: &Element) -> Option<Vec<Vec<usize>>> {
    if e.parts.len() < 2 {
        return None;
    }
    let units: Vec<Unit> = e.parts.iter().map(|(_, p)| Unit::of(p)).collect();
    let all: Vec<usize> = (0..units.len()).collect();
    let mut sets = Vec::with_capacity(4);
    for half in bisect(&units, &all) {
        if half.len() >= 2 {
            sets.extend(bisect(&units, &half));
        } else {
            sets.push(half);
        }
    }
    Some(sets)
}

/// The children of one refinement split of grouped element `e` ([`split_sets`]), in order:
/// a set of one part is an element of that part's own polygon (as a lone small piece is);
/// a set of more is a group again, with its own proxy (sides at most the parent's longest,
/// which holds its area), lit on its parts when the parent was (the parent's decision, so
/// that a split never turns a proxy's light into its parts'). Every part goes to exactly one
/// child, so what is drawn does not change, only which element shows it. `None` when `e`
/// has fewer than two parts or a child's proxy would be degenerate.
pub(crate) fn split_group(e: &Element) -> Option<Vec<Element>> {
    let h = e.polygon.max_edge();
    split_sets(e)?
        .into_iter()
        .map(|set| {
            let (face, first) = e.parts[set[0]];
            if set.len() == 1 {
                return Some(Element {
                    polygon: first,
                    face,
                    surface: e.surface,
                    patch: e.patch,
                    parts: Vec::new(),
                    on_parts: false,
                });
            }
            let polygons: Vec<&Polygon> = set.iter().map(|&i| &e.parts[i].1).collect();
            Some(Element {
                polygon: proxy(&polygons, h)?,
                face,
                surface: e.surface,
                patch: e.patch,
                parts: set.iter().map(|&i| e.parts[i]).collect(),
                on_parts: e.on_parts,
            })
        })
        .collect()
}

/// What is drawn of `elements` (in their order): one element per polygon drawn
/// ([`Element::shown`]: the element itself, or each face of a dense mesh's element, `parts`
/// empty), the index into `elements` each shows, and whether any element is drawn as other
/// polygons than its own (then the file holds them as section FACES).
pub(crate) fn shown_faces<'a>(
    elements: impl ExactSizeIterator<Item = &'a Element>,
) -> (Vec<Element>, Vec<u32>, bool) {
    let mut faces = Vec::with_capacity(elements.len());
    let mut of = Vec::with_capacity(elements.len());
    let mut grouped = false;
    for (s, e) in elements.enumerate() {
        grouped |= !e.parts.is_empty();
        for (face, polygon) in e.shown() {
            faces.push(Element {
                polygon: *polygon,
                face,
                surface: e.surface,
                patch: e.patch,
                parts: Vec::new(),
                on_parts: false,
            });
            of.push(s as u32);
        }
    }
    (faces, of, grouped)
}

/// Whether a group's faces are parallel (normals within 1e-12 of each other, about 1.4e-6
/// rad) but not in one plane (a vertex more than 1e-4 `h` off the first face's plane, far
/// more than such a tilt makes across a group, at most 2√2 h wide: a nearly planar
/// tessellation with float noise in its normals or heights stays on its proxy): faces of
/// separate objects side by side, the tops of boxes of several heights. Such a group is lit
/// on its parts: a proxy standing on the highest of them is in front of the others, and the
/// light they exchange with what lies between them was lost (a hall of boxes 9–16 % too dark
/// against the same hall ungrouped, docs/MESHING.md). A curved surface's faces are not parallel and
/// keep their proxy; the parallel faces of one plane (a planar region's grid cells) lie in it.
fn stacked(parts: &[&Polygon], h: f64) -> bool {
    let first = parts[0];
    let origin = first.vertices()[0];
    let parallel = parts
        .iter()
        .all(|p| p.normal.dot(first.normal) >= 1.0 - 1e-12);
    parallel
        && parts.iter().any(|p| {
            (p.vertices().iter()).any(|&v| (v - origin).dot(first.normal).abs() > 1e-4 * h)
        })
}

/// The planar proxy of a group of faces (module docs): a rectangle of their total area, or
/// `None` when their normals cancel or the rectangle would be degenerate. Its sides are at
/// most `max_side` (a group's area is at most its square): the proxy is then one element of
/// the subdivision hierarchy, as the patch cut and the split rule take it.
pub(crate) fn proxy(parts: &[&Polygon], max_side: f64) -> Option<Polygon> {
    let area: f64 = parts.iter().map(|p| p.area()).sum();
    let centroid = parts.iter().map(|p| p.area() * p.centroid()).sum::<DVec3>() / area;
    let normal = parts
        .iter()
        .map(|p| p.area() * p.normal)
        .sum::<DVec3>()
        .try_normalize()?;
    let (a, b) = normal.any_orthonormal_pair();
    let vertices = || parts.iter().flat_map(|p| p.vertices().iter().copied());
    // Principal axes of the projected vertices (2×2 covariance, closed form).
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for v in vertices() {
        let d = v - centroid;
        let (x, y) = (d.dot(a), d.dot(b));
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
    }
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let u = a * theta.cos() + b * theta.sin();
    let v = normal.cross(u);
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for x in vertices() {
        let d = x - centroid;
        let p = DVec3::new(d.dot(u), d.dot(v), d.dot(normal));
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let (du, dv) = (hi.x - lo.x, hi.y - lo.y);
    if !(du > 0.0 && dv > 0.0 && area > 0.0) {
        return None;
    }
    let s = (area / (du * dv)).sqrt();
    let (mut hu, mut hv) = (0.5 * s * du, 0.5 * s * dv);
    let most = 0.5 * max_side * (1.0 - 1e-9);
    if hu > most {
        (hu, hv) = (most, 0.25 * area / most);
    } else if hv > most {
        (hu, hv) = (0.25 * area / most, most);
    }
    let middle = centroid + normal * hi.z.max(0.0);
    let corners = [
        middle - u * hu - v * hv,
        middle + u * hu - v * hv,
        middle + u * hu + v * hv,
        middle - u * hu + v * hv,
    ];
    let mut p = Polygon::new(&corners)?;
    p.normal = normal;
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshSizes;
    use crate::mesh::tests::cuboid;

    /// A unit icosphere of `subdivisions` (20·4^s triangles), as triangles.
    fn sphere(subdivisions: u32) -> Vec<[DVec3; 3]> {
        crate::scene::procedural::icosphere(subdivisions, [0.0; 3], 1.0)
            .iter()
            .map(|t| [0, 1, 2].map(|i| DVec3::from_array(t[i])))
            .collect()
    }

    /// A 4 × 4 grid of small boxes of five heights, as triangles.
    fn boxes_of_five_heights() -> Vec<[DVec3; 3]> {
        let mut tris = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let lo = DVec3::new(i as f64 * 0.5, j as f64 * 0.5, 0.0);
                let height = 0.2 + 0.05 * ((i * 4 + j) % 5) as f64;
                tris.extend(cuboid(lo, lo + DVec3::new(0.2, 0.2, height)));
            }
        }
        tris
    }

    fn fine(triangles: &[[DVec3; 3]], h: f64) -> (Scene, Vec<Element>) {
        let scene = crate::mesh::tests::one_surface("sphere", triangles);
        let sizes = MeshSizes {
            element_size: h,
            patch_size: 2.0 * h,
        };
        let (elements, _, _) = crate::mesh::fine_mesh(&scene, sizes).unwrap();
        (scene, elements)
    }

    /// Small boxes of several heights in one surface: their parallel faces are grouped across
    /// boxes and lit on their parts (no proxy standing in front of the lower ones); a sphere's
    /// groups keep their proxies.
    #[test]
    fn faces_of_separate_boxes_are_lit_on_their_parts() {
        let tris = boxes_of_five_heights();
        let scene = crate::mesh::tests::one_surface("boxes", &tris);
        let sizes = MeshSizes {
            element_size: 1.0,
            patch_size: 2.0,
        };
        let (elements, _, _) = crate::mesh::fine_mesh(&scene, sizes).unwrap();
        let grouped: Vec<&Element> = elements.iter().filter(|e| !e.parts.is_empty()).collect();
        assert!(grouped.len() >= 6, "{} groups", grouped.len());
        for e in &grouped {
            let heights: Vec<f64> = (e.parts.iter())
                .map(|(_, p)| p.vertices()[0].dot(e.polygon.normal))
                .collect();
            let spread = heights.iter().cloned().fold(f64::MIN, f64::max)
                - heights.iter().cloned().fold(f64::MAX, f64::min);
            assert_eq!(e.on_parts, spread > 1e-6, "{heights:?}");
        }
        assert!(grouped.iter().any(|e| e.on_parts));
        let (_, sphere) = fine(&sphere(4), 0.35);
        assert!(sphere.iter().any(|e| !e.parts.is_empty()));
        assert!(sphere.iter().all(|e| !e.on_parts));
    }

    /// The element count follows the area, not the triangles: the same sphere at 16× and
    /// 256× its triangles gives about as many elements (within 1.5×, the goal), each
    /// face in exactly one element and the proxies' area the sphere's.
    #[test]
    fn a_finer_tessellation_gives_about_the_same_elements() {
        let h = 0.35;
        let mut counts = Vec::new();
        for subdivisions in [2, 4, 6] {
            let tris = sphere(subdivisions);
            let (scene, elements) = fine(&tris, h);
            let mut grouped = vec![0u32; scene.faces.len()];
            let mut shown = 0.0;
            for e in &elements {
                e.parts.iter().for_each(|&(f, _)| grouped[f as usize] += 1);
                shown += e.shown().map(|(_, p)| p.area()).sum::<f64>();
            }
            assert!(grouped.iter().all(|&c| c <= 1), "a face in two elements");
            let area: f64 = scene.faces.iter().map(|f| f.polygon.area()).sum();
            assert!((shown / area - 1.0).abs() < 1e-9, "drawn {shown} of {area}");
            let proxies: f64 = elements.iter().map(|e| e.polygon.area()).sum();
            assert!((proxies / area - 1.0).abs() < 1e-9, "{proxies} vs {area}");
            counts.push(elements.len() as f64);
        }
        let (lo, hi) = counts
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &c| (l.min(c), h.max(c)));
        eprintln!("element counts {counts:?}");
        assert!(hi / lo <= 1.5, "element counts {counts:?}");
    }

    /// The smooth weights of a dense mesh's faces, gathered per element, are what the file's
    /// check asks: every vertex's weights on elements that exist, non-zero, finite, within
    /// ±8 and summing to one; every face corner names a vertex.
    #[test]
    fn display_weights_gather_per_element() {
        let (scene, elements) = fine(&sphere(5), 0.35);
        assert!(elements.iter().any(|e| e.parts.len() > 1));
        let (faces, of, grouped) = shown_faces(elements.iter());
        assert!(grouped && faces.len() == scene.faces.len());
        let refs: Vec<&Element> = faces.iter().collect();
        let s = crate::mesh::smooth::per_element(
            &crate::mesh::smooth::weights(&scene, &refs, None),
            &of,
        );
        assert_eq!(s.corners.len(), 4 * faces.len());
        for v in 0..s.vertex_count() {
            let r = s.offsets[v] as usize..s.offsets[v + 1] as usize;
            assert!(!r.is_empty());
            let sum: f64 = s.weights[r.clone()].iter().map(|&w| f64::from(w)).sum();
            assert!((sum - 1.0).abs() < 1e-5, "vertex {v}: {sum}");
            for (&p, &w) in s.positions[r.clone()].iter().zip(&s.weights[r]) {
                assert!((p as usize) < elements.len());
                assert!(w.is_finite() && w != 0.0 && w.abs() <= 8.0);
            }
        }
        for (f, face) in faces.iter().enumerate() {
            for c in 0..face.polygon.count {
                assert!((s.corners[4 * f + c] as usize) < s.vertex_count());
            }
        }
    }

    /// A refinement split of a group shares its parts among up to four children, each part
    /// in exactly one, in the parent's surface and patch; each child is a proxy of its parts'
    /// area (sides no longer than the parent's), or a lone part as its own polygon; a group
    /// of parts lit on its parts (or not) has children lit on theirs (or not); the split does
    /// not depend on the scale.
    #[test]
    fn a_split_group_shares_its_parts_among_its_children() {
        let boxes = boxes_of_five_heights();
        let mut on_parts = 0;
        for (tris, h) in [(sphere(5), 0.35), (sphere(3), 0.35), (boxes, 1.0)] {
            let (_, elements) = fine(&tris, h);
            let groups: Vec<&Element> = elements.iter().filter(|e| !e.parts.is_empty()).collect();
            assert!(groups.len() > 4);
            for e in groups {
                on_parts += usize::from(e.on_parts);
                let kids = split_group(e).expect("a group of two or more parts splits");
                assert!((2..=4).contains(&kids.len()), "{} children", kids.len());
                let mut parts: Vec<(u32, Polygon)> = Vec::new();
                let mut area = 0.0;
                for k in &kids {
                    assert_eq!((k.surface, k.patch), (e.surface, e.patch));
                    area += k.polygon.area();
                    if k.parts.is_empty() {
                        assert!(!k.on_parts);
                        parts.push((k.face, k.polygon));
                        continue;
                    }
                    assert!(k.parts.len() >= 2 && k.on_parts == e.on_parts);
                    assert_eq!(k.face, k.parts[0].0);
                    assert!(k.polygon.max_edge() <= e.polygon.max_edge() * (1.0 + 1e-9));
                    let own: f64 = k.parts.iter().map(|(_, p)| p.area()).sum();
                    assert!((k.polygon.area() / own - 1.0).abs() < 1e-9);
                    parts.extend(k.parts.iter().copied());
                }
                let whole = e.polygon.area();
                assert!((area / whole - 1.0).abs() < 1e-9, "{area} of {whole}");
                let key = |(f, p): &(u32, Polygon)| (*f, p.centroid().to_array().map(f64::to_bits));
                let mut a: Vec<_> = parts.iter().map(key).collect();
                let mut b: Vec<_> = e.parts.iter().map(key).collect();
                a.sort_unstable();
                b.sort_unstable();
                assert_eq!(a, b, "every part in exactly one child");
                // The same group scaled by 1e4 splits into the same sets of parts.
                let scaled = Element {
                    parts: (e.parts.iter())
                        .map(|(f, p)| {
                            let v: Vec<DVec3> = p.vertices().iter().map(|v| *v * 1e4).collect();
                            (*f, Polygon::new(&v).unwrap())
                        })
                        .collect(),
                    ..e.clone()
                };
                assert_eq!(split_sets(&scaled), split_sets(e));
                let lone = Element {
                    parts: e.parts[..1].to_vec(),
                    ..e.clone()
                };
                assert!(split_group(&lone).is_none());
            }
        }
        assert!(on_parts > 0, "no group lit on its parts was split");
    }

    /// A proxy lies on or in front of every vertex of its faces, has their area, and faces
    /// their mean normal.
    #[test]
    fn a_proxy_stands_in_front_of_its_faces() {
        let tris = sphere(4);
        let polygons: Vec<Polygon> = tris
            .iter()
            .filter(|t| t.iter().all(|v| v.z > 0.8))
            .map(|t| Polygon::new(t).unwrap())
            .collect();
        let refs: Vec<&Polygon> = polygons.iter().collect();
        let p = proxy(&refs, f64::INFINITY).unwrap();
        let area: f64 = polygons.iter().map(|q| q.area()).sum();
        assert!((p.area() / area - 1.0).abs() < 1e-12);
        assert!(p.normal.dot(DVec3::Z) > 0.999);
        for q in &polygons {
            for v in q.vertices() {
                assert!(p.height(*v) <= 1e-12, "{}", p.height(*v));
            }
        }
    }
}
