//! The file's binary BVH collapsed into 4-wide nodes by dynamic programming over the binary
//! tree (after Ylitie, Karras and Laine 2017, "Efficient incoherent ray traversal on GPUs
//! through compressed wide BVHs", section 3.1): a conversion, not a build. Every slot of a
//! wide node is one binary node's box and every leaf of the file one leaf slot; the only
//! choice is which binary inner nodes become wide nodes and which are opened into their
//! children.
//!
//! The choice minimises the surface area heuristic's cost of the wide nodes, the sum of their
//! box areas (the leaves are the same in every choice, so their cost is too). Per binary node
//! `n` and `j` in 1..=4, `cost[j - 1]` is the least cost of covering `n`'s subtree with at most
//! `j` slots: `n` itself as one slot (a leaf: nothing; an inner node: a wide node, its area
//! plus its children covered by four slots), or its two children covered by `k` and `j - k`
//! slots. The wide tree is read off from the root, slots left to right (the binary order).
//!
//! On the dense scene of `lrr bench render` (212 199 binary nodes) this gives 40 121 wide
//! nodes of 3.64 slots on average, where opening the largest child until there are four
//! (the collapse before, as the bake's `visibility/flat.rs` still does) gave 50 000 of 3.1, and
//! 2.5 % fewer node visits per camera ray (26.7 against 27.4, counted at 480 × 270 with
//! packets of four; 3 % fewer per shadow ray). Leaves made of small subtrees
//! (Ylitie et al.'s leaves of several triangles) were tried: 4.7 % fewer node visits, 4.6 % more
//! triangle groups tested, and a ray touching a leaf's box within rounding then tests triangles
//! the binary traversal does not, which changed which of two tied triangles wins
//! (docs/PERFORMANCE.md, round 4).

use lrr_formats::BvhNode;

use super::{Bvh4, EMPTY_NODE, Group, LAST, LEAF, NotATree};

/// The dynamic program's table for one binary node.
#[derive(Clone, Copy, Default)]
struct Best {
    /// Least cost of covering the subtree with at most `j + 1` slots.
    cost: [f32; 4],
    /// How `j + 1` slots are used: 0 for the node itself as one slot, `k` for `k` slots to
    /// its first child and `j + 1 - k` to its second.
    split: [u8; 4],
    /// An inner node made a wide node: the slots of its four given to its first child.
    open: u8,
}

impl Bvh4 {
    /// Collapses `nodes` (the file's binary BVH: children after parents, checked by `scene.rs`:
    /// indices in bounds, at most [`MAX_BVH_DEPTH`](super::super::bvh::MAX_BVH_DEPTH) deep)
    /// over `tris` (in leaf order).
    pub(crate) fn new(nodes: &[BvhNode], tris: &[[f32; 9]]) -> Result<Self, NotATree> {
        collapse(nodes, tris)
    }
}

fn collapse(nodes: &[BvhNode], tris: &[[f32; 9]]) -> Result<Bvh4, NotATree> {
    let mut b = Collapse {
        bvh: Bvh4::default(),
        binary: nodes,
        tris,
        best: plan(nodes),
        seen: vec![false; nodes.len()],
        triangles: 0,
    };
    if nodes.is_empty() {
        return Ok(b.bvh);
    }
    b.seen[0] = true;
    if nodes[0].count > 0 {
        // A single leaf: one node whose only child is that leaf.
        b.bvh.nodes.push(EMPTY_NODE);
        b.set_slot(0, 0, 0)?;
        b.bvh.stack = 4;
    } else {
        b.push(0, 1)?;
    }
    Ok(b.bvh)
}

/// The table of every binary node, children before parents (they come after their parents:
/// `scene.rs` checks it; a damaged file whose node points back gets a wrong plan, never a
/// panic, and is refused while the tree is read off).
fn plan(nodes: &[BvhNode]) -> Vec<Best> {
    let half_area = |n: &BvhNode| {
        let d = [0, 1, 2].map(|a| (n.max[a] - n.min[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    };
    let mut best = vec![Best::default(); nodes.len()];
    for (i, n) in nodes.iter().enumerate().rev() {
        let c = n.first as usize;
        let (true, Some(&l), Some(&r)) = (n.count == 0, best.get(c), best.get(c + 1)) else {
            continue;
        };
        // The children covered by at most `j` slots, `k` of them the first child's (the
        // first least).
        let children = |j: usize| {
            (1..j)
                .map(|k| (l.cost[k - 1] + r.cost[j - k - 1], k as u8))
                .fold((f32::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
        };
        let (below, open) = children(4);
        let wide = half_area(n) + below;
        let mut b = Best {
            cost: [wide; 4],
            split: [0; 4],
            open,
        };
        for j in 2..=4 {
            let (cost, k) = children(j);
            if cost < wide {
                (b.cost[j - 1], b.split[j - 1]) = (cost, k);
            }
        }
        best[i] = b;
    }
    best
}

/// Reading the wide tree off the plan.
struct Collapse<'a> {
    bvh: Bvh4,
    binary: &'a [BvhNode],
    tris: &'a [[f32; 9]],
    best: Vec<Best>,
    /// Binary nodes already placed (a node reached twice: not a tree).
    seen: Vec<bool>,
    /// Triangles placed in groups so far.
    triangles: usize,
}

impl Collapse<'_> {
    /// Appends the wide node for the binary inner node `index` (at wide depth `depth`) and its
    /// subtree, depth first; returns its position.
    fn push(&mut self, index: usize, depth: usize) -> Result<u32, NotATree> {
        let first = self.binary[index].first as usize;
        let k = usize::from(self.best[index].open.clamp(1, 3));
        let mut slots = Vec::with_capacity(4);
        self.cover(first, k, &mut slots)?;
        self.cover(first + 1, 4 - k, &mut slots)?;
        let at = self.bvh.nodes.len();
        self.bvh.nodes.push(EMPTY_NODE);
        // A node at `depth` is popped, then pushes up to four: at most 3 · depth + 1 entries.
        self.bvh.stack = self.bvh.stack.max(3 * depth + 1);
        for (slot, &c) in slots.iter().enumerate() {
            self.set_slot(at, slot, c)?;
            if self.binary[c].count == 0 {
                self.bvh.nodes[at].child[slot] = self.push(c, depth + 1)?;
            }
        }
        Ok(at as u32)
    }

    /// Appends the binary nodes that cover `c`'s subtree with at most `j` slots to `slots`.
    fn cover(&mut self, c: usize, j: usize, slots: &mut Vec<usize>) -> Result<(), NotATree> {
        if std::mem::replace(&mut self.seen[c], true) {
            return Err(NotATree::Shared);
        }
        let k = usize::from(self.best[c].split[j - 1]);
        if k == 0 || k >= j || self.binary[c].count > 0 {
            slots.push(c);
            return Ok(());
        }
        let first = self.binary[c].first as usize;
        self.cover(first, k, slots)?;
        self.cover(first + 1, j - k, slots)
    }

    /// Writes binary node `c`'s box into slot `slot` of wide node `at`, and its triangles as
    /// groups when it is a leaf.
    fn set_slot(&mut self, at: usize, slot: usize, c: usize) -> Result<(), NotATree> {
        let n = &self.binary[c];
        for a in 0..3 {
            self.bvh.nodes[at].bounds[0][a][slot] = n.min[a];
            self.bvh.nodes[at].bounds[1][a][slot] = n.max[a];
        }
        if n.count == 0 {
            return Ok(());
        }
        let (first, count) = (n.first as usize, n.count as usize);
        self.triangles += count;
        if self.triangles > self.tris.len() || self.bvh.groups.len() >= LEAF as usize {
            return Err(NotATree::TooManyTriangles);
        }
        self.bvh.nodes[at].child[slot] = LEAF | self.bvh.groups.len() as u32;
        for start in (first..first + count).step_by(4) {
            let lanes = (first + count - start).min(4);
            let mut group = Group {
                v: [[0.0; 4]; 9],
                first: start as u32,
                info: (1 << lanes) - 1,
            };
            for lane in 0..4 {
                // Unused lanes repeat the last triangle (masked off by `info`).
                let tri = &self.tris[start + lane.min(lanes - 1)];
                for (k, v) in tri.iter().enumerate() {
                    group.v[k][lane] = *v;
                }
            }
            if start + 4 >= first + count {
                group.info |= LAST;
            }
            self.bvh.groups.push(group);
        }
        Ok(())
    }
}
