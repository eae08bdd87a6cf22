//! Recursive subdivision of faces into the element/patch hierarchy.

use glam::DVec3;

use super::{Element, MeshSizes, Patch};
use crate::formfactor::kernel::Polygon;
use crate::scene::Scene;

/// Splits a node into children: quads 2×2 (or 1×2 along the long side when one side is at
/// least twice the other, to keep elements near square), triangles into 4 by edge midpoints.
pub fn split(p: &Polygon) -> Vec<Polygon> {
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

/// The 2MF meshes: elements where the size ([`Polygon::size`]) first drops to the element size,
/// patches where it first drops to the patch size (an element larger than the patch size is its own patch).
pub fn two_fixed(scene: &Scene, sizes: MeshSizes) -> (Vec<Element>, Vec<Patch>) {
    let mut elements = Vec::new();
    let mut patches = Vec::new();
    for (piece, f) in super::imprint::split_at_contacts(&scene.faces) {
        let surface = scene.faces[f].surface as u32;
        let ctx = Ctx {
            face: f as u32,
            surface,
            sizes,
        };
        descend(&ctx, piece, None, &mut elements, &mut patches);
    }
    (elements, patches)
}

struct Ctx {
    face: u32,
    surface: u32,
    sizes: MeshSizes,
}

fn descend(
    ctx: &Ctx,
    node: Polygon,
    mut patch: Option<u32>,
    elements: &mut Vec<Element>,
    patches: &mut Vec<Patch>,
) {
    let edge = node.size();
    let is_leaf = edge <= ctx.sizes.element_size;
    if patch.is_none() && (edge <= ctx.sizes.patch_size || is_leaf) {
        patches.push(Patch {
            polygon: node,
            face: ctx.face,
            surface: ctx.surface,
        });
        patch = Some(patches.len() as u32 - 1);
    }
    if is_leaf {
        let patch = patch.expect("set above for leaves");
        elements.push(Element {
            polygon: node,
            face: ctx.face,
            surface: ctx.surface,
            patch,
        });
        return;
    }
    for child in split(&node) {
        descend(ctx, child, patch, elements, patches);
    }
}
