//! Recursive subdivision of faces into the element/patch hierarchy.

use glam::DVec3;

use super::element::{Element, MeshSizes};
use crate::geometry::Polygon;
use crate::scene::Scene;

/// Splits a node into children: quads 2×2 (or 1×2 along the long side when one side is at
/// least twice the other, to keep elements near square), triangles into 4 by edge midpoints.
pub(crate) fn split(p: &Polygon) -> Vec<Polygon> {
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
            let mut child = Polygon::new(q).expect("children of a valid polygon are valid");
            child.normal = p.normal; // exact parent normal: no drift down the hierarchy
            child
        })
        .collect()
}

/// Upper bound on the element count of a subdivision (for refusing huge bakes early).
pub fn estimate_elements(scene: &Scene, element_size: f64) -> f64 {
    scene
        .faces
        .iter()
        .map(|f| {
            let ratio = f.polygon.size() / element_size;
            if ratio <= 1.0 {
                1.0
            } else {
                // each halving of the edge multiplies the count by at most 4
                4f64.powf(ratio.log2().ceil())
            }
        })
        .sum()
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
}

/// The fine mesh: every piece subdivided depth-first until its nodes' size ([`Polygon::size`])
/// drops to the element size. It does not depend on the patch method; `patch` is left unset
/// (`u32::MAX`) for the coarse mesh to fill.
pub(crate) fn fine(scene: &Scene, element_size: f64) -> (Vec<Element>, Vec<Piece>) {
    let mut elements = Vec::new();
    let mut pieces = Vec::new();
    for (polygon, f) in super::imprint::split_at_contacts(&scene.faces) {
        let surface = scene.faces[f].surface as u32;
        let first = elements.len() as u32;
        leaves(polygon, element_size, &mut |p| {
            elements.push(Element {
                polygon: p,
                face: f as u32,
                surface,
                patch: u32::MAX,
            })
        });
        pieces.push(Piece {
            polygon,
            face: f as u32,
            surface,
            first,
            count: elements.len() as u32 - first,
        });
    }
    (elements, pieces)
}

/// Calls `visit` on the leaves (elements) under `node`, depth-first.
pub(crate) fn leaves(node: Polygon, element_size: f64, visit: &mut dyn FnMut(Polygon)) {
    if node.size() <= element_size {
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
    size <= sizes.patch_size || size <= sizes.element_size
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
    if edge <= sizes.patch_size || edge <= sizes.element_size {
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
