//! Section BVH (format 1.2): the flattened binary BVH over the display triangles; byte encoding
//! (tabled in the crate docs), decoding and invariants, checked in O(nodes + triangles).

use crate::bytes::{self, u32_at, vec3_at};
use crate::display::{Bvh, BvhNode};
use crate::error::FormatError;
use crate::file::OperatorFile;

/// Bytes per node: min, first; max, count.
const NODE_LEN: usize = 32;

/// How far outside its box a triangle's vertex (or a child's box) may lie, relative to the
/// largest coordinate magnitude of the geometry: f32 rounding of a box computed in another
/// precision, nothing more.
pub(crate) const BOX_TOLERANCE: f32 = 4.0 * f32::EPSILON;

fn vec3(v: &[f32]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

/// Encodes `bvh` (validated).
pub(crate) fn encode(bvh: &Bvh) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 + NODE_LEN * bvh.nodes.len() + 4 * bvh.triangles.len());
    bytes::put_u32s(
        &mut out,
        &[bvh.nodes.len() as u32, bvh.triangles.len() as u32],
    );
    for node in &bvh.nodes {
        bytes::put_f32s(&mut out, &node.min);
        bytes::put_u32s(&mut out, &[node.first]);
        bytes::put_f32s(&mut out, &node.max);
        bytes::put_u32s(&mut out, &[node.count]);
    }
    bytes::put_u32s(&mut out, &bvh.triangles);
    out
}

/// Decodes the payload; lengths are checked, values are not.
pub(crate) fn decode(payload: &[u8]) -> Result<Bvh, FormatError> {
    let corrupt = |m: String| FormatError::corrupt(format!("section BVH (kind 17): {m}"));
    let (nodes, triangles) = match (u32_at(payload, 0), u32_at(payload, 4)) {
        (Some(n), Some(t)) => (n as u64, t as u64),
        _ => {
            return Err(corrupt(format!(
                "{} bytes, too short for the two counts",
                payload.len()
            )));
        }
    };
    // At most 8 + 32 * 2^32 + 4 * 2^32: no overflow in u64.
    let expected = 8 + NODE_LEN as u64 * nodes + 4 * triangles;
    if expected != payload.len() as u64 {
        return Err(corrupt(format!(
            "expected {expected} bytes (8 + {nodes} nodes of {NODE_LEN} bytes + {triangles} \
             triangle ids of 4 bytes), found {}",
            payload.len()
        )));
    }
    let nodes_end = 8 + NODE_LEN * nodes as usize;
    Ok(Bvh {
        nodes: payload[8..nodes_end]
            .chunks_exact(NODE_LEN)
            .map(|r| BvhNode {
                min: vec3_at(r, 0),
                first: u32_at(r, 12).unwrap_or_default(),
                max: vec3_at(r, 16),
                count: u32_at(r, 28).unwrap_or_default(),
            })
            .collect(),
        triangles: bytes::u32s(&payload[nodes_end..]),
    })
}

/// The invariants of [`Bvh`] against the file's display triangles: a tree whose children come
/// after their parents, leaves that share out the triangle list, every triangle exactly once,
/// and boxes that hold their triangles and children. The display faces (GEOMETRY, or FACES)
/// have been checked before.
pub(crate) fn check(f: &OperatorFile, bvh: &Bvh) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section BVH: {m}")));
    let faces = f.faces();
    let g = faces.geometry;
    let count = faces.triangle_count();
    if bvh.triangles.len() != count {
        let source = if faces.is_separate() {
            "FACES"
        } else {
            "GEOMETRY"
        };
        return fail(format!(
            "{} triangle ids, but {source} has {count} display triangles",
            bvh.triangles.len()
        ));
    }
    let mut seen = vec![false; count];
    for (i, &t) in bvh.triangles.iter().enumerate() {
        match seen.get_mut(t as usize) {
            None => return fail(format!("triangles[{i}] = {t} is not below {count}")),
            Some(true) => return fail(format!("triangles[{i}] repeats triangle {t}")),
            Some(slot) => *slot = true,
        }
    }
    let nodes = bvh.nodes.len();
    if nodes == 0 {
        return fail("no nodes: the root is needed".into());
    }
    // Per triangle slot: which leaf holds it; per node: its parent.
    let mut slot_leaf = vec![u32::MAX; count];
    let mut parent = vec![u32::MAX; nodes];
    let scale = g.vertices.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let slack = BOX_TOLERANCE * scale;
    // Per triangle id: face `e` and fan index `i` as `e << 2 | i` (8 bytes, not the 36 of its
    // vertices: the decoder's memory stays within a small multiple of the input).
    let fan: Vec<u64> = (g.vertex_count.iter().enumerate())
        .flat_map(|(e, &c)| {
            (1..usize::from(c).saturating_sub(1)).map(move |i| (e as u64) << 2 | i as u64)
        })
        .collect();
    let vertex = |e: usize, j: usize| vec3(&g.vertices[e * 12 + j * 3..]);
    // Boxes first: a parent compares its children's boxes with its own.
    for (i, node) in bvh.nodes.iter().enumerate() {
        if let Some(j) = (0..3).find(|&j| {
            !(node.min[j].is_finite() && node.max[j].is_finite() && node.min[j] <= node.max[j])
        }) {
            return fail(format!(
                "node {i}: box axis {j}: [{}, {}] must be finite with min <= max",
                node.min[j], node.max[j]
            ));
        }
    }
    for (i, node) in bvh.nodes.iter().enumerate() {
        let fail = |m: String| fail(format!("node {i}: {m}"));
        let inside = |p: [f32; 3]| {
            (0..3).all(|j| p[j] >= node.min[j] - slack && p[j] <= node.max[j] + slack)
        };
        if node.count == 0 {
            let first = node.first as usize;
            if first <= i || first + 1 >= nodes {
                return fail(format!(
                    "children {first} and {} must come after this node and below {nodes} nodes",
                    first + 1
                ));
            }
            for child in [first, first + 1] {
                if parent[child] != u32::MAX {
                    return fail(format!(
                        "child {child} is also a child of node {}: the nodes must form a tree",
                        parent[child]
                    ));
                }
                parent[child] = i as u32;
                let c = &bvh.nodes[child];
                if !(inside(c.min) && inside(c.max)) {
                    return fail(format!(
                        "the box [{:?}, {:?}] does not hold child {child}'s [{:?}, {:?}]",
                        node.min, node.max, c.min, c.max
                    ));
                }
            }
        } else {
            let range = (node.first as usize)
                .checked_add(node.count as usize)
                .filter(|&end| end <= count)
                .map(|end| node.first as usize..end);
            let Some(range) = range else {
                return fail(format!(
                    "leaf of {} triangles from {} runs past the {count} triangle ids",
                    node.count, node.first
                ));
            };
            for s in range {
                if slot_leaf[s] != u32::MAX {
                    return fail(format!(
                        "triangles[{s}] is also in leaf {}: leaves must not overlap",
                        slot_leaf[s]
                    ));
                }
                slot_leaf[s] = i as u32;
                let t = bvh.triangles[s];
                let (e, i) = (
                    (fan[t as usize] >> 2) as usize,
                    (fan[t as usize] & 3) as usize,
                );
                let corners = [vertex(e, 0), vertex(e, i), vertex(e, i + 1)];
                if let Some(v) = corners.iter().find(|&&v| !inside(v)) {
                    return fail(format!(
                        "the box [{:?}, {:?}] does not hold triangle {t}'s vertex {v:?}",
                        node.min, node.max
                    ));
                }
            }
        }
    }
    // Children come after parents and have one parent each, so walking up from any node
    // ends at a node without a parent: it must be the root, or the nodes form several trees.
    if let Some(orphan) = (1..nodes).find(|&i| parent[i] == u32::MAX) {
        return fail(format!(
            "node {orphan} is no node's child: every node but the root 0 must be in the tree"
        ));
    }
    if let Some(s) = slot_leaf.iter().position(|&l| l == u32::MAX) {
        return fail(format!(
            "triangles[{s}] (triangle {}) is in no leaf: the leaves must cover every triangle",
            bvh.triangles[s]
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata::display_sample;

    #[test]
    fn encoding_is_as_documented() {
        let f = display_sample();
        let bvh = f.display.bvh.as_ref().unwrap();
        let bytes = encode(bvh);
        assert_eq!(bytes.len(), 8 + 32 * 5 + 4 * 9);
        assert_eq!(u32_at(&bytes, 0), Some(5));
        assert_eq!(u32_at(&bytes, 4), Some(9));
        assert_eq!(vec3_at(&bytes, 8 + 32 + 16), bvh.nodes[1].max);
        assert_eq!(u32_at(&bytes, 8 + 32 + 28), Some(bvh.nodes[1].count));
        assert_eq!(u32_at(&bytes, 8 + 160), Some(bvh.triangles[0]));
        assert_eq!(&decode(&bytes).unwrap(), bvh);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let f = display_sample();
        let good = encode(f.display.bvh.as_ref().unwrap());
        for len in 0..good.len() {
            assert!(decode(&good[..len]).is_err(), "prefix {len}");
        }
        for at in [0, 4] {
            let mut huge = good.clone();
            huge[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
            let e = decode(&huge).unwrap_err();
            assert!(e.message.contains("expected"), "{e}");
        }
    }

    #[test]
    fn invariants_name_node_and_problem() {
        type Edit = fn(&mut Bvh);
        let cases: [(Edit, &str); 14] = [
            (
                |b| b.triangles.truncate(8),
                "8 triangle ids, but GEOMETRY has 9",
            ),
            (|b| b.triangles[3] = 9, "triangles[3] = 9 is not below 9"),
            (
                |b| b.triangles[3] = b.triangles[0],
                "triangles[3] repeats triangle",
            ),
            (|b| b.nodes.clear(), "no nodes"),
            (|b| b.nodes[3].min[0] = f32::NAN, "node 3: box axis 0: [NaN"),
            (|b| b.nodes[3].max[1] = -1.0, "node 3: box axis 1"),
            (
                |b| b.nodes[2].first = 1,
                "node 2: children 1 and 2 must come after",
            ),
            (
                |b| b.nodes[2].first = 4,
                "node 2: children 4 and 5 must come after",
            ),
            (
                |b| b.nodes[0].max[0] = 5.0,
                "node 0: the box [[0.0, 0.0, 0.0], [5.0, 1.0, 0.0]] does not hold child 2",
            ),
            (
                |b| b.nodes[4].min[0] = 4.5,
                "node 4: the box [[4.5, 0.0, 0.0], [6.0, 1.0, 0.0]] does not hold triangle",
            ),
            (
                |b| {
                    b.nodes[3].count = 2;
                    b.nodes[3].max[0] = 6.0;
                },
                "node 4: triangles[6] is also in leaf 3",
            ),
            (
                |b| b.nodes[4].count = 4,
                "node 4: leaf of 4 triangles from 6 runs past",
            ),
            (
                |b| b.nodes[3].count = 0,
                "node 3: children 5 and 6 must come after this node and below 5",
            ),
            (
                |b| {
                    // Node 2 a leaf of triangles[4]: nodes 3 and 4 are nobody's children.
                    b.nodes[1].count = 4;
                    b.nodes[2] = BvhNode {
                        first: 4,
                        count: 1,
                        ..b.nodes[0]
                    };
                },
                "node 3 is no node's child",
            ),
        ];
        for (edit, expected) in cases {
            let mut f = display_sample();
            edit(f.display.bvh.as_mut().unwrap());
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with("section BVH: "),
                "{e} (expected {expected:?})"
            );
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
        }
    }

    #[test]
    fn uncovered_and_shared_children_are_refused() {
        let mut f = display_sample();
        let b = f.display.bvh.as_mut().unwrap();
        // Leaf 4 gives up its last triangle: triangles[8] lies in no leaf.
        b.nodes[4].count = 2;
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .contains("triangles[8] (triangle 8) is in no leaf"),
            "{e}"
        );
        // Two interior nodes claiming the same children.
        let mut f = display_sample();
        let b = f.display.bvh.as_mut().unwrap();
        b.nodes.push(b.nodes[2]);
        b.nodes[1] = BvhNode {
            first: 3,
            count: 0,
            ..b.nodes[0]
        };
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .contains("node 2: child 3 is also a child of node 1"),
            "{e}"
        );
    }
}
