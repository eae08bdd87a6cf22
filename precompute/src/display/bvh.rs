//! The BVH a renderer traces (section BVH): obvhs' PLOC binary BVH over the display triangles
//! (the fan triangulation of GEOMETRY, in the file's f32 coordinates), flattened into the
//! file's layout: depth first from the root, the two children of a node side by side after it,
//! each leaf's triangle ids contiguous. Boxes are recomputed from the f32 vertices (exact
//! minima and maxima), so they hold their triangles and children without padding.
//!
//! Deterministic: obvhs is built without its `parallel` feature, and the flattening walks the
//! tree in a fixed order, so the bytes do not depend on `--threads`.

use glam::Vec3A;
use lrr_formats::{Bvh, BvhNode, Geometry};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;

/// The build: the `medium_build` preset with `search_depth_threshold = 0` and at most 2
/// triangles per leaf, as the bake's own occlusion BVH (`visibility::obvhs`, where the stock
/// threshold traversed grid-tessellated walls about 30× slower).
const PARAMS: BvhBuildParams = BvhBuildParams {
    search_depth_threshold: 0,
    max_prims_per_leaf: 2,
    collapse_traversal_cost: 1.0,
    ..BvhBuildParams::medium_build()
};

/// Bytes [`build`] may hold at once per display triangle, planned before it starts: the
/// triangle in f32 (36 bytes) and its box (32); obvhs' PLOC build, per primitive, two arrays of
/// leaf nodes (48 each), the binary tree's two nodes (96), Morton codes and indices (24) and
/// the leaf collapse's copy of the tree (96); the file's tree (two nodes of 32 and an index:
/// 68). About 450 bytes were all of it live at once. Measured: zdm2's display (scenes/real,
/// about 10⁵ triangles) raised the resident memory by 17.9 MB over the stage, under 180 bytes
/// a triangle.
const BUILD_BYTES_PER_TRIANGLE: u128 = 512;

/// What [`build`] may take over `triangles` display triangles.
pub(crate) fn build_bytes(triangles: usize) -> u128 {
    triangles as u128 * BUILD_BYTES_PER_TRIANGLE
}

/// The BVH over `geometry`'s display triangles (empty when there are none).
pub(crate) fn build(geometry: &Geometry) -> Bvh {
    let triangles: Vec<[[f32; 3]; 3]> = geometry.triangles().map(|(_, t)| t).collect();
    if triangles.is_empty() {
        return Bvh::default();
    }
    let boxes: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let (min, max) = bounds(t.iter().copied());
            Aabb::new(Vec3A::from(min), Vec3A::from(max))
        })
        .collect();
    let tree = build_bvh2(&boxes, PARAMS, &mut std::time::Duration::default());
    let empty = BvhNode {
        min: [0.0; 3],
        max: [0.0; 3],
        first: 0,
        count: 0,
    };
    let mut bvh = Bvh {
        nodes: vec![empty],
        triangles: Vec::with_capacity(triangles.len()),
    };
    // (node of obvhs' tree, its place in ours); the first child is visited first.
    let mut stack = vec![(0usize, 0usize)];
    while let Some((from, to)) = stack.pop() {
        let node = &tree.nodes[from];
        let first = node.first_index as usize;
        if node.prim_count > 0 {
            let ids = &tree.primitive_indices[first..first + node.prim_count as usize];
            bvh.nodes[to].first = bvh.triangles.len() as u32;
            bvh.nodes[to].count = node.prim_count;
            bvh.triangles.extend_from_slice(ids);
        } else {
            let children = bvh.nodes.len();
            bvh.nodes[to].first = children as u32;
            bvh.nodes.extend([empty, empty]);
            stack.push((first + 1, children + 1));
            stack.push((first, children));
        }
    }
    // Children come after their parents: a backward pass sees every child before its parent.
    for i in (0..bvh.nodes.len()).rev() {
        let node = bvh.nodes[i];
        let first = node.first as usize;
        let (min, max) = if node.count > 0 {
            let ids = &bvh.triangles[first..first + node.count as usize];
            bounds(ids.iter().flat_map(|&t| triangles[t as usize]))
        } else {
            let (a, b) = (&bvh.nodes[first], &bvh.nodes[first + 1]);
            bounds([a.min, a.max, b.min, b.max].into_iter())
        };
        (bvh.nodes[i].min, bvh.nodes[i].max) = (min, max);
    }
    bvh
}

/// Component-wise minimum and maximum of `points`.
fn bounds(points: impl Iterator<Item = [f32; 3]>) -> ([f32; 3], [f32; 3]) {
    points.fold(
        ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                std::array::from_fn(|j| lo[j].min(p[j])),
                std::array::from_fn(|j| hi[j].max(p[j])),
            )
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` unit quads side by side along x, with a few far apart (uneven spacing).
    fn strip(count: usize) -> Geometry {
        let mut g = Geometry {
            vertex_count: Vec::new(),
            vertices: Vec::new(),
            normals: Vec::new(),
        };
        for e in 0..count {
            let x = if e % 7 == 0 {
                100.0 * e as f32
            } else {
                e as f32
            };
            g.vertex_count.push(if e % 3 == 0 { 3 } else { 4 });
            g.vertices
                .extend([x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x + 1.0, 1.0, 0.0]);
            g.vertices
                .extend(if e % 3 == 0 { [0.0; 3] } else { [x, 1.0, 0.0] });
            g.normals.extend([0.0, 0.0, 1.0]);
        }
        g
    }

    #[test]
    fn every_triangle_once_children_after_parents_boxes_exact() {
        for count in [1, 2, 5, 300] {
            let g = strip(count);
            let bvh = build(&g);
            let mut ids = bvh.triangles.clone();
            ids.sort_unstable();
            assert_eq!(ids, (0..g.triangle_count() as u32).collect::<Vec<_>>());
            let tris: Vec<_> = g.triangles().map(|(_, t)| t).collect();
            let mut covered = 0;
            for (i, n) in bvh.nodes.iter().enumerate() {
                if n.count == 0 {
                    assert!(n.first as usize > i && (n.first as usize) + 1 < bvh.nodes.len());
                } else {
                    assert!(n.count <= 2);
                    covered += n.count as usize;
                    for &t in &bvh.triangles[n.first as usize..(n.first + n.count) as usize] {
                        for v in tris[t as usize] {
                            assert!((0..3).all(|j| n.min[j] <= v[j] && v[j] <= n.max[j]));
                        }
                    }
                }
            }
            assert_eq!(covered, tris.len());
            // The root's box is the triangles' bounds exactly.
            let (lo, hi) = bounds(tris.iter().flatten().copied());
            assert_eq!((bvh.nodes[0].min, bvh.nodes[0].max), (lo, hi));
        }
        assert_eq!(build(&strip(0)), Bvh::default());
    }

    #[test]
    fn the_same_bytes_on_any_thread_count() {
        let g = strip(2000);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| build(&g));
        let four = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap()
            .install(|| build(&g));
        assert_eq!(one, four);
    }
}
