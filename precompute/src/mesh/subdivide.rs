//! Recursive subdivision of faces into the element/patch hierarchy.

use glam::DVec3;
use rayon::prelude::*;

use std::time::Instant;

use super::element::{Element, MeshSizes, face_estimate, within};
use super::imprint::{
    Contact, ContactIndex, ContactLine, INDEXED_CONTACTS, Imprinter, boxes_meet, cut_all,
    polygon_bounds, through,
};
use super::region::{self, PlanCounts, Root};
use crate::geometry::Polygon;
use crate::geometry::at_least;
use crate::geometry::boxes::BoxGrid;
use crate::scene::Scene;

/// Splits a node into children: quads 2×2 (or 1×2 along the long side when one side is at
/// least twice the other, to keep elements near square), triangles into 4 by edge midpoints.
pub(crate) fn split(p: &Polygon) -> Vec<Polygon> {
    try_split(p).expect("children of a polygon larger than the element size are valid")
}

/// [`split`], or `None` when a child would have no area in floating point (a sliver far
/// below the element size, as refinement may pick).
pub(crate) fn try_split(p: &Polygon) -> Option<Vec<Polygon>> {
    let v = p.vertices();
    let mid = |a: DVec3, b: DVec3| (a + b) * 0.5;
    let pieces: Vec<Vec<DVec3>> = if v.len() == 3 {
        let (m01, m12, m20) = (mid(v[0], v[1]), mid(v[1], v[2]), mid(v[2], v[0]));
        vec![
            vec![v[0], m01, m20],
            vec![m01, v[1], m12],
            vec![m20, m12, v[2]],
            vec![m01, m12, m20],
        ]
    } else {
        let lu = ((v[1] - v[0]).length() + (v[2] - v[3]).length()) * 0.5;
        let lw = ((v[3] - v[0]).length() + (v[2] - v[1]).length()) * 0.5;
        let (m01, m12, m23, m30) = (
            mid(v[0], v[1]),
            mid(v[1], v[2]),
            mid(v[2], v[3]),
            mid(v[3], v[0]),
        );
        // Up to rounding: the Godot living room's 0.5 × 1 quads split 1×2 at its own scale
        // and 2×2 at 0.01, its window frames meshed to 232 elements instead of 164.
        if at_least(lu, 2.0, lw) {
            vec![vec![v[0], m01, m23, v[3]], vec![m01, v[1], v[2], m23]]
        } else if at_least(lw, 2.0, lu) {
            vec![vec![v[0], v[1], m12, m30], vec![m30, m12, v[2], v[3]]]
        } else {
            let c = (v[0] + v[1] + v[2] + v[3]) * 0.25;
            vec![
                vec![v[0], m01, c, m30],
                vec![m01, v[1], m12, c],
                vec![c, m12, v[2], m23],
                vec![m30, c, m23, v[3]],
            ]
        }
    };
    pieces
        .iter()
        .map(|q| {
            let mut child = Polygon::new(q)?;
            child.normal = p.normal; // exact parent normal: no drift down the hierarchy
            Some(child)
        })
        .collect()
}

/// Estimated element count of the fine mesh (for refusing huge bakes early): the subdivision
/// bound of faces meshed as faces, the (face, cell) pairs of regions meshed as grids (see
/// `region`), so it follows the area of triangles, not the square of their longest edge.
pub fn estimate_elements(scene: &Scene, element_size: f64) -> f64 {
    let (roots, _) = region::plan(scene, element_size, &|p| {
        leaf_count(*p, element_size) as f64
    });
    per_surface_estimate(scene, &roots, element_size, f64::INFINITY)
        .iter()
        .sum()
}

/// The estimate of each surface, stopping once the total passes `cap`.
pub(crate) fn per_surface_estimate(
    scene: &Scene,
    roots: &[Root],
    element_size: f64,
    cap: f64,
) -> Vec<f64> {
    let mut out = vec![0.0; scene.surfaces.len().max(1)];
    let mut total = 0.0;
    for root in roots {
        let (s, e) = match root {
            Root::Face(p, f) => (scene.faces[*f].surface, face_estimate(p, element_size)),
            Root::Grid(g) => (
                scene.faces[g.faces[0]].surface,
                g.estimate(&scene.faces, element_size, cap - total),
            ),
        };
        out[s] += e;
        total += e;
        if total > cap {
            break;
        }
    }
    out
}

/// A piece of an input face (after imprinting): the root of one subdivision hierarchy, and the
/// consecutive original ids `first..first + count` of its elements.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Piece {
    pub polygon: Polygon,
    pub face: u32,
    pub surface: u32,
    pub first: u32,
    pub count: u32,
    /// How it was made, which decides whether `dense` may group it.
    pub kind: PieceKind,
}

/// How a [`Piece`] was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PieceKind {
    /// A face root (or a piece of one cut at its contacts), subdivided: `dense` groups it when
    /// it is one element of a face no larger than the element size.
    Subdivided,
    /// A cell of a planar region meshed as a grid (`region`), clipped to one of its faces:
    /// `dense` groups it.
    RegionGrid,
    /// A piece of a face under many contacts meshed as a grid ([`face_cut`]), `covered` when
    /// it lies behind what stands on the face there (under a box), in `group` with the
    /// pieces of its cell on its side that it meets freely ([`groups`]): `dense` makes each
    /// group one element lit on its parts ([`Element::on_parts`]).
    FaceGrid { group: u32, covered: bool },
}

/// What building the fine mesh found and how long its stages took.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshReport {
    /// Regions merged or meshed as grids.
    pub regions: PlanCounts,
    /// Faces passing through others that were imprinted (cut along the crossing).
    pub interpenetrations: usize,
    /// Area of grid pieces too small to be elements (below 1e-12 of a cell), dropped.
    pub dropped_area: f64,
    /// Elements made by grids.
    pub grid_elements: usize,
    /// Faces whose contacts would have cut them into strips, meshed as grids instead
    /// (`face_cut`).
    pub sliver_faces: usize,
    /// Smallest interior angle of any element, degrees.
    pub min_angle: f64,
    /// Smallest interior angle of a grid element, degrees (180 when there are none).
    pub grid_min_angle: f64,
    /// (stage, seconds): `regions` (grouping and merging), `grid` (clipped grids),
    /// `imprint` (contact and crossing cuts, and the grids of faces under many contacts),
    /// `subdivide` (the hierarchy's leaves), `group` (small pieces grouped, `dense`).
    pub stages: Vec<(&'static str, f64)>,
    /// Elements split by refinement where light changes (`lrr bake --refine`), 0 without.
    pub refined: usize,
    /// Pieces of small input faces and grid cells grouped into elements of about the element
    /// size (`dense`; stage `group`).
    pub grouped: Grouped,
    /// Bytes the mesh stage was planned to hold before its buffers existed, checked against
    /// `--max-memory`: meshing's ([`crate::mesh::MESH_BYTES_PER_FACE`] and
    /// [`crate::mesh::MESH_BYTES_PER_PIECE`]) and 2MSC's probes'. 0 for a mesh read from a
    /// plan.
    pub planned_bytes: u128,
}

/// What grouping did: pieces grouped and the elements they became.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Grouped {
    /// Pieces (of small input faces, or grid cells) that are now parts of a grouped element.
    pub faces: usize,
    /// Elements they became.
    pub elements: usize,
}

/// The fine mesh: planar regions planned (`region`), faces cut at their contacts and
/// subdivided depth-first until their nodes' size ([`Polygon::size`]) drops to the element
/// size (or, under many contacts, meshed as a grid: [`face_cut`]), grid regions cut into
/// cells (each element its own piece) and at their contacts. It does not depend on the patch
/// method; `patch` is left unset (`u32::MAX`) for the coarse mesh to fill.
pub(crate) fn fine(
    scene: &Scene,
    roots: Vec<Root>,
    element_size: f64,
    index: &ContactIndex,
    report: &mut MeshReport,
) -> (Vec<Element>, Vec<Piece>) {
    let mut elements = Vec::new();
    let mut pieces = Vec::new();
    let imprinter = Imprinter::with(&scene.faces, index);
    let (mut t_grid, mut t_imprint, mut t_subdivide) = (0.0, 0.0, 0.0);
    report.min_angle = 180.0;
    report.grid_min_angle = 180.0;
    // Each face root is cut at its contacts on its own: in parallel, kept in root order.
    let t = Instant::now();
    // The faces' contact lines are handed to the index a chunk of roots at a time, so that
    // no more than a chunk's are held beside its table.
    let mut splits: Vec<Option<FaceCut>> = Vec::with_capacity(roots.len());
    let mut keeper = index.keeper();
    for chunk in roots.chunks(ROOTS_A_CHUNK) {
        let mut cuts: Vec<Option<FaceCut>> = chunk
            .par_iter()
            .map(|root| match root {
                Root::Face(polygon, f) => {
                    Some(face_cut(scene, &imprinter, *polygon, *f, element_size))
                }
                Root::Grid(_) => None,
            })
            .collect();
        for (root, cut) in chunk.iter().zip(&mut cuts) {
            if let (Root::Face(_, f), Some(cut)) = (root, cut)
                && let Some(lines) = cut.kept.take()
            {
                keeper.add(*f, &lines);
            }
        }
        splits.extend(cuts);
    }
    index.keep(keeper);
    t_imprint += t.elapsed().as_secs_f64();
    for (root, split) in roots.into_iter().zip(splits) {
        match root {
            Root::Face(_, f) => {
                let cut = split.expect("every face root was split");
                report.interpenetrations += cut.through;
                let surface = scene.faces[f].surface as u32;
                if cut.grid {
                    report.dropped_area += cut.dropped;
                    report.sliver_faces += 1;
                    let t = Instant::now();
                    let kinds = cut
                        .cells
                        .iter()
                        .map(|&(group, covered)| PieceKind::FaceGrid { group, covered });
                    grid_pieces(
                        cut.pieces.into_iter().zip(kinds),
                        f,
                        surface,
                        report,
                        &mut elements,
                        &mut pieces,
                    );
                    t_grid += t.elapsed().as_secs_f64();
                    continue;
                }
                let t = Instant::now();
                for polygon in cut.pieces {
                    let first = elements.len() as u32;
                    leaves(polygon, element_size, &mut |p| {
                        report.min_angle = report.min_angle.min(region::min_angle(&p));
                        elements.push(Element {
                            polygon: p,
                            face: f as u32,
                            surface,
                            patch: u32::MAX,
                            parts: Vec::new(),
                            on_parts: false,
                        })
                    });
                    pieces.push(Piece {
                        polygon,
                        face: f as u32,
                        surface,
                        first,
                        count: elements.len() as u32 - first,
                        kind: PieceKind::Subdivided,
                    });
                }
                t_subdivide += t.elapsed().as_secs_f64();
            }
            Root::Grid(grid) => {
                let t = Instant::now();
                let (cells, dropped) = grid.elements(&scene.faces, element_size);
                report.dropped_area += dropped;
                t_grid += t.elapsed().as_secs_f64();
                let t = Instant::now();
                let plane = grid.plane_polygon();
                let contacts = imprinter.contacts(&plane, grid.bounds(&scene.faces), None);
                let (cut, _, used) = cut_cells(cells, &contacts, plane.scale);
                let f = grid.faces[0];
                let surface = scene.faces[f].surface as u32;
                let cut = cut.into_iter().map(|p| (p, PieceKind::RegionGrid));
                grid_pieces(cut, f, surface, report, &mut elements, &mut pieces);
                report.interpenetrations += through(&contacts, &used);
                t_imprint += t.elapsed().as_secs_f64();
            }
        }
    }
    report.stages.extend([
        ("grid", t_grid),
        ("imprint", t_imprint),
        ("subdivide", t_subdivide),
    ]);
    (elements, pieces)
}

/// Face roots cut at a time (their contact lines held until the index takes them).
const ROOTS_A_CHUNK: usize = 1 << 14;

/// A face root cut at its contacts: the pieces to subdivide, or (`grid`) the elements of its
/// grid.
struct FaceCut {
    pieces: Vec<Polygon>,
    /// With `grid`: each piece's group and whether it is covered ([`PieceKind::FaceGrid`]).
    cells: Vec<(u32, bool)>,
    through: usize,
    grid: bool,
    /// Area of grid pieces too small to be elements.
    dropped: f64,
    /// The contacts when `polygon` is the whole face, for the mesh's contact index to keep.
    kept: Option<Box<[ContactLine]>>,
}

/// Face `f`'s root `polygon` cut at its contact lines. A contact cuts the whole piece its
/// segment crosses, and the pieces are then subdivided along their length: a floor under
/// many boxes becomes strips that each cross the floor, and subdivide into far more elements
/// than its area and contacts call for (1 000 boxes on a floor: 43 900 elements where its
/// area gives 198). Where the pieces would subdivide into more than twice the sum of what the
/// face makes uncut and what its cuts add (below; a cut's length is its whole segment, so a
/// cut running past the face counts more than it adds), the face is also meshed as a grid
/// whose cells are cut by the contacts near them, so that a cut ends at the cell's side;
/// that is kept when it makes at most half the elements (the 1 000 boxes: 7 796, the bake's
/// surface means within 0.9 % of the strips', docs/MESHING.md).
///
/// `dense` then groups each cell's pieces into at most two elements lit on their parts
/// ([`Element::on_parts`]): the pieces about what stands on the face and the pieces under it
/// ([`covered`]). A proxy lit in their place stands partly under the boxes, where its rays are
/// blocked: grouping them so made the floor 4 % darker on those boxes, the ceiling 11 %.
fn face_cut(
    scene: &Scene,
    imprinter: &Imprinter,
    polygon: Polygon,
    f: usize,
    element_size: f64,
) -> FaceCut {
    let (pieces, contacts, used) = imprinter.split(polygon, f);
    let kept = (polygon == scene.faces[f].polygon).then(|| ContactLine::of(&contacts));
    let subdivided = FaceCut {
        through: through(&contacts, &used),
        pieces,
        cells: Vec::new(),
        grid: false,
        dropped: 0.0,
        kept,
    };
    let h = element_size;
    // What the face makes uncut, two pieces along each element-size length of the cuts and
    // two more a cut (a box's foot inside a cell: its four cuts make nine pieces of one),
    // doubled: strips that merely follow a few cuts (the Cornell box's floor about its two
    // blocks) stay as they are.
    let cuts = contacts.iter().zip(&used).filter(|(_, u)| **u);
    let (length, m) = cuts.fold((0.0, 0.0), |(l, m), (c, _)| (l + c.length(), m + 1.0));
    if m == 0.0 {
        return subdivided;
    }
    let bound = 2.0 * (leaf_count(polygon, h) as f64 + 2.0 * length / h + 2.0 * m);
    // The strips are counted only as far as a decision needs: past the bound, then past twice
    // the grid's elements.
    let mut strips = subdivided.pieces.iter();
    let mut count = 0.0;
    for p in strips.by_ref() {
        count += leaf_count(*p, h) as f64;
        if count > bound {
            break;
        }
    }
    if count <= bound {
        return subdivided;
    }
    let grid = region::Grid::of_polygon(&scene.faces, polygon, f);
    let (cells, dropped) = grid.elements(&scene.faces, h);
    let (pieces, tags, used) = cut_cells(cells, &contacts, polygon.scale);
    let enough = 2.0 * pieces.len() as f64;
    for p in strips {
        if count >= enough {
            break;
        }
        count += leaf_count(*p, h) as f64;
    }
    if count < enough {
        return subdivided;
    }
    FaceCut {
        through: through(&contacts, &used),
        pieces,
        cells: tags,
        grid: true,
        dropped,
        kept: subdivided.kept,
    }
}

/// Grid cells each cut by the contacts whose segments come near it (a cut ends at the cell's
/// sides), in cell order, each piece with its group and whether it is covered ([`covered`]):
/// the pieces of one cell on one side that meet along an edge no contact lies on share a
/// group ([`groups`]), numbered from 0 in cell order. `used[i]` when contact `i` cut
/// something. `scale` sets the tolerance of "near".
fn cut_cells(
    cells: Vec<Polygon>,
    contacts: &[Contact],
    scale: f64,
) -> (Vec<Polygon>, Vec<(u32, bool)>, Vec<bool>) {
    let mut used = vec![false; contacts.len()];
    let grow = 1e-7 * scale;
    let index = (contacts.len() > INDEXED_CONTACTS).then(|| {
        let boxes: Vec<(DVec3, DVec3)> = contacts.iter().map(|c| c.bounds()).collect();
        BoxGrid::new(&boxes)
    });
    let mut out = Vec::with_capacity(cells.len());
    let mut tags = Vec::with_capacity(cells.len());
    let mut next = 0u32;
    for cell in cells {
        let bounds = polygon_bounds(&cell);
        let mut near: Vec<usize> = match &index {
            Some(index) => {
                let g = DVec3::splat(grow);
                let found = index.candidates((bounds.0 - g, bounds.1 + g));
                found.into_iter().map(|i| i as usize).collect()
            }
            None => (0..contacts.len()).collect(),
        };
        near.sort_unstable();
        near.dedup();
        near.retain(|&i| boxes_meet(bounds, contacts[i].bounds(), grow));
        if near.is_empty() {
            out.push(cell);
            tags.push((next, false));
            next += 1;
            continue;
        }
        let picked: Vec<Contact> = near.iter().map(|&i| contacts[i]).collect();
        let mut u = vec![false; near.len()];
        let area = cell.area();
        let pieces = cut_all(vec![cell], &picked, area, &mut u);
        let sides: Vec<bool> = pieces.iter().map(|p| covered(p, &picked)).collect();
        let (group, count) = groups(&pieces, &sides, &picked, grow);
        tags.extend(group.iter().zip(&sides).map(|(&g, &c)| (next + g, c)));
        next += count;
        out.extend(pieces);
        for (k, &i) in near.iter().enumerate() {
            used[i] |= u[k];
        }
    }
    (out, tags, used)
}

/// Whether a piece of a cut cell lies under what stands on its face: behind a contact
/// nearest its centroid. Several as near (within rounding) decide together, and one behind
/// is enough: under a box against a wall, or against another box, the box's side and the
/// wall's foot (or the other box's side, which faces away) lie on one line; at a box's
/// corner outside, the point is in front of both sides. Only the cell's contacts are asked.
/// Grouping by it keeps the floor about a box's foot apart from the floor under it, which
/// sees nothing.
fn covered(piece: &Polygon, contacts: &[Contact]) -> bool {
    let x = piece.centroid();
    let sides: Vec<(f64, bool)> = contacts.iter().map(|c| c.behind(x, piece.normal)).collect();
    let nearest = sides.iter().map(|s| s.0).fold(f64::INFINITY, f64::min);
    let tie = nearest + 1e-9 * piece.scale;
    nearest.is_finite() && sides.iter().any(|&(d, behind)| d <= tie && behind)
}

/// The groups of one cell's pieces: the covered ones (`covered`: under what stands on the
/// face, seeing nothing) one group; the open ones by connection, two joining when an edge of
/// one runs along an edge of the other (collinear, opposite, overlapping by more than `tol`)
/// and no contact lies on the middle of that overlap. The floor on either side of a wall
/// crossing the cell stays apart, as the pieces of a strip would. Returns each piece's group
/// (numbered from 0 in the order of its first piece) and the number of groups.
fn groups(pieces: &[Polygon], covered: &[bool], contacts: &[Contact], tol: f64) -> (Vec<u32>, u32) {
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut parent: Vec<usize> = (0..pieces.len()).collect();
    let bounds: Vec<(DVec3, DVec3)> = pieces.iter().map(polygon_bounds).collect();
    for i in 0..pieces.len() {
        for j in i + 1..pieces.len() {
            if covered[i] != covered[j] {
                continue;
            }
            let join = covered[i]
                || (boxes_meet(bounds[i], bounds[j], tol)
                    && meet_freely(&pieces[i], &pieces[j], contacts, tol));
            if join {
                let (a, b) = (root(&mut parent, i), root(&mut parent, j));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut number = vec![u32::MAX; pieces.len()];
    let mut count = 0;
    let mut out = Vec::with_capacity(pieces.len());
    for i in 0..pieces.len() {
        let r = root(&mut parent, i);
        if number[r] == u32::MAX {
            number[r] = count;
            count += 1;
        }
        out.push(number[r]);
    }
    (out, count)
}

/// Whether `a` and `b` share a stretch of edge (collinear, opposite, overlapping by more than
/// `tol`) whose middle no contact lies on ([`Contact::holds`]).
fn meet_freely(a: &Polygon, b: &Polygon, contacts: &[Contact], tol: f64) -> bool {
    let (va, vb) = (a.vertices(), b.vertices());
    for i in 0..va.len() {
        let (p, q) = (va[i], va[(i + 1) % va.len()]);
        let len = p.distance(q);
        if len <= tol {
            continue;
        }
        let d = (q - p) / len;
        // Distance of `x` from the line of a's edge.
        let off = |x: DVec3| (x - p - d * (x - p).dot(d)).length();
        for k in 0..vb.len() {
            let (r, t) = (vb[k], vb[(k + 1) % vb.len()]);
            if (t - r).dot(d) >= 0.0 || off(r) > tol || off(t) > tol {
                continue;
            }
            let (lo, hi) = ((t - p).dot(d).max(0.0), (r - p).dot(d).min(len));
            if hi - lo <= tol {
                continue;
            }
            let mid = p + d * (0.5 * (lo + hi));
            if !contacts.iter().any(|c| c.holds(mid, d, tol)) {
                return true;
            }
        }
    }
    false
}

/// Grid pieces of face `f`, each one element and its own piece of the given kind.
fn grid_pieces(
    cut: impl Iterator<Item = (Polygon, PieceKind)>,
    f: usize,
    surface: u32,
    report: &mut MeshReport,
    elements: &mut Vec<Element>,
    pieces: &mut Vec<Piece>,
) {
    for (polygon, kind) in cut {
        let angle = region::min_angle(&polygon);
        report.min_angle = report.min_angle.min(angle);
        report.grid_min_angle = report.grid_min_angle.min(angle);
        report.grid_elements += 1;
        pieces.push(Piece {
            polygon,
            face: f as u32,
            surface,
            first: elements.len() as u32,
            count: 1,
            kind,
        });
        elements.push(Element {
            polygon,
            face: f as u32,
            surface,
            patch: u32::MAX,
            parts: Vec::new(),
            on_parts: false,
        });
    }
}

/// Calls `visit` on the leaves (elements) under `node`, depth-first.
pub(crate) fn leaves(node: Polygon, element_size: f64, visit: &mut dyn FnMut(Polygon)) {
    if within(node.size(), element_size) {
        visit(node);
        return;
    }
    for child in split(&node) {
        leaves(child, element_size, visit);
    }
}

/// Number of elements under `node`.
pub(crate) fn leaf_count(node: Polygon, element_size: f64) -> u32 {
    let mut n = 0;
    leaves(node, element_size, &mut |_| n += 1);
    n
}

/// True when a piece is its own patch or smaller under the 2MF cut (its root is cut): such
/// pieces are grouped by clustering instead of each becoming a patch.
pub(crate) fn is_small(piece: &Piece, sizes: MeshSizes) -> bool {
    let size = piece.polygon.size();
    within(size, sizes.patch_size) || within(size, sizes.element_size)
}

/// Fewest small pieces a surface must have for them to be clustered: below it each small
/// piece stays its own patch, as the 2MF cut makes it. Imprinting leaves a few small slivers
/// at the feet of blocks and walls (3 on the Cornell box floor); dense meshes have hundreds.
pub(crate) const DENSE_PIECES: usize = 16;

/// The small pieces of each *dense* surface (at least [`DENSE_PIECES`] of them), by surface
/// then piece index: what clustering groups.
pub(crate) fn dense_sets(pieces: &[Piece], sizes: MeshSizes) -> Vec<Vec<usize>> {
    let mut small: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
    for (i, p) in pieces.iter().enumerate() {
        if is_small(p, sizes) {
            small.entry(p.surface).or_default().push(i);
        }
    }
    small
        .into_values()
        .filter(|set| set.len() >= DENSE_PIECES)
        .collect()
}

/// The 2MF cut of one (large) piece: nodes where the size first drops to the patch size (an
/// element larger than the patch size is its own patch), depth-first; `visit` gets each patch
/// polygon and its first element id and element count.
pub(crate) fn cut(
    node: Polygon,
    first: u32,
    sizes: MeshSizes,
    visit: &mut dyn FnMut(Polygon, u32, u32),
) -> u32 {
    let edge = node.size();
    if within(edge, sizes.patch_size) || within(edge, sizes.element_size) {
        let count = leaf_count(node, sizes.element_size);
        visit(node, first, count);
        return count;
    }
    let mut count = 0;
    for child in split(&node) {
        count += cut(child, first + count, sizes, visit);
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rectangle of two to one splits across its long side at any scale: scaled by a factor
    /// that is not a power of two, its sides are two to one only up to rounding.
    #[test]
    fn a_two_to_one_rectangle_splits_one_by_two_at_any_scale() {
        for s in [1.0, 0.01, 0.1, 0.3, 1e-3, 7.0, 1e4, 1.0000001] {
            let p = |x: f64, y: f64| DVec3::new(x * s, y * s, 2.5 * s);
            let quad = Polygon::new(&[p(-4.5, 1.0), p(-5.0, 1.0), p(-5.0, 2.0), p(-4.5, 2.0)]);
            let children = split(&quad.unwrap());
            assert_eq!(children.len(), 2, "scale {s}");
            let wide = Polygon::new(&[p(-4.5, 1.0), p(-3.5, 1.0), p(-3.5, 1.5), p(-4.5, 1.5)]);
            assert_eq!(
                split(&wide.unwrap()).len(),
                2,
                "scale {s}, the long side along u"
            );
        }
    }

    /// The floor under a box is covered where another box touches it (their sides on one
    /// line, the other's facing the first) and where it stands flush against the room's
    /// wall; the floor beside a box, at its corner, is open.
    #[test]
    fn the_floor_under_touching_boxes_is_covered() {
        let scene = crate::mesh::boxes_on_floor_and(&[
            ([0.0, 3.1], [0.06, 3.16]),
            ([0.01, 1.1], [0.05, 1.14]),
            ([0.05, 1.1], [0.09, 1.14]),
        ]);
        let floor = scene.surfaces.iter().position(|s| s == "cube.-z").unwrap();
        let f = scene.faces.iter().position(|x| x.surface == floor).unwrap();
        let imprinter = Imprinter::new(&scene.faces);
        let plane = scene.faces[f].polygon;
        let contacts = imprinter.contacts(&plane, polygon_bounds(&plane), Some(f));
        let square = |x0: f64, y0: f64, x1: f64, y1: f64| {
            let v = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]].map(|[x, y]| DVec3::new(x, y, 0.0));
            Polygon::new(&v).unwrap()
        };
        // Under the first of the touching boxes, under the second, under the flush one.
        assert!(covered(&square(0.01, 1.1, 0.05, 1.14), &contacts));
        assert!(covered(&square(0.05, 1.1, 0.09, 1.14), &contacts));
        assert!(covered(&square(0.0, 3.1, 0.06, 3.16), &contacts));
        // Beside the touching pair's corner, and between two boxes of the lattice.
        assert!(!covered(&square(0.09, 1.14, 0.095, 1.145), &contacts));
        assert!(!covered(&square(0.181, 0.05, 0.35, 0.13), &contacts));
    }
}
