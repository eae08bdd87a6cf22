//! The file's binary BVH collapsed into 4-wide nodes by dynamic programming over the binary
//! tree (Ylitie, Karras and Laine 2017, "Efficient incoherent ray traversal on GPUs through
//! compressed wide BVHs", section 3.1): a conversion, not a build. Every slot of a wide node
//! is one binary node's box; the choice is only which binary nodes become wide nodes, which
//! become leaf slots, and which are opened into their children.
//!
//! Per binary node `n` and `j` in 1..=4, `cost[n][j - 1]` is the least SAH cost of covering
//! `n`'s subtree with at most `j` slots: `n` itself as one slot (the cheaper of a wide node,
//! `area(n) · NODE_COST` plus its children covered by four slots, and a leaf, `area(n) ·
//! GROUP_COST` per group of four triangles, for a subtree of at most [`MAX_LEAF`] triangles),
//! or its two children covered by `k` and `j - k` slots. The wide tree is then read off from
//! the root, children left to right (the binary order).
//!
//! A leaf slot made of a subtree lists its binary leaves' triangles in order, in groups of four
//! (consecutive runs of the leaf order packed together). It tests triangles whose own leaf box
//! a ray may not enter: those are hit only where the ray touches the box within rounding, the
//! case `bvh4.rs` names, so the answers stay those of the binary traversal (the tests hold them
//! to it and to brute force).

use lrr_formats::BvhNode;

use super::{Bvh4, EMPTY_NODE, Group, LAST, LEAF, NotATree};

/// Cost of visiting a wide node (per unit of half area).
const NODE_COST: f32 = 1.0;
/// Cost of testing one group of four triangles (per unit of half area).
fn group_cost() -> f32 {
    std::env::var("LRR_CG").ok().and_then(|s| s.parse().ok()).unwrap_or(1.0)
}
/// Most triangles a leaf made of a subtree holds (a file's leaf may hold more: it stays one).
fn max_leaf() -> u64 {
    std::env::var("LRR_LEAF").ok().and_then(|s| s.parse().ok()).unwrap_or(8)
}
const MAX_LEAF: u64 = 8;

/// The dynamic program's table for one binary node.
#[derive(Clone, Copy, Default)]
struct Best {
    /// Least cost with at most `j + 1` slots.
    cost: [f32; 4],
    /// How `j + 1` slots are used: 0 for the node itself as one slot, `k` for `k` slots to
    /// its first child and the rest to its second.
    split: [u8; 4],
    /// The node as one slot is a leaf (not a wide node).
    leaf: bool,
    /// Triangles in the subtree (saturating: a damaged file may share subtrees).
    tris: u64,
    /// Groups of four its triangles take as one leaf.
    groups: u64,
    /// The subtree's triangles are `first..end` of the leaf order, in order.
    run: Option<(u64, u64)>,
}

/// Collapses `nodes` over `tris` (see [`Bvh4::new`]).
pub(super) fn collapse(nodes: &[BvhNode], tris: &[[f32; 9]]) -> Result<Bvh4, NotATree> {
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
    if std::env::var("LRR_BVH4_STATS").is_ok() {
        let slots: usize = b
            .bvh
            .nodes
            .iter()
            .map(|n| n.bounds[0][0].iter().filter(|x| x.is_finite()).count())
            .sum();
        let lanes: u32 = b.bvh.groups.iter().map(|g| (g.info & 0xf).count_ones()).sum();
        eprintln!(
            "bvh4: {} binary nodes -> {} wide nodes, {:.2} slots each; {} groups, {:.2} triangles each",
            nodes.len(),
            b.bvh.nodes.len(),
            slots as f64 / b.bvh.nodes.len() as f64,
            b.bvh.groups.len(),
            lanes as f64 / b.bvh.groups.len() as f64,
        );
    }
    Ok(b.bvh)
}

/// The table of every binary node, children first (they come after their parents: `scene.rs`
/// checks it; a damaged file reading a node not yet planned gets a wrong plan, never a panic,
/// and is refused while the tree is read off).
fn plan(nodes: &[BvhNode]) -> Vec<Best> {
    let half_area = |n: &BvhNode| {
        let d = [0, 1, 2].map(|a| (n.max[a] - n.min[a]).max(0.0));
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    };
    let (group_cost, max_leaf) = (group_cost(), max_leaf().max(MAX_LEAF.min(0)));
    let mut best = vec![Best::default(); nodes.len()];
    for (i, n) in nodes.iter().enumerate().rev() {
        let area = half_area(n);
        if n.count > 0 {
            let (tris, first) = (u64::from(n.count), u64::from(n.first));
            let groups = tris.div_ceil(4);
            let cost = area * group_cost * groups as f32;
            best[i] = Best {
                cost: [cost; 4],
                split: [0; 4],
                leaf: true,
                tris,
                groups,
                run: Some((first, first + tris)),
            };
            continue;
        }
        let c = n.first as usize;
        let (Some(&l), Some(&r)) = (best.get(c), best.get(c + 1)) else {
            continue;
        };
        let tris = l.tris.saturating_add(r.tris);
        let run = match (l.run, r.run) {
            (Some((a, b)), Some((c, d))) if b == c => Some((a, d)),
            (Some((a, b)), Some((c, d))) if d == a => Some((c, b)),
            _ => None,
        };
        let groups = match run {
            Some(_) => tris.div_ceil(4),
            None => l.groups.saturating_add(r.groups),
        };
        // The children covered by `j` slots, `k` of them the first child's.
        let children = |j: usize| {
            (1..j)
                .map(|k| (l.cost[k - 1] + r.cost[j - k - 1], k as u8))
                .fold((f32::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
        };
        let wide = area * NODE_COST + children(4).0;
        let as_leaf = if tris <= max_leaf {
            area * group_cost * groups as f32
        } else {
            f32::INFINITY
        };
        let one = wide.min(as_leaf);
        let mut b = Best {
            cost: [one; 4],
            split: [0; 4],
            leaf: as_leaf <= wide,
            tris,
            groups,
            run,
        };
        for j in 2..=4 {
            let (cost, k) = children(j);
            if cost < b.cost[j - 1] {
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
        let mut slots = Vec::with_capacity(4);
        // The split of four slots between the two children, as `plan` chose it for the node.
        let k = (1..4usize)
            .map(|k| {
                let (l, r) = (&self.best[first], &self.best[first + 1]);
                (l.cost[k - 1] + r.cost[3 - k], k)
            })
            .fold((f32::INFINITY, 1), |a, b| if b.0 < a.0 { b } else { a })
            .1;
        self.cover(first, k, &mut slots)?;
        self.cover(first + 1, 4 - k, &mut slots)?;
        let at = self.bvh.nodes.len();
        self.bvh.nodes.push(EMPTY_NODE);
        // A node at `depth` is popped, then pushes up to four: at most 3 · depth + 1 entries.
        self.bvh.stack = self.bvh.stack.max(3 * depth + 1);
        for (slot, &c) in slots.iter().enumerate() {
            self.set_slot(at, slot, c)?;
            if self.binary[c].count == 0 && !self.best[c].leaf {
                self.bvh.nodes[at].child[slot] = self.push(c, depth + 1)?;
            }
        }
        Ok(at as u32)
    }

    /// Lists the binary nodes that cover `c`'s subtree with at most `j` slots.
    fn cover(&mut self, c: usize, j: usize, slots: &mut Vec<usize>) -> Result<(), NotATree> {
        self.mark(c)?;
        let k = self.best[c].split[j - 1] as usize;
        if k == 0 || self.binary[c].count > 0 {
            slots.push(c);
            return Ok(());
        }
        let first = self.binary[c].first as usize;
        self.cover(first, k, slots)?;
        self.cover(first + 1, j - k, slots)
    }

    fn mark(&mut self, c: usize) -> Result<(), NotATree> {
        if std::mem::replace(&mut self.seen[c], true) {
            return Err(NotATree::Shared);
        }
        Ok(())
    }

    /// Writes binary node `c`'s box into slot `slot` of wide node `at`, and its triangles as
    /// groups when it is a leaf slot.
    fn set_slot(&mut self, at: usize, slot: usize, c: usize) -> Result<(), NotATree> {
        let n = &self.binary[c];
        for a in 0..3 {
            self.bvh.nodes[at].bounds[0][a][slot] = n.min[a];
            self.bvh.nodes[at].bounds[1][a][slot] = n.max[a];
        }
        if n.count == 0 && !self.best[c].leaf {
            return Ok(());
        }
        // The subtree's leaves in order, consecutive runs joined.
        let mut runs: Vec<(usize, usize)> = Vec::new();
        self.leaves(c, &mut runs)?;
        runs.sort_unstable();
        runs.dedup_by(|next, run| {
            let joined = run.0 + run.1 == next.0;
            if joined {
                run.1 += next.1;
            }
            joined
        });
        self.bvh.nodes[at].child[slot] = LEAF | self.bvh.groups.len() as u32;
        for (first, count) in runs {
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
                self.bvh.groups.push(group);
            }
        }
        let last = self.bvh.groups.len() - 1;
        self.bvh.groups[last].info |= LAST;
        Ok(())
    }

    /// Appends the leaves of `c`'s subtree (`c` already marked) to `runs`, joining a leaf that
    /// continues the last run; checks the count of triangles.
    fn leaves(&mut self, c: usize, runs: &mut Vec<(usize, usize)>) -> Result<(), NotATree> {
        let n = &self.binary[c];
        if n.count == 0 {
            let first = n.first as usize;
            for child in [first, first + 1] {
                self.mark(child)?;
                self.leaves(child, runs)?;
            }
            return Ok(());
        }
        let (first, count) = (n.first as usize, n.count as usize);
        self.triangles += count;
        if self.triangles > self.tris.len() || self.bvh.groups.len() + count >= LEAF as usize {
            return Err(NotATree::TooManyTriangles);
        }
        runs.push((first, count));
        Ok(())
    }
}
