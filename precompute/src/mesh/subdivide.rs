//! Recursive subdivision of faces into the element/patch hierarchy.

use glam::DVec3;
use rayon::prelude::*;

use std::time::Instant;

use super::element::{Element, MeshSizes, face_estimate, within};
use super::imprint::{Contact, Imprinter, boxes_meet, cut_all, polygon_bounds, through};
use super::region::{self, PlanCounts, Root};
use crate::geometry::Polygon;
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
        if lu >= 2.0 * lw {
            vec![vec![v[0], m01, m23, v[3]], vec![m01, v[1], v[2], m23]]
        } else if lw >= 2.0 * lu {
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
    /// Whether it is a cell of a planar region meshed as a grid (`region`).
    pub grid: bool,
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
    /// Smallest interior angle of any element, degrees.
    pub min_angle: f64,
    /// Smallest interior angle of a grid element, degrees (180 when there are none).
    pub grid_min_angle: f64,
    /// (stage, seconds): `regions` (grouping and merging), `grid` (clipped grids),
    /// `imprint` (contact and crossing cuts), `subdivide` (the hierarchy's leaves), `group`
    /// (small pieces grouped, `dense`).
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
/// size, grid regions cut into cells (each element its own piece) and at their contacts. It
/// does not depend on the patch method; `patch` is left unset (`u32::MAX`) for the coarse mesh
/// to fill.
pub(crate) fn fine(
    scene: &Scene,
    roots: Vec<Root>,
    element_size: f64,
    report: &mut MeshReport,
) -> (Vec<Element>, Vec<Piece>) {
    let mut elements = Vec::new();
    let mut pieces = Vec::new();
    let imprinter = Imprinter::new(&scene.faces);
    let (mut t_grid, mut t_imprint, mut t_subdivide) = (0.0, 0.0, 0.0);
    report.min_angle = 180.0;
    report.grid_min_angle = 180.0;
    // Each face root is cut at its contacts on its own: in parallel, kept in root order.
    let t = Instant::now();
    let splits: Vec<Option<(Vec<Polygon>, usize)>> = roots
        .par_iter()
        .map(|root| match root {
            Root::Face(polygon, f) => Some(imprinter.split(*polygon, *f)),
            Root::Grid(_) => None,
        })
        .collect();
    t_imprint += t.elapsed().as_secs_f64();
    for (root, split) in roots.into_iter().zip(splits) {
        match root {
            Root::Face(_, f) => {
                let (cut, through) = split.expect("every face root was split");
                report.interpenetrations += through;
                let t = Instant::now();
                let surface = scene.faces[f].surface as u32;
                for polygon in cut {
                    let first = elements.len() as u32;
                    leaves(polygon, element_size, &mut |p| {
                        report.min_angle = report.min_angle.min(region::min_angle(&p));
                        elements.push(Element {
                            polygon: p,
                            face: f as u32,
                            surface,
                            patch: u32::MAX,
                            parts: Vec::new(),
                        })
                    });
                    pieces.push(Piece {
                        polygon,
                        face: f as u32,
                        surface,
                        first,
                        count: elements.len() as u32 - first,
                        grid: false,
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
                let mut used = vec![false; contacts.len()];
                let f = grid.faces[0];
                let surface = scene.faces[f].surface as u32;
                let grow = 1e-7 * plane.scale;
                for cell in cells {
                    let near: Vec<usize> = (0..contacts.len())
                        .filter(|&i| boxes_meet(polygon_bounds(&cell), contacts[i].bounds(), grow))
                        .collect();
                    let cut = if near.is_empty() {
                        vec![cell]
                    } else {
                        let picked: Vec<Contact> = near.iter().map(|&i| contacts[i]).collect();
                        let mut u = vec![false; near.len()];
                        let cut = cut_all(vec![cell], &picked, cell.area(), &mut u);
                        for (k, &i) in near.iter().enumerate() {
                            used[i] |= u[k];
                        }
                        cut
                    };
                    for polygon in cut {
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
                            grid: true,
                        });
                        elements.push(Element {
                            polygon,
                            face: f as u32,
                            surface,
                            patch: u32::MAX,
                            parts: Vec::new(),
                        });
                    }
                }
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
