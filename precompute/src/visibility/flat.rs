//! The BVH the obvhs backend traverses: obvhs' binary BVH (PLOC, reinsertion, one triangle per
//! leaf) collapsed into a flat 4-wide BVH whose nodes hold their four child boxes as structure
//! of arrays, so that one node is four slab tests in four SIMD lanes (glam's `Vec4`, SSE on
//! x86-64, no `unsafe`), and an any-hit traversal over a small explicit stack.
//!
//! Why not obvhs' own traversal (`CwBvh::ray_traverse_miss`): its compressed wide nodes decode
//! eight quantised child boxes each, and its child test ignores the ray's `tmin` (see `obvhs.rs`);
//! a plain binary BVH (one box per node, horizontal min/max) was no faster. On the bake's rays
//! (scenes of tens to thousands of triangles, rays that start and end on surfaces) the 4-wide
//! nodes answer the same rays faster than both (docs/PERFORMANCE.md).
//!
//! The traversal only proposes candidates: a child is entered when the f32 ray meets its box
//! within `[tmin, tmax]` (and, for a child tagged with a group, when the caller says so);
//! the caller decides every candidate exactly. Culling is conservative as
//! long as the boxes are padded by more than the f32 rounding of the ray (`obvhs.rs` pads them).

use glam::{Vec3A, Vec4};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2;

/// Direction components smaller than this are replaced by it (sign kept) so that `1 / d` is
/// finite and no slab distance is `0 × ∞` (NaN): the ray turns by at most 1e-20 radians,
/// moving by under 1e-16 over the longest segment of the scaled scene, far inside the boxes'
/// padding.
const MIN_COMPONENT: f32 = 1e-20;

/// Stack entries kept on the caller's stack frame; a deeper tree (never seen: PLOC trees of
/// 10⁶ triangles are ~40 binary levels deep) gets a heap stack per query.
const INLINE_STACK: usize = 64;

/// One node of the wide BVH: up to four children, their boxes as structure of arrays
/// (`lo[axis]` holds the four children's minimum along `axis`). An unused slot has an empty
/// box (`lo = +∞`, `hi = -∞`), which no ray enters.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    /// Inner child: its node index. Leaf child: its first primitive.
    child: [u32; 4],
    /// Leaf child: its number of primitives; 0 for an inner child (and an unused slot).
    count: [u16; 4],
    /// The group (`groups`) every primitive under the child belongs to, or [`NO_GROUP`] (mixed,
    /// ungrouped, unused): [`FlatBvh::any_hit_by_group`] asks whether to enter the child.
    group: [u16; 4],
}

const _: () = assert!(size_of::<Node>() == 128);

/// A ray prepared for the slab tests: origin, inverse direction and parameter interval, each
/// splatted over the four lanes.
#[derive(Debug, Clone, Copy)]
pub(super) struct FlatRay {
    origin: [Vec4; 3],
    inv: [Vec4; 3],
    /// Per axis, whether the direction is negative (then `hi` is the near side).
    negative: [bool; 3],
    tmin: Vec4,
    tmax: Vec4,
}

impl FlatRay {
    /// The ray `origin + t · direction`, `t` in `[tmin, tmax]`.
    pub(super) fn new(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Self {
        let guard = |d: f32| {
            if d.abs() < MIN_COMPONENT {
                MIN_COMPONENT.copysign(d)
            } else {
                d
            }
        };
        let d = [guard(direction.x), guard(direction.y), guard(direction.z)];
        let o = origin.to_array();
        Self {
            origin: o.map(Vec4::splat),
            inv: d.map(|d| Vec4::splat(1.0 / d)),
            negative: d.map(|d| d < 0.0),
            tmin: Vec4::splat(tmin),
            tmax: Vec4::splat(tmax),
        }
    }

    /// Bit `i` set when the ray meets child `i`'s box within its interval.
    #[inline(always)]
    fn enters(&self, node: &Node) -> u32 {
        let mut near = self.tmin;
        let mut far = self.tmax;
        for axis in 0..3 {
            let (n, f) = if self.negative[axis] {
                (node.hi[axis], node.lo[axis])
            } else {
                (node.lo[axis], node.hi[axis])
            };
            near = near.max((n - self.origin[axis]) * self.inv[axis]);
            far = far.min((f - self.origin[axis]) * self.inv[axis]);
        }
        near.cmple(far).bitmask()
    }
}

/// The tag of a child whose primitives are not all of one group ([`FlatBvh::tag`]).
pub(super) const NO_GROUP: u16 = 0;

/// The flat 4-wide BVH over primitive boxes.
pub(super) struct FlatBvh {
    nodes: Vec<Node>,
    /// Original index of each primitive, in the order the leaves hold them.
    pub(super) order: Vec<u32>,
    /// Most nodes a traversal can have on its stack.
    depth: usize,
}

impl FlatBvh {
    /// Builds over `boxes` (one per primitive) with obvhs' PLOC builder, then collapses the
    /// binary tree into 4-wide nodes.
    pub(super) fn build(boxes: &[Aabb], mut params: BvhBuildParams) -> Self {
        // A leaf's count is a u16 (obvhs' leaves hold at most `max_prims_per_leaf`).
        params.max_prims_per_leaf = params.max_prims_per_leaf.min(u32::from(u16::MAX));
        let mut flat = Self {
            nodes: Vec::new(),
            order: Vec::with_capacity(boxes.len()),
            depth: 0,
        };
        if boxes.is_empty() {
            return flat;
        }
        let bvh = build_bvh2(boxes, params, &mut std::time::Duration::default());
        let root = &bvh.nodes[0];
        if root.prim_count > 0 {
            // A single leaf: one node whose only child is that leaf.
            flat.nodes.push(empty_node());
            flat.set_child(0, 0, &bvh, 0);
        } else {
            flat.push(&bvh, 0, 1);
        }
        flat
    }

    /// Appends the wide node for the binary inner node `index` and its subtree depth-first;
    /// returns its position.
    fn push(&mut self, bvh: &Bvh2, index: usize, depth: usize) -> usize {
        // Open the largest inner child until there are four children or only leaves.
        let first = bvh.nodes[index].first_index as usize;
        let mut children = vec![first, first + 1];
        while children.len() < 4 {
            let widest = children
                .iter()
                .enumerate()
                .filter(|(_, c)| bvh.nodes[**c].prim_count == 0)
                .max_by(|a, b| {
                    let area = |c: &usize| bvh.nodes[*c].aabb.half_area();
                    area(a.1).total_cmp(&area(b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = widest else { break };
            let c = bvh.nodes[children[i]].first_index as usize;
            children.splice(i..=i, [c, c + 1]);
        }
        let at = self.nodes.len();
        self.nodes.push(empty_node());
        // A node at `depth` is popped, then pushes up to four: at most 3 · depth + 1 entries.
        self.depth = self.depth.max(3 * depth + 1);
        for (slot, &c) in children.iter().enumerate() {
            self.set_child(at, slot, bvh, c);
            if bvh.nodes[c].prim_count == 0 {
                self.nodes[at].child[slot] = self.push(bvh, c, depth + 1) as u32;
            }
        }
        at
    }

    /// Writes binary node `c`'s box into slot `slot` of wide node `at`, and its primitives when
    /// it is a leaf.
    fn set_child(&mut self, at: usize, slot: usize, bvh: &Bvh2, c: usize) {
        let n = &bvh.nodes[c];
        let (lo, hi) = (n.aabb.min.to_array(), n.aabb.max.to_array());
        for axis in 0..3 {
            self.nodes[at].lo[axis][slot] = lo[axis];
            self.nodes[at].hi[axis][slot] = hi[axis];
        }
        if n.prim_count > 0 {
            let first = n.first_index as usize;
            let count = n.prim_count as usize;
            self.nodes[at].child[slot] = self.order.len() as u32;
            self.nodes[at].count[slot] = n.prim_count as u16;
            self.order
                .extend_from_slice(&bvh.primitive_indices[first..first + count]);
        }
    }

    /// Tags every child with the group all its primitives belong to (`group[p]` of primitive
    /// `p` in [`FlatBvh::order`]'s order, [`NO_GROUP`] for none), or [`NO_GROUP`] when they
    /// differ.
    pub(super) fn tag(&mut self, group: &[u16]) {
        if !self.nodes.is_empty() {
            self.tag_node(0, group);
        }
    }

    /// Tags node `i`'s children; returns the tag its whole subtree takes.
    fn tag_node(&mut self, i: usize, group: &[u16]) -> u16 {
        let mut all: Option<u16> = None;
        for slot in 0..4 {
            let (c, count) = (self.nodes[i].child[slot], self.nodes[i].count[slot]);
            let tag = if count > 0 {
                let first = c as usize;
                let g = group[first];
                if group[first..first + count as usize].iter().all(|&x| x == g) {
                    g
                } else {
                    NO_GROUP
                }
            } else if c != 0 {
                self.tag_node(c as usize, group) // an inner child (none points at the root)
            } else {
                continue; // an unused slot
            };
            self.nodes[i].group[slot] = tag;
            all = Some(match all {
                None => tag,
                Some(a) if a == tag => a,
                Some(_) => NO_GROUP,
            });
        }
        all.unwrap_or(NO_GROUP)
    }

    /// Offers every primitive (its index in [`FlatBvh::order`]'s order) whose leaf box the ray
    /// enters to `blocks` until `blocks` says yes; returns that primitive.
    #[inline]
    pub(super) fn any_hit(
        &self,
        ray: &FlatRay,
        blocks: impl FnMut(usize) -> bool,
    ) -> Option<usize> {
        match self.any_hit_by_group(ray, |_| Enter::Yes, blocks) {
            Hit::Primitive(p) => Some(p),
            Hit::Group | Hit::Nothing => None,
        }
    }

    /// [`any_hit`](Self::any_hit), but a child tagged with a group ([`FlatBvh::tag`]) is
    /// entered as `decide(tag)` says: [`Enter::No`] (the caller knows the ray cannot meet the
    /// group), [`Enter::Blocked`] (it knows the ray meets the group: the traversal stops) or
    /// [`Enter::Yes`].
    #[inline]
    pub(super) fn any_hit_by_group(
        &self,
        ray: &FlatRay,
        decide: impl FnMut(u16) -> Enter,
        blocks: impl FnMut(usize) -> bool,
    ) -> Hit {
        if self.nodes.is_empty() {
            return Hit::Nothing;
        }
        if self.depth <= INLINE_STACK {
            self.traverse(&mut [0; INLINE_STACK], ray, decide, blocks)
        } else {
            self.traverse(&mut vec![0; self.depth], ray, decide, blocks)
        }
    }

    /// The traversal proper (a hot loop: one node's four slab tests, then its leaves tested at
    /// once and its inner children pushed).
    #[inline(always)]
    fn traverse(
        &self,
        stack: &mut [u32],
        ray: &FlatRay,
        mut decide: impl FnMut(u16) -> Enter,
        mut blocks: impl FnMut(usize) -> bool,
    ) -> Hit {
        let mut top = 0;
        let mut i = 0;
        loop {
            let node = &self.nodes[i];
            let mut mask = ray.enters(node);
            while mask != 0 {
                let slot = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let group = node.group[slot];
                if group != NO_GROUP {
                    match decide(group) {
                        Enter::Yes => {}
                        Enter::No => continue,
                        Enter::Blocked => return Hit::Group,
                    }
                }
                let (c, count) = (node.child[slot], node.count[slot]);
                if count == 0 {
                    stack[top] = c;
                    top += 1;
                    continue;
                }
                let first = c as usize;
                for p in first..first + count as usize {
                    if blocks(p) {
                        return Hit::Primitive(p);
                    }
                }
            }
            if top == 0 {
                return Hit::Nothing;
            }
            top -= 1;
            i = stack[top] as usize;
        }
    }
}

/// Whether a traversal enters a child tagged with a group ([`FlatBvh::any_hit_by_group`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Enter {
    Yes,
    No,
    /// The ray is known to meet the group: the answer is found.
    Blocked,
}

/// What [`FlatBvh::any_hit_by_group`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Hit {
    /// A primitive `blocks` said yes to.
    Primitive(usize),
    /// A group `decide` said the ray meets.
    Group,
    Nothing,
}

/// A node with four unused slots.
fn empty_node() -> Node {
    Node {
        lo: [Vec4::INFINITY; 3],
        hi: [Vec4::NEG_INFINITY; 3],
        child: [0; 4],
        count: [0; 4],
        group: [NO_GROUP; 4],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: the primitives whose box the ray enters.
    fn entered(boxes: &[Aabb], o: Vec3A, d: Vec3A, tmax: f32) -> Vec<u32> {
        (0..boxes.len() as u32)
            .filter(|&i| {
                let b = &boxes[i as usize];
                let (mut near, mut far) = (0.0f32, tmax);
                for a in 0..3 {
                    let inv = 1.0 / d[a];
                    let (t0, t1) = ((b.min[a] - o[a]) * inv, (b.max[a] - o[a]) * inv);
                    near = near.max(t0.min(t1));
                    far = far.min(t0.max(t1));
                }
                near <= far
            })
            .collect()
    }

    #[test]
    fn traversal_offers_every_entered_box_once() {
        let mut state = 0x77_u64;
        let mut next = move || {
            state = crate::geometry::hash::mix(state);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        for count in [1, 2, 3, 5, 17, 300] {
            let boxes: Vec<Aabb> = (0..count)
                .map(|_| {
                    let c = Vec3A::new(next(), next(), next()) * 100.0;
                    let h = Vec3A::new(next(), next(), next()) * 10.0 + 0.01;
                    Aabb::new(c - h, c + h)
                })
                .collect();
            let mut bvh = FlatBvh::build(&boxes, BvhBuildParams::medium_build());
            // Every other tree traversed with the heap stack of deep trees.
            if count % 2 == 1 {
                bvh.depth = bvh.depth.max(INLINE_STACK + 1);
            }
            let mut sorted = bvh.order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..count as u32).collect::<Vec<_>>());
            for _ in 0..200 {
                let o = Vec3A::new(next(), next(), next()) * 100.0;
                let d = (Vec3A::new(next(), next(), next()) - 0.5).normalize();
                let ray = FlatRay::new(o, d, 0.0, 60.0);
                let mut offered = Vec::new();
                let none = bvh.any_hit(&ray, |p| {
                    offered.push(bvh.order[p]);
                    false
                });
                assert!(none.is_none());
                offered.sort_unstable();
                let want = entered(&boxes, o, d, 60.0);
                // Every box the ray enters is offered (the nodes' boxes hold theirs), once.
                assert!(want.iter().all(|w| offered.binary_search(w).is_ok()));
                assert!(offered.windows(2).all(|w| w[0] < w[1]), "{offered:?}");
            }
        }
    }

    /// The primitives (in `order`'s order) under slot `slot` of node `i`.
    fn under(bvh: &FlatBvh, i: usize, slot: usize, out: &mut Vec<usize>) {
        let (c, count) = (bvh.nodes[i].child[slot], bvh.nodes[i].count[slot]);
        if count > 0 {
            out.extend(c as usize..c as usize + count as usize);
        } else if c != 0 {
            for s in 0..4 {
                under(bvh, c as usize, s, out);
            }
        }
    }

    /// Every child is tagged with the group all its primitives share, or none; a traversal
    /// told a group is not to be entered offers none of its primitives, and one told the ray
    /// meets it stops.
    #[test]
    fn children_are_tagged_with_their_primitives_group() {
        // Four clusters of boxes far apart (groups 1, 2, 3 and none), then boxes of groups 1
        // and 2 mixed in a fifth cluster.
        let mut boxes = Vec::new();
        let mut of_box = Vec::new();
        for (cluster, group) in [
            (0.0, 1),
            (100.0, 2),
            (200.0, 3),
            (300.0, NO_GROUP),
            (400.0, 9),
        ] {
            for i in 0..40 {
                let c = Vec3A::new(cluster + (i % 7) as f32, (i / 7) as f32, 0.0);
                boxes.push(Aabb::new(c, c + 0.5));
                of_box.push(if group == 9 {
                    1 + (i % 2) as u16
                } else {
                    group
                });
            }
        }
        let mut bvh = FlatBvh::build(&boxes, BvhBuildParams::medium_build());
        let group: Vec<u16> = bvh.order.iter().map(|&b| of_box[b as usize]).collect();
        bvh.tag(&group);
        let mut tagged = 0;
        for i in 0..bvh.nodes.len() {
            for slot in 0..4 {
                let mut prims = Vec::new();
                under(&bvh, i, slot, &mut prims);
                let Some(&first) = prims.first() else {
                    continue;
                };
                let same = prims.iter().all(|&p| group[p] == group[first]);
                let want = if same { group[first] } else { NO_GROUP };
                assert_eq!(bvh.nodes[i].group[slot], want, "node {i} slot {slot}");
                tagged += usize::from(want != NO_GROUP);
            }
        }
        assert!(tagged > 3);
        // A ray along the row of every cluster: group 2 skipped, group 3 said to block.
        let ray = FlatRay::new(Vec3A::new(-10.0, 0.25, 0.25), Vec3A::X, 0.0, 1000.0);
        let mut offered = Vec::new();
        let hit = bvh.any_hit_by_group(
            &ray,
            |g| if g == 2 { Enter::No } else { Enter::Yes },
            |p| {
                offered.push(p);
                false
            },
        );
        assert_eq!(hit, Hit::Nothing);
        let x = |p: usize| boxes[bvh.order[p] as usize].min.x;
        assert!(
            offered.iter().all(|&p| !(100.0..150.0).contains(&x(p))),
            "group 2 skipped"
        );
        assert!(
            offered.iter().any(|&p| (300.0..350.0).contains(&x(p))),
            "ungrouped offered"
        );
        assert!(offered.iter().any(|&p| group[p] == 1) && offered.iter().any(|&p| group[p] == 3));
        let hit = bvh.any_hit_by_group(
            &ray,
            |g| if g == 3 { Enter::Blocked } else { Enter::Yes },
            |_| false,
        );
        assert_eq!(hit, Hit::Group);
    }
}
