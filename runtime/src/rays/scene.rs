//! What rays traverse, copied once from an operator file into flat arrays indexed by `u32` (the
//! buffers a WGSL twin binds): the BVH nodes as the file stores them, the display triangles in
//! the BVH's leaf order (so a leaf's triangles are one contiguous run), each with its display
//! face, and per display face its element's original id and its normal. The display faces are
//! the file's ([`OperatorFile::faces`]: section FACES, else GEOMETRY's elements, face = file
//! position).
//!
//! Everything a traversal indexes is checked here, so that no file (the file's own validation
//! included or not) can make a traversal read out of bounds or overflow its stack. The direct
//! pass's shadow rays (`lights.rs`) and the ray tracer (`trace/scene.rs` adds the materials and
//! point lights) stand on it.

use lrr_formats::{BvhNode, OperatorFile};

#[cfg(feature = "trace")]
use super::bvh::Hit;
use super::bvh::{MAX_BVH_DEPTH, Ray};
use super::bvh4::{Bvh4, NotATree};
use super::math::{V3, length, sub};
use crate::error::{RuntimeError, input};

/// The display triangles of a file and its BVH, checked.
#[derive(Debug, Clone)]
pub(crate) struct RayScene {
    /// The file's BVH nodes (node 0 the root; what the GPU twins traverse).
    #[cfg(feature = "gpu")]
    pub nodes: Vec<BvhNode>,
    /// Display triangles in leaf order (`Bvh::triangles` order): v0, v1, v2.
    pub tris: Vec<[f32; 9]>,
    /// The same tree collapsed into 4-wide nodes, what the CPU traverses.
    pub bvh4: Bvh4,
    /// Per leaf-order triangle: its display face.
    pub tri_face: Vec<u32>,
    /// Per leaf-order triangle: its display triangle id (the file's `Bvh::triangles`).
    #[cfg(feature = "trace")]
    pub tri_id: Vec<u32>,
    /// Per display face: the original id of its element (the index into a frame's radiosity).
    pub face_id: Vec<u32>,
    /// Per display face: unit normal.
    pub normals: Vec<V3>,
    /// Offset of secondary and shadow ray origins off their surface: 1e-5 of the scene's
    /// extent (f32 rounds coordinates to 6e-8 relative; the margin covers the hit distance's
    /// error too).
    pub epsilon: f32,
    /// Number of elements.
    n: usize,
}

impl RayScene {
    /// Copies and checks the display triangles and BVH of `file`; an error when it has no BVH
    /// or when a part does not fit the rest.
    pub(crate) fn new(file: &OperatorFile) -> Result<Self, RuntimeError> {
        let n = file.n as usize;
        let g = &file.geometry;
        if g.vertex_count.len() != n || g.vertices.len() != 12 * n || g.normals.len() != 3 * n {
            return Err(bad("the geometry does not have n elements"));
        }
        if file.order.len() != n || file.order.iter().any(|&id| id as usize >= n) {
            return Err(bad("the element order is not a list of n ids below n"));
        }
        let Some(bvh) = &file.display.bvh else {
            return Err(input(
                "the file has no BVH (section BVH, format 1.2), so it cannot be ray traced; \
                 re-bake the scene with this version of lrr (`lrr bake`), which stores one",
            ));
        };
        let faces = file.faces();
        let fg = faces.geometry;
        let count = faces.len();
        let shaped = fg.vertices.len() == 12 * count
            && fg.normals.len() == 3 * count
            && fg.vertex_count.iter().all(|&c| c == 3 || c == 4);
        if !shaped {
            return Err(bad(
                "the display faces are not polygons of 3 or 4 vertices with a normal each",
            ));
        }
        let face_element: Vec<u32> = match faces.elements() {
            Some(e) if e.len() != count || e.iter().any(|&p| p as usize >= n) => {
                return Err(bad("a display face names no element"));
            }
            Some(e) => e.to_vec(),
            None => (0..n as u32).collect(),
        };
        let all: Vec<(u32, [[f32; 3]; 3])> = faces.triangles().collect();
        check_bvh(&bvh.nodes, &bvh.triangles, all.len())?;
        let tris: Vec<[f32; 9]> = bvh
            .triangles
            .iter()
            .map(|&t| {
                let [a, b, c] = all[t as usize].1;
                [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]]
            })
            .collect();
        let bvh4 = Bvh4::new(&bvh.nodes, &tris).map_err(|e| {
            bad(match e {
                NotATree::Shared => "a BVH node is the child of two nodes",
                NotATree::TooManyTriangles => {
                    "the BVH's leaves list more triangles than the file has"
                }
            })
        })?;
        let tri_face: Vec<u32> = bvh.triangles.iter().map(|&t| all[t as usize].0).collect();
        let extent = bvh
            .nodes
            .first()
            .map_or(1.0, |root| length(sub(root.max, root.min)));
        Ok(RayScene {
            #[cfg(feature = "gpu")]
            nodes: bvh.nodes.clone(),
            tris,
            bvh4,
            tri_face,
            #[cfg(feature = "trace")]
            tri_id: bvh.triangles.clone(),
            face_id: face_element
                .iter()
                .map(|&e| file.order[e as usize])
                .collect(),
            normals: fg
                .normals
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]])
                .collect(),
            epsilon: 1e-5 * extent.max(f32::MIN_POSITIVE),
            n,
        })
    }

    /// The nearest triangle `ray` hits in `(t_min, t_max)`; between triangles at the same
    /// distance, the lower leaf-order index.
    #[cfg(feature = "trace")]
    #[inline(always)]
    pub(crate) fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        self.bvh4.closest_hit(ray, t_min, t_max)
    }

    /// [`RayScene::closest_hit`] of four rays at once (a packet: `bvh4/packet.rs`), the same
    /// answers.
    #[cfg(feature = "trace")]
    #[inline(always)]
    pub(crate) fn closest_hit4(
        &self,
        rays: &[Ray; 4],
        t_min: f32,
        t_max: [f32; 4],
    ) -> [Option<Hit>; 4] {
        self.bvh4.closest_hit4(rays, t_min, t_max)
    }

    /// [`RayScene::closest_hit`] of eight rays at once (a packet: `bvh4/packet8.rs`), the
    /// same answers; for CPUs where [`RayScene::packets_of_eight`].
    #[cfg(feature = "trace")]
    #[inline(always)]
    pub(crate) fn closest_hit8(
        &self,
        rays: &[Ray; 8],
        t_min: f32,
        t_max: [f32; 8],
    ) -> [Option<Hit>; 8] {
        self.bvh4.closest_hit8(rays, t_min, t_max)
    }

    /// Whether closest hits are best traced eight rays at a time on this CPU (AVX2).
    #[cfg(feature = "trace")]
    pub(crate) fn packets_of_eight(&self) -> bool {
        Bvh4::packets_of_eight()
    }

    /// [`RayScene::occluded`] of four rays at once (a packet: `bvh4/packet.rs`), the same
    /// answers.
    #[inline(always)]
    pub(crate) fn occluded4(&self, rays: &[Ray; 4], t_min: f32, t_max: [f32; 4]) -> [bool; 4] {
        self.bvh4.occluded4(rays, t_min, t_max)
    }

    /// Whether any triangle blocks `ray` in `(t_min, t_max)` (shadow rays: the first hit ends
    /// it).
    #[inline(always)]
    pub(crate) fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        self.bvh4.occluded(ray, t_min, t_max)
    }

    /// Number of elements.
    pub(crate) fn n(&self) -> usize {
        self.n
    }
}

/// The error of a file whose display data does not fit together.
pub(crate) fn bad(what: &str) -> RuntimeError {
    input(format!(
        "cannot ray trace this file: {what}; it is damaged or was written by a broken \
         writer, re-bake it"
    ))
}

/// Every index a traversal follows stays in bounds, every leaf's triangles exist, the tree
/// terminates (children after their parent) and fits the traversal stack.
fn check_bvh(nodes: &[BvhNode], triangles: &[u32], count: usize) -> Result<(), RuntimeError> {
    if triangles.len() != count || triangles.iter().any(|&t| t as usize >= count) {
        return Err(bad(
            "the BVH's triangle list does not list the display triangles",
        ));
    }
    if nodes.is_empty() {
        return if count == 0 {
            Ok(())
        } else {
            Err(bad("the BVH has no nodes"))
        };
    }
    let mut depth = vec![0usize; nodes.len()];
    for (i, node) in nodes.iter().enumerate() {
        let finite = node.min.iter().chain(&node.max).all(|c| c.is_finite());
        if !finite {
            return Err(bad(&format!("BVH node {i} has a non-finite box")));
        }
        let (first, count_) = (node.first as usize, node.count as usize);
        if count_ > 0 {
            if first
                .checked_add(count_)
                .is_none_or(|end| end > triangles.len())
            {
                return Err(bad(&format!("BVH leaf {i} lists triangles past the end")));
            }
            continue;
        }
        if first <= i || first + 1 >= nodes.len() {
            return Err(bad(&format!(
                "BVH node {i}'s children {first} and {} are not after it and in the list",
                first + 1
            )));
        }
        for c in [first, first + 1] {
            depth[c] = depth[c].max(depth[i] + 1);
            if depth[c] >= MAX_BVH_DEPTH {
                return Err(input(format!(
                    "cannot ray trace this file: its BVH is deeper than {MAX_BVH_DEPTH} levels, \
                     more than the tracer's stack holds; re-bake it with this version of lrr"
                )));
            }
        }
    }
    Ok(())
}
