//! The 4-wide BVH the CPU traverses (the direct pass's shadow rays, the tracer's rays): the
//! file's binary BVH collapsed at load into nodes of four children (a conversion, not a build:
//! the same leaves, the same triangles in each), child boxes and leaf triangles stored as
//! structure of arrays in `[f32; 4]` lanes, so that one node is four slab tests and one group of
//! triangles four watertight tests, in plain safe code the compiler turns into SSE (the
//! workspace builds for generic x86-64: no AVX2 at compile time; docs/PERFORMANCE.md has the
//! measurements).
//!
//! - Nodes: per axis the four children's minima and maxima (`bounds[0][axis]`,
//!   `bounds[1][axis]`, 128 bytes a node). The traversal is monomorphised on the ray's octant
//!   (and, for the triangle test, its dominant axis), so the near and far side of each axis are
//!   fixed fields: a slab test is a subtraction and a product per side, with no `min`/`max`
//!   between the two sides (the same values as `bvh.rs`'s `enter`, which takes the `min`/`max`
//!   of both: the near side of a valid box is never the far one). Unused slots hold an empty
//!   box (`+∞` minima, `−∞` maxima) that no ray enters.
//! - Collapse (`bvh4/collapse.rs`): which binary inner nodes become wide nodes and which are
//!   opened into their children is chosen by dynamic programming over the binary tree, the
//!   least SAH cost of the wide nodes (Ylitie et al. 2017; before: open the child with the
//!   largest box until there are four, as the bake's `visibility/flat.rs` does, which left
//!   nodes of 3.1 children against 3.64 now on the dense scene). Every leaf of the file becomes
//!   one leaf slot of a wide node. A node reached twice (not a tree) or leaves listing more
//!   triangles than the file has are refused, so that a damaged file cannot make the
//!   conversion blow up.
//! - Leaves: each leaf's triangles (a contiguous run of the leaf order) in groups of four lanes
//!   (a leaf of 1–4 triangles is one group; unused lanes repeat the last triangle and are
//!   masked off), the 9 coordinates as lanes, tested with the watertight test of `bvh.rs`
//!   operation for operation (the same f32 rounding, the same f64 fallback on a zero edge
//!   function), so a triangle's distance is bit for bit the one `bvh.rs`'s `triangle` returns;
//!   only the accept tests are regrouped (exactly: see `triangles`) so that each is one
//!   comparison.
//! - Closest hit: a fixed stack of (child, entry distance); the children a ray enters are
//!   visited nearest first (the farther ones pushed, farthest first), a popped entry skipped
//!   when it starts beyond the best hit. The answer is the triangle of least distance, ties
//!   between equal distances broken by the lower leaf-order index, which does not depend on
//!   the visiting order (`trace.wgsl`'s binary traversal breaks ties the same way).
//! - Any hit (shadow rays): children in slot order, leaves tested at once, the first hit ends
//!   it.
//! - Packets (`bvh4/packet.rs`, `bvh4/packet8.rs`): four or eight neighbouring rays through
//!   the same nodes, a ray per lane, each with this file's single-ray answers. Eight for closest
//!   hits where the CPU has AVX2: the portable code compiled a second time for it and chosen at
//!   run time (one `unsafe` call; without AVX2 the eight lanes take two SSE registers and
//!   measured no faster than four, so packets of four are used there).
//!
//! Exactness: the boxes of a tree hold their children's, and the slab test is monotone in the
//! box (a ray that enters a box enters every box holding it), so a traversal tests the
//! triangles of the leaves whose own box the ray enters, the same in the binary traversal of the
//! same file: any-hit answers are the same booleans, and a closest hit is the same triangle at
//! the same distance (the tests hold both traversals and brute force to it). The one exception
//! left is shared by every traversal order: a triangle hit at a distance within rounding of its
//! box's entry distance, behind a hit found first at a distance in between.
//!
//! Vectorisation: LLVM's SLP vectoriser turns the lane-wise helpers below into `subps`,
//! `mulps`, `minps`, `maxps`, `cmpps` and `movmskps`, but only when each bit mask comes from one
//! comparison and a reduction runs as a chain from a splat (`min(min(min(t_max, x), y), z)`):
//! several comparisons combined lane by lane, or `min(x, min(y, z))`, are scalarised or
//! interleaved across axes (checked in the assembly; `lrr bench render` measures the result).

#[cfg(feature = "trace")]
use super::bvh::Hit;
use super::bvh::{FAR_SCALE, MAX_BVH_DEPTH, Ray};

mod collapse;
mod packet;
#[cfg(feature = "trace")]
mod packet8;

/// Four lanes.
type F4 = [f32; 4];

/// A child slot holding a leaf: its first triangle group, this bit set.
const LEAF: u32 = 1 << 31;
/// `Group::info`: the group ends its leaf.
const LAST: u32 = 1 << 8;
/// Stack entries kept on the caller's stack frame; a deeper tree gets a heap stack per query
/// (the tests' trees use both).
const INLINE_STACK: usize = if cfg!(test) { 16 } else { 64 };

#[inline(always)]
fn splat(x: f32) -> F4 {
    [x; 4]
}

#[inline(always)]
fn sub(a: F4, b: F4) -> F4 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]
}

#[inline(always)]
fn add(a: F4, b: F4) -> F4 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

#[inline(always)]
fn mul(a: F4, b: F4) -> F4 {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2], a[3] * b[3]]
}

#[inline(always)]
fn div(a: F4, b: F4) -> F4 {
    [a[0] / b[0], a[1] / b[1], a[2] / b[2], a[3] / b[3]]
}

/// Lane-wise `if a > b { a } else { b }` (`maxps`; `f32::max`'s NaN rule would cost more).
#[inline(always)]
fn hi(a: F4, b: F4) -> F4 {
    let m = |a: f32, b: f32| if a > b { a } else { b };
    [m(a[0], b[0]), m(a[1], b[1]), m(a[2], b[2]), m(a[3], b[3])]
}

/// Lane-wise `if a < b { a } else { b }` (`minps`).
#[inline(always)]
fn lo(a: F4, b: F4) -> F4 {
    let m = |a: f32, b: f32| if a < b { a } else { b };
    [m(a[0], b[0]), m(a[1], b[1]), m(a[2], b[2]), m(a[3], b[3])]
}

#[inline(always)]
fn neg(a: F4) -> F4 {
    [-a[0], -a[1], -a[2], -a[3]]
}

/// Lane-wise `if a >= b { x } else { y }`.
#[inline(always)]
fn select_ge(a: F4, b: F4, x: F4, y: F4) -> F4 {
    let s = |i: usize| if a[i] >= b[i] { x[i] } else { y[i] };
    [s(0), s(1), s(2), s(3)]
}

/// Bit `i` set where `f(a[i], b[i])`: one comparison and `movmskps` (combining several
/// comparisons lane by lane defeats the vectoriser, so each test is one comparison).
#[inline(always)]
fn bits(a: F4, b: F4, f: impl Fn(f32, f32) -> bool) -> u32 {
    (f(a[0], b[0]) as u32)
        | ((f(a[1], b[1]) as u32) << 1)
        | ((f(a[2], b[2]) as u32) << 2)
        | ((f(a[3], b[3]) as u32) << 3)
}

/// One wide node (two cache lines).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    /// `bounds[0][axis]`: the four children's minima along `axis`; `bounds[1]`: maxima.
    bounds: [[F4; 3]; 2],
    /// Per slot: an inner child's node index, or [`LEAF`] | the leaf's first group.
    child: [u32; 4],
}

const EMPTY_NODE: Node = Node {
    bounds: [[[f32::INFINITY; 4]; 3], [[f32::NEG_INFINITY; 4]; 3]],
    child: [0; 4],
};

/// Up to four triangles of one leaf.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
struct Group {
    /// `v[3 k + axis]`: vertex `k`'s coordinate along `axis`, one triangle per lane.
    v: [F4; 9],
    /// Leaf-order index of lane 0's triangle (lane `i` holds `first + i`).
    first: u32,
    /// The lanes in use as a bit mask (low 4 bits), and [`LAST`] on a leaf's last group.
    info: u32,
}

/// The ray as the slab tests of a node read it: origin and reciprocal direction in four lanes.
struct BoxRay {
    origin: [F4; 3],
    inv: [F4; 3],
}

impl BoxRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        BoxRay {
            origin: ray.origin.map(splat),
            inv: ray.inv.map(splat),
        }
    }

    /// The entry distance into each child's box within `(0, t_max)`, and the children entered
    /// as a bit mask. `OCT` has bit `a` set when the ray's direction is negative along axis `a`
    /// (so the maxima are the near side): the values of `bvh.rs`'s `enter`, which takes the
    /// `min` and `max` of both sides, in the same order, four lanes wide.
    #[inline(always)]
    fn enter<const OCT: usize>(&self, node: &Node, t_max: f32) -> (F4, u32) {
        let side = |a: usize| (OCT >> a) & 1;
        let slab = |a: usize, s: usize| mul(sub(node.bounds[s][a], self.origin[a]), self.inv[a]);
        let near = hi(
            hi(hi(splat(0.0), slab(0, side(0))), slab(1, side(1))),
            slab(2, side(2)),
        );
        // The far side in `enter`'s order, each axis scaled (scaled once after a minimum of the
        // three, the same value, the vectoriser interleaves the axes' lanes: measured slower).
        let scaled = |a: usize| mul(slab(a, side(a) ^ 1), splat(FAR_SCALE));
        let far = lo(lo(lo(splat(t_max), scaled(0)), scaled(1)), scaled(2));
        (near, bits(near, far, |n, f| n <= f))
    }
}

/// The watertight test of `ray` against the four triangles of `g` (`bvh.rs`'s `triangle`,
/// operation for operation): each lane's distance, and the lanes hit in `(t_min, t_max)`.
#[inline(always)]
fn triangles<const KZ: usize>(ray: &Ray, g: &Group, t_min: f32, t_max: f32) -> (F4, u32) {
    let (kx, ky, kz) = ((KZ + 1) % 3, (KZ + 2) % 3, KZ);
    let o = ray.origin;
    let rel = |k: usize, axis: usize| sub(g.v[3 * k + axis], splat(o[axis]));
    let [sx, sy, sz] = ray.shear.map(splat);
    let (az, bz, cz) = (rel(0, kz), rel(1, kz), rel(2, kz));
    let ax = sub(rel(0, kx), mul(sx, az));
    let ay = sub(rel(0, ky), mul(sy, az));
    let bx = sub(rel(1, kx), mul(sx, bz));
    let by = sub(rel(1, ky), mul(sy, bz));
    let cx = sub(rel(2, kx), mul(sx, cz));
    let cy = sub(rel(2, ky), mul(sy, cz));
    let mut u = sub(mul(cx, by), mul(cy, bx));
    let mut v = sub(mul(ax, cy), mul(ay, cx));
    let mut w = sub(mul(bx, ay), mul(by, ax));
    let zero = splat(0.0);
    // A lane with an edge function exactly zero has `(u v w)² = 0` or NaN (so do a few more,
    // rounded to zero): then every lane is checked exactly.
    let p = mul(mul(u, v), w);
    // Not `>` (NaN included), one comparison (`cmpnltps`).
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let unclean = |p: f32, z: f32| !(p > z);
    if bits(mul(p, p), zero, unclean) != 0 {
        [u, v, w] = on_edge([ax, ay, bx, by, cx, cy], [u, v, w]);
    }
    // Signs all alike (zeros allowed): `min ≥ 0` or `max ≤ 0`, i.e. `max(min, -max) ≥ 0`. A NaN
    // makes `det` and `t` NaN, which the distance test rejects.
    let signs = hi(lo(lo(u, v), w), neg(hi(hi(u, v), w)));
    let det = add(add(u, v), w);
    let t_scaled = add(
        add(mul(u, mul(sz, az)), mul(v, mul(sz, bz))),
        mul(w, mul(sz, cz)),
    );
    let t = div(t_scaled, det);
    // `t_min < t < t_max` as `min(t - t_min, t_max - t) > 0` (a difference of floats is zero
    // only between equals and has their order's sign; a NaN or infinite `t`, which `det = 0`
    // gives, fails), and `-1` in place of it where the signs differ: one comparison (several
    // combined lane by lane defeat the vectoriser). `det = 0` needs no test of its own.
    let gate = select_ge(signs, zero, splat(f32::INFINITY), splat(-1.0));
    let inside = lo(gate, lo(sub(t, splat(t_min)), sub(splat(t_max), t)));
    (t, bits(inside, zero, |d, z| d > z) & g.info & 0xf)
}

/// The f64 edge functions of `bvh.rs` in the lanes with an edge function exactly zero in f32.
#[cold]
#[inline(never)]
fn on_edge([ax, ay, bx, by, cx, cy]: [F4; 6], [mut u, mut v, mut w]: [F4; 3]) -> [F4; 3] {
    for i in 0..4 {
        if u[i] != 0.0 && v[i] != 0.0 && w[i] != 0.0 {
            continue;
        }
        let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
        u[i] = f(cx[i], by[i], cy[i], bx[i]);
        v[i] = f(ax[i], cy[i], ay[i], cx[i]);
        w[i] = f(bx[i], ay[i], by[i], ax[i]);
    }
    [u, v, w]
}

/// The file's BVH as 4-wide nodes over triangle groups.
#[derive(Debug, Clone, Default)]
pub(crate) struct Bvh4 {
    /// Node 0 is the root; empty when the file has no triangles.
    nodes: Vec<Node>,
    groups: Vec<Group>,
    /// Most entries a traversal's stack can hold.
    stack: usize,
}

/// Why a file's BVH cannot be collapsed (a damaged file: `scene.rs` words the error).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotATree {
    /// A node is the child of two nodes.
    Shared,
    /// The leaves list more triangles than there are.
    TooManyTriangles,
}

impl Bvh4 {
    /// The nearest triangle `ray` hits in `(t_min, t_max)` (ties: the lower leaf-order index).
    #[cfg(feature = "trace")]
    #[inline]
    pub(crate) fn closest_hit(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let (mut inline, mut heap);
        let stack: &mut [(u32, f32)] = if self.stack <= INLINE_STACK {
            inline = [(0u32, 0.0f32); INLINE_STACK];
            &mut inline
        } else {
            heap = vec![(0u32, 0.0f32); self.stack];
            &mut heap
        };
        match ray.kz {
            0 => self.closest_kz::<0>(stack, ray, t_min, t_max),
            1 => self.closest_kz::<1>(stack, ray, t_min, t_max),
            _ => self.closest_kz::<2>(stack, ray, t_min, t_max),
        }
    }

    /// [`Bvh4::closest_hit`] dispatched on the ray's octant.
    #[cfg(feature = "trace")]
    #[inline(always)]
    fn closest_kz<const KZ: usize>(
        &self,
        stack: &mut [(u32, f32)],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        match octant(ray) {
            0 => self.closest::<KZ, 0>(stack, ray, t_min, t_max),
            1 => self.closest::<KZ, 1>(stack, ray, t_min, t_max),
            2 => self.closest::<KZ, 2>(stack, ray, t_min, t_max),
            3 => self.closest::<KZ, 3>(stack, ray, t_min, t_max),
            4 => self.closest::<KZ, 4>(stack, ray, t_min, t_max),
            5 => self.closest::<KZ, 5>(stack, ray, t_min, t_max),
            6 => self.closest::<KZ, 6>(stack, ray, t_min, t_max),
            _ => self.closest::<KZ, 7>(stack, ray, t_min, t_max),
        }
    }

    /// Whether any triangle blocks `ray` in `(t_min, t_max)`.
    #[inline]
    pub(crate) fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let (mut inline, mut heap);
        let stack: &mut [u32] = if self.stack <= INLINE_STACK {
            inline = [0u32; INLINE_STACK];
            &mut inline
        } else {
            heap = vec![0u32; self.stack];
            &mut heap
        };
        match ray.kz {
            0 => self.any_kz::<0>(stack, ray, t_min, t_max),
            1 => self.any_kz::<1>(stack, ray, t_min, t_max),
            _ => self.any_kz::<2>(stack, ray, t_min, t_max),
        }
    }

    /// [`Bvh4::occluded`] dispatched on the ray's octant.
    #[inline(always)]
    fn any_kz<const KZ: usize>(
        &self,
        stack: &mut [u32],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        match octant(ray) {
            0 => self.any::<KZ, 0>(stack, ray, t_min, t_max),
            1 => self.any::<KZ, 1>(stack, ray, t_min, t_max),
            2 => self.any::<KZ, 2>(stack, ray, t_min, t_max),
            3 => self.any::<KZ, 3>(stack, ray, t_min, t_max),
            4 => self.any::<KZ, 4>(stack, ray, t_min, t_max),
            5 => self.any::<KZ, 5>(stack, ray, t_min, t_max),
            6 => self.any::<KZ, 6>(stack, ray, t_min, t_max),
            _ => self.any::<KZ, 7>(stack, ray, t_min, t_max),
        }
    }

    /// [`Bvh4::closest_hit`] for rays whose dominant axis is `KZ`, in octant `OCT`.
    #[cfg(feature = "trace")]
    fn closest<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [(u32, f32)],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        let boxes = BoxRay::new(ray);
        let (mut best_t, mut best_tri) = (t_max, u32::MAX);
        let mut sp = 0usize;
        let mut at = 0u32;
        loop {
            if at & LEAF == 0 {
                let node = &self.nodes[at as usize];
                let (near, mut mask) = boxes.enter::<OCT>(node, best_t);
                if mask != 0 {
                    // The nearest child is next, the others pushed farthest first.
                    let entry = |i: u32| (node.child[i as usize], near[i as usize]);
                    let mut a = entry(mask.trailing_zeros());
                    mask &= mask - 1;
                    if mask == 0 {
                        at = a.0;
                        continue;
                    }
                    let mut b = entry(mask.trailing_zeros());
                    mask &= mask - 1;
                    if b.1 < a.1 {
                        (a, b) = (b, a);
                    }
                    if mask == 0 {
                        stack[sp] = b;
                        sp += 1;
                        at = a.0;
                        continue;
                    }
                    let mut c = entry(mask.trailing_zeros());
                    mask &= mask - 1;
                    if c.1 < b.1 {
                        (b, c) = (c, b);
                        if b.1 < a.1 {
                            (a, b) = (b, a);
                        }
                    }
                    if mask == 0 {
                        stack[sp] = c;
                        stack[sp + 1] = b;
                        sp += 2;
                        at = a.0;
                        continue;
                    }
                    let mut d = entry(mask.trailing_zeros());
                    if d.1 < c.1 {
                        (c, d) = (d, c);
                        if c.1 < b.1 {
                            (b, c) = (c, b);
                            if b.1 < a.1 {
                                (a, b) = (b, a);
                            }
                        }
                    }
                    stack[sp] = d;
                    stack[sp + 1] = c;
                    stack[sp + 2] = b;
                    sp += 3;
                    at = a.0;
                    continue;
                }
            } else {
                let mut g = (at & !LEAF) as usize;
                loop {
                    let group = &self.groups[g];
                    let (t, mut hit) = triangles::<KZ>(ray, group, t_min, t_max);
                    while hit != 0 {
                        let i = hit.trailing_zeros();
                        hit &= hit - 1;
                        let tri = group.first + i;
                        let t = t[i as usize];
                        if t < best_t || (t == best_t && tri < best_tri) {
                            (best_t, best_tri) = (t, tri);
                        }
                    }
                    if group.info & LAST != 0 {
                        break;
                    }
                    g += 1;
                }
            }
            // Pop the next entry not beyond the best hit.
            loop {
                if sp == 0 {
                    return (best_tri != u32::MAX).then_some(Hit {
                        t: best_t,
                        tri: best_tri,
                    });
                }
                sp -= 1;
                let (next, t_enter) = stack[sp];
                if t_enter <= best_t {
                    at = next;
                    break;
                }
            }
        }
    }

    /// [`Bvh4::occluded`] for rays whose dominant axis is `KZ`, in octant `OCT`.
    fn any<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [u32],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        let boxes = BoxRay::new(ray);
        let mut sp = 0usize;
        let mut at = 0usize;
        loop {
            let node = &self.nodes[at];
            let (_, mut mask) = boxes.enter::<OCT>(node, t_max);
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let c = node.child[i];
                if c & LEAF == 0 {
                    stack[sp] = c;
                    sp += 1;
                    continue;
                }
                let mut g = (c & !LEAF) as usize;
                loop {
                    let group = &self.groups[g];
                    if triangles::<KZ>(ray, group, t_min, t_max).1 != 0 {
                        return true;
                    }
                    if group.info & LAST != 0 {
                        break;
                    }
                    g += 1;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            at = stack[sp] as usize;
        }
    }
}

/// Bit `a` set where the ray's direction is negative along axis `a` (its reciprocal is never
/// zero: `Ray::new`).
#[inline(always)]
fn octant(ray: &Ray) -> usize {
    (ray.inv[0] < 0.0) as usize
        | ((ray.inv[1] < 0.0) as usize) << 1
        | ((ray.inv[2] < 0.0) as usize) << 2
}

/// Stack bound of [`MAX_BVH_DEPTH`] binary levels collapsed (never more wide levels than
/// binary ones).
const _: () = assert!(3 * MAX_BVH_DEPTH + 1 < LEAF as usize);

#[cfg(test)]
mod tests {
    use lrr_formats::{BvhNode, Geometry};

    use super::super::bvh::{self, Binary, Hit, Ray, triangle};
    use super::{Bvh4, INLINE_STACK, NotATree};

    /// SplitMix64 in [0, 1).
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// A file's BVH and its triangles in leaf order, as `TraceScene` holds them.
    struct Scene {
        nodes: Vec<BvhNode>,
        tris: Vec<[f32; 9]>,
    }

    impl Scene {
        /// The testkit's binned-SAH BVH (leaves of at most 4) over `tris`.
        fn sah(tris: &[[f32; 9]]) -> Scene {
            let n = tris.len();
            let mut vertices = Vec::with_capacity(12 * n);
            for t in tris {
                vertices.extend_from_slice(t);
                vertices.extend([0.0; 3]);
            }
            let geometry = Geometry {
                vertex_count: vec![3; n],
                vertices,
                normals: vec![0.0; 3 * n],
            };
            let bvh = crate::testkit::bvh::build(&geometry);
            Scene {
                tris: bvh.triangles.iter().map(|&t| tris[t as usize]).collect(),
                nodes: bvh.nodes,
            }
        }

        /// Median splits along x down to leaves of at most `leaf` triangles (leaves of several
        /// groups), or one leaf of all when `leaf >= tris.len()`.
        fn median(tris: &[[f32; 9]], leaf: usize) -> Scene {
            let centre = |t: &[f32; 9]| t[0] + t[3] + t[6];
            let mut tris = tris.to_vec();
            tris.sort_by(|a, b| centre(a).total_cmp(&centre(b)));
            let mut nodes = vec![empty()];
            let mut work = vec![(0usize, 0usize, tris.len())];
            while let Some((at, start, end)) = work.pop() {
                let mut n = empty();
                for t in &tris[start..end] {
                    for k in 0..3 {
                        for a in 0..3 {
                            n.min[a] = n.min[a].min(t[3 * k + a]);
                            n.max[a] = n.max[a].max(t[3 * k + a]);
                        }
                    }
                }
                if end - start <= leaf {
                    (n.first, n.count) = (start as u32, (end - start) as u32);
                } else {
                    n.first = nodes.len() as u32;
                    let mid = (start + end) / 2;
                    work.push((nodes.len(), start, mid));
                    work.push((nodes.len() + 1, mid, end));
                    nodes.extend([empty(), empty()]);
                }
                nodes[at] = n;
            }
            Scene { nodes, tris }
        }

        fn bvh4(&self) -> Bvh4 {
            Bvh4::new(&self.nodes, &self.tris).unwrap()
        }

        fn binary(&self) -> Binary<'_> {
            Binary {
                nodes: &self.nodes,
                tris: &self.tris,
            }
        }

        /// Every triangle tested: the least distance, ties to the lower leaf-order index.
        fn brute(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
            let mut best: Option<Hit> = None;
            for (i, tri) in self.tris.iter().enumerate() {
                let t = match ray.kz {
                    0 => triangle::<0>(ray, tri, t_min, t_max),
                    1 => triangle::<1>(ray, tri, t_min, t_max),
                    _ => triangle::<2>(ray, tri, t_min, t_max),
                };
                if let Some(t) = t
                    && best.is_none_or(|b| t < b.t)
                {
                    best = Some(Hit { t, tri: i as u32 });
                }
            }
            best
        }
    }

    fn empty() -> BvhNode {
        BvhNode {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            first: 0,
            count: 0,
        }
    }

    /// Triangles of size about `size` around random centres in `[0, 10)³`.
    fn soup(rng: &mut Rng, count: usize, size: f32) -> Vec<[f32; 9]> {
        (0..count)
            .map(|_| {
                let c = [rng.unit() * 10.0, rng.unit() * 10.0, rng.unit() * 10.0];
                std::array::from_fn(|i| c[i % 3] + (rng.unit() - 0.5) * size)
            })
            .collect()
    }

    /// Checks `ray` against the binary traversal (the same triangle at the same distance, bit
    /// for bit; the same any-hit answer) and against brute force: the same answer too, or,
    /// when `on_faces` (rays in the plane of box faces with a zero direction component, where
    /// the slab test of both traversals misses boxes the ray only touches), the same distance.
    fn check_with(
        scene: &Scene,
        bvh4: &Bvh4,
        ray: &Ray,
        (t_min, t_max): (f32, f32),
        on_faces: bool,
    ) -> bool {
        let got = bvh4.closest_hit(ray, t_min, t_max);
        let binary = bvh::closest_hit(scene.binary(), ray, t_min, t_max);
        assert_eq!(got, binary, "closest hit of {ray:?} in ({t_min}, {t_max})");
        let blocked = bvh4.occluded(ray, t_min, t_max);
        assert_eq!(blocked, got.is_some(), "any hit of {ray:?}");
        assert_eq!(bvh::occluded(scene.binary(), ray, t_min, t_max), blocked);
        let want = scene.brute(ray, t_min, t_max);
        if on_faces {
            assert_eq!(got.map(|h| h.t), want.map(|h| h.t), "{ray:?}");
        } else {
            assert_eq!(got, want, "brute force, {ray:?} in ({t_min}, {t_max})");
        }
        blocked
    }

    fn check(scene: &Scene, bvh4: &Bvh4, ray: &Ray, t_min: f32, t_max: f32) -> bool {
        check_with(scene, bvh4, ray, (t_min, t_max), false)
    }

    fn random_ray(rng: &mut Rng) -> Ray {
        let o = [0.0; 3].map(|_| rng.unit() * 14.0 - 2.0);
        let d = [0.0; 3].map(|_| rng.unit() - 0.5);
        Ray::new(o, d)
    }

    #[test]
    fn the_wide_traversal_finds_what_brute_force_finds_on_random_rays() {
        let mut rng = Rng(0x5eed);
        let mut stacks = [0; 2];
        for (count, size) in [
            (1, 3.0),
            (2, 3.0),
            (3, 2.0),
            (5, 2.0),
            (17, 2.0),
            (300, 1.0),
        ]
        .into_iter()
        .chain([(3000, 0.4)])
        {
            let tris = soup(&mut rng, count, size);
            for scene in [
                Scene::sah(&tris),
                Scene::median(&tris, 1),
                Scene::median(&tris, 7),
                Scene::median(&tris, count),
            ] {
                let bvh4 = scene.bvh4();
                let mut hits = 0;
                for r in 0..400 {
                    let ray = random_ray(&mut rng);
                    // Every fourth ray ends short.
                    let t_max = if r % 4 == 0 { 5.0 } else { f32::INFINITY };
                    hits += check(&scene, &bvh4, &ray, 0.0, t_max) as usize;
                }
                assert!(count < 300 || hits > 10, "{count} triangles: {hits} hits");
                stacks[(bvh4.stack > INLINE_STACK) as usize] += 1;
            }
        }
        assert!(
            stacks[0] > 0 && stacks[1] > 0,
            "inline and heap stacks: {stacks:?}"
        );
    }

    #[test]
    fn rays_along_axes_and_rays_starting_on_a_triangle() {
        let mut rng = Rng(0xa1e5);
        let tris = soup(&mut rng, 500, 1.5);
        let scene = Scene::sah(&tris);
        let bvh4 = scene.bvh4();
        let axes: Vec<[f32; 3]> = vec![
            [1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [0.6, 0.0, -0.8],
            [0.0, -0.6, 0.8],
            [-0.0, 0.0, 1.0],
        ];
        let mut hits = 0;
        for d in &axes {
            for _ in 0..300 {
                let o = [0.0; 3].map(|_| rng.unit() * 12.0 - 1.0);
                hits += check(&scene, &bvh4, &Ray::new(o, *d), 0.0, f32::INFINITY) as usize;
            }
        }
        assert!(hits > 300, "{hits}");
        // From a point of a triangle (its barycentre and a vertex) in random directions: the
        // triangle itself is at t = 0 or within rounding of it.
        for (i, t) in scene.tris.iter().enumerate().step_by(7) {
            let centre = [0, 1, 2].map(|a| (t[a] + t[3 + a] + t[6 + a]) / 3.0);
            for o in [centre, [t[0], t[1], t[2]]] {
                for d in axes
                    .iter()
                    .copied()
                    .chain([[0.0; 3].map(|_| rng.unit() - 0.5)])
                {
                    let ray = Ray::new(o, d);
                    check(&scene, &bvh4, &ray, 0.0, f32::INFINITY);
                    check(&scene, &bvh4, &ray, 1e-4, f32::INFINITY);
                }
            }
            let _ = i;
        }
    }

    #[test]
    fn ties_go_to_the_lower_leaf_order_index() {
        // A 16 x 16 grid of unit quads in the plane z = 1, two triangles each: rays along z
        // through the grid's inner vertices hit up to six triangles at exactly t = 1 (the
        // outer ones graze the scene's box, which both traversals miss).
        let mut tris = Vec::new();
        for y in 0..16 {
            for x in 0..16 {
                let (x0, y0, x1, y1) = (x as f32, y as f32, x as f32 + 1.0, y as f32 + 1.0);
                tris.push([x0, y0, 1.0, x1, y0, 1.0, x1, y1, 1.0]);
                tris.push([x0, y0, 1.0, x1, y1, 1.0, x0, y1, 1.0]);
            }
        }
        for scene in [Scene::sah(&tris), Scene::median(&tris, 3)] {
            let bvh4 = scene.bvh4();
            let mut ties = 0;
            for y in 1..16 {
                for x in 1..16 {
                    for d in [[0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.5, 0.25, 1.0]] {
                        let o = [x as f32 - 0.5 * d[0], y as f32 - 0.25 * d[1], 0.0];
                        let ray = Ray::new(o, d);
                        check_with(&scene, &bvh4, &ray, (0.0, f32::INFINITY), true);
                        let n = scene
                            .tris
                            .iter()
                            .filter(|t| {
                                triangle::<2>(&ray, t, 0.0, f32::INFINITY) == Some(1.0 / d[2])
                            })
                            .count();
                        ties += (n > 1) as usize;
                    }
                }
            }
            assert!(ties > 150, "{ties} rays with tied triangles");
        }
    }

    /// Packet `p` of a packet test: `N` rays from one origin, directions a little apart (every
    /// third packet: in any direction), some ending short, and the packet's `t_min`.
    fn packet<const N: usize>(rng: &mut Rng, p: usize) -> ([Ray; N], f32, [f32; N]) {
        let o = [0.0; 3].map(|_| rng.unit() * 14.0 - 2.0);
        let d = [0.0; 3].map(|_| rng.unit() - 0.5);
        let spread = if p.is_multiple_of(3) { 1.0 } else { 0.02 };
        let rays = std::array::from_fn(|_| Ray::new(o, d.map(|x| x + (rng.unit() - 0.5) * spread)));
        let t_max = std::array::from_fn(|i| {
            if (p + i).is_multiple_of(5) {
                4.0
            } else {
                f32::INFINITY
            }
        });
        let t_min = if p.is_multiple_of(7) { 1e-4 } else { 0.0 };
        (rays, t_min, t_max)
    }

    #[test]
    fn packets_of_four_rays_answer_as_single_rays() {
        // Packets of nearby rays (one origin, directions a little apart: mostly one octant, so
        // the packet traversal) and of rays in any direction (mostly traced ray by ray), over
        // the tree shapes above, some rays ending short; closest hits and any hits.
        let mut rng = Rng(0x9ac4);
        let (mut packed, mut blocked, mut total) = (0, 0, 0);
        for (count, size) in [(1, 3.0), (5, 2.0), (300, 1.0), (3000, 0.4), (20000, 0.8)] {
            let tris = soup(&mut rng, count, size);
            for scene in [
                Scene::sah(&tris),
                Scene::median(&tris, 1),
                Scene::median(&tris, 7),
            ] {
                let bvh4 = scene.bvh4();
                for p in 0..300 {
                    let (rays, t_min, t_max) = packet::<4>(&mut rng, p);
                    let got = bvh4.closest_hit4(&rays, t_min, t_max);
                    for (i, (ray, got)) in rays.iter().zip(got).enumerate() {
                        let want = bvh4.closest_hit(ray, t_min, t_max[i]);
                        assert_eq!(got, want, "ray {i} of packet {p}: {ray:?}");
                    }
                    let got = bvh4.occluded4(&rays, t_min, t_max);
                    for (i, (ray, got)) in rays.iter().zip(got).enumerate() {
                        let want = bvh4.occluded(ray, t_min, t_max[i]);
                        assert_eq!(got, want, "any hit, ray {i} of packet {p}: {ray:?}");
                        if count == 20000 {
                            blocked += usize::from(got);
                        }
                    }
                    let oct = super::octant(&rays[0]);
                    packed += rays
                        .iter()
                        .all(|r| super::octant(r) == oct && r.kz == rays[0].kz)
                        as usize;
                    if count == 20000 {
                        total += 4;
                    }
                }
            }
        }
        assert!(packed > 1000, "{packed} packets traced together");
        // In the dense soup both answers occur often: the any-hit packets exit early and run
        // to the end.
        assert!(
            blocked > total / 5 && blocked < total * 4 / 5,
            "{blocked} of {total} rays of the dense soup blocked"
        );
    }

    #[test]
    fn packets_of_eight_rays_answer_as_single_rays_with_and_without_avx2() {
        // As above, eight rays a packet: the portable build against the single ray, and the
        // AVX2 build against the portable one bit for bit. Without AVX2 the test fails (the
        // AVX2 build, the one the tracer runs, would go untested) unless `LRR_SKIP_AVX2=1`
        // says that is expected, as the kernels' tests do.
        let avx2 = super::packet8::avx2_available();
        if !avx2 {
            assert!(
                std::env::var_os("LRR_SKIP_AVX2").is_some(),
                "this CPU lacks AVX2, so the AVX2 packets cannot be tested here: run on an \
                 x86-64 CPU with it, or set LRR_SKIP_AVX2=1 to check the portable ones alone"
            );
            eprintln!("no AVX2 on this CPU (LRR_SKIP_AVX2 is set): portable packets alone");
        }
        let bits = |h: [Option<Hit>; 8]| h.map(|h| h.map(|h| (h.t.to_bits(), h.tri)));
        let mut rng = Rng(0x8a7e);
        let mut packed = 0;
        for (count, size) in [(1, 3.0), (5, 2.0), (300, 1.0), (3000, 0.4), (20000, 0.8)] {
            let tris = soup(&mut rng, count, size);
            for scene in [
                Scene::sah(&tris),
                Scene::median(&tris, 1),
                Scene::median(&tris, 7),
            ] {
                let bvh4 = scene.bvh4();
                for p in 0..200 {
                    let (rays, t_min, t_max) = packet::<8>(&mut rng, p);
                    let got = bvh4.closest_hit8_with(&rays, t_min, t_max, false);
                    for (i, (ray, got)) in rays.iter().zip(got).enumerate() {
                        let want = bvh4.closest_hit(ray, t_min, t_max[i]);
                        assert_eq!(got, want, "ray {i} of packet {p}: {ray:?}");
                    }
                    if avx2 {
                        let fast = bvh4.closest_hit8_with(&rays, t_min, t_max, true);
                        assert_eq!(bits(fast), bits(got), "AVX2 against portable, packet {p}");
                    }
                    let oct = super::octant(&rays[0]);
                    packed += rays
                        .iter()
                        .all(|r| super::octant(r) == oct && r.kz == rays[0].kz)
                        as usize;
                }
            }
        }
        assert!(packed > 1000, "{packed} packets traced together");
    }

    /// Half the surface area of a box.
    fn half_area(min: [f32; 3], max: [f32; 3]) -> f64 {
        let d = [0, 1, 2].map(|a| (max[a] - min[a]).max(0.0) as f64);
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }

    /// The SAH cost of the wide nodes of the collapse before the dynamic program (open the
    /// child with the largest box until there are four), from binary node `i` down.
    fn greedy_cost(nodes: &[BvhNode], i: usize) -> f64 {
        let area = |n: &BvhNode| half_area(n.min, n.max);
        let first = nodes[i].first as usize;
        let mut children = vec![first, first + 1];
        while children.len() < 4 {
            let inner = children
                .iter()
                .enumerate()
                .filter(|(_, c)| nodes[**c].count == 0);
            let Some((slot, _)) = inner.fold(None, |w: Option<(usize, &usize)>, (s, c)| match w {
                Some((_, b)) if area(&nodes[*b]) >= area(&nodes[*c]) => w,
                _ => Some((s, c)),
            }) else {
                break;
            };
            let c = nodes[children[slot]].first as usize;
            children.splice(slot..=slot, [c, c + 1]);
        }
        let below: f64 = children
            .iter()
            .filter(|&&c| nodes[c].count == 0)
            .map(|&c| greedy_cost(nodes, c))
            .sum();
        area(&nodes[i]) + below
    }

    #[test]
    fn the_collapse_costs_no_more_than_opening_the_largest_child() {
        // The dynamic program's wide nodes (their boxes: the union of their slots) against
        // the greedy collapse's, by the SAH cost both minimise; every triangle in one lane.
        let mut rng = Rng(0xc011);
        let mut better = 0;
        for (count, size) in [(16, 1.0), (300, 1.0), (3000, 0.4), (20000, 0.8)] {
            let tris = soup(&mut rng, count, size);
            for scene in [
                Scene::sah(&tris),
                Scene::median(&tris, 1),
                Scene::median(&tris, 3),
            ] {
                let bvh4 = scene.bvh4();
                let cost: f64 = bvh4
                    .nodes
                    .iter()
                    .map(|n| {
                        let slots = (0..4).filter(|&s| n.bounds[0][0][s].is_finite());
                        assert!(slots.clone().count() >= 2, "a node of fewer than two slots");
                        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
                        for s in slots {
                            for a in 0..3 {
                                lo[a] = lo[a].min(n.bounds[0][a][s]);
                                hi[a] = hi[a].max(n.bounds[1][a][s]);
                            }
                        }
                        half_area(lo, hi)
                    })
                    .sum();
                let greedy = greedy_cost(&scene.nodes, 0);
                assert!(cost <= greedy * (1.0 + 1e-9), "{count}: {cost} > {greedy}");
                better += (cost < greedy * 0.99) as usize;
                let lanes: u32 = bvh4
                    .groups
                    .iter()
                    .map(|g| (g.info & 0xf).count_ones())
                    .sum();
                assert_eq!(lanes as usize, count);
            }
        }
        assert!(
            better >= 4,
            "{better} trees cheaper than the greedy collapse's"
        );
    }

    #[test]
    fn empty_and_single_triangle_trees() {
        let none = Bvh4::new(&[], &[]).unwrap();
        let ray = Ray::new([0.0; 3], [0.0, 0.0, 1.0]);
        assert_eq!(none.closest_hit(&ray, 0.0, f32::INFINITY), None);
        assert!(!none.occluded(&ray, 0.0, f32::INFINITY));
        let one = [[-1.0, -1.0, 2.0, 1.0, -1.0, 2.0, 0.0, 1.0, 2.0]];
        let scene = Scene::sah(&one);
        assert_eq!(scene.nodes.len(), 1);
        let bvh4 = scene.bvh4();
        assert_eq!(
            bvh4.closest_hit(&ray, 0.0, f32::INFINITY),
            Some(Hit { t: 2.0, tri: 0 })
        );
        assert!(bvh4.occluded(&ray, 0.0, f32::INFINITY));
        assert!(!bvh4.occluded(&ray, 0.0, 2.0), "t_max is exclusive");
        assert!(!bvh4.occluded(&ray, 2.0, 3.0), "t_min is exclusive");
        assert_eq!(
            bvh4.closest_hit(&Ray::new([0.0; 3], [0.0, 0.0, -1.0]), 0.0, 9.0),
            None
        );
        let mut rng = Rng(1);
        for _ in 0..500 {
            check(&scene, &bvh4, &random_ray(&mut rng), 0.0, f32::INFINITY);
        }
    }

    #[test]
    fn a_damaged_tree_is_refused() {
        let mut rng = Rng(7);
        let tris = soup(&mut rng, 20, 1.0);
        let scene = Scene::median(&tris, 2);
        // Two nodes sharing children: a DAG, which collapsing would expand.
        let mut shared = scene.nodes.clone();
        let inner: Vec<usize> = (1..shared.len())
            .filter(|&i| shared[i].count == 0)
            .collect();
        shared[inner[1]].first = shared[inner[0]].first;
        assert_eq!(
            Bvh4::new(&shared, &scene.tris).unwrap_err(),
            NotATree::Shared
        );
        // Leaves listing more triangles than there are.
        let mut greedy = scene.nodes.clone();
        let leaf = greedy.iter().position(|n| n.count > 0).unwrap();
        (greedy[leaf].first, greedy[leaf].count) = (0, tris.len() as u32);
        assert_eq!(
            Bvh4::new(&greedy, &scene.tris).unwrap_err(),
            NotATree::TooManyTriangles
        );
    }
}
