//! Four rays through the 4-wide BVH together: one node fetch, one child ordering and one set of
//! branches for the rays of a packet, each ray's slab tests and triangle tests its own (the
//! single-ray traversal's values, with its own best distance), so every ray tests the triangles
//! of the leaves whose box it enters, as alone: the same closest hits (the least distance, ties
//! to the lower leaf-order index; the tests hold it to the single-ray traversal bit for bit; the
//! order of visits differs, which only matters in the rounding case `bvh4.rs` names).
//!
//! - The traversal (`closest_packet`) is generic over the number of lanes, 4 here and 8 in
//!   `packet8.rs`; the lane operations are loops over a constant count, which the compiler
//!   unrolls (measured the same as the former hand-unrolled copy per count: docs/PERFORMANCE.md).
//! - The rays are the lanes: per child one slab test of the N rays gives the child's mask
//!   of rays and their entry distances directly (a first version with one ray's four children
//!   in the lanes, as `bvh4.rs`, then the masks transposed per child, gained nothing).
//! - Children are visited in the order of the entry distances of the first ray in each, the
//!   nearest next, the others pushed farthest first with their rays and the rays' entry
//!   distances; a popped entry keeps the rays whose best hit is not before their entry.
//! - Rays of a packet must share the octant and the dominant axis (the monomorphised slab and
//!   triangle tests); a packet whose rays do not is traced ray by ray.
//!
//! Neighbouring camera rays visit mostly the same nodes, and the single-ray traversal spends
//! its time on the control flow per node: `lrr bench render` measured ×1.2 on primary rays
//! (four neighbouring pixels of a row) and ×1.35 on their mirror reflections, whole frames
//! ×0.85–0.89 the time (docs/PERFORMANCE.md). Used by the tracer (feature `trace`): the batch
//! API (`trace/batch.rs`) and the renderer's camera rays (`trace/tracer.rs`) on a CPU without
//! AVX2; with it, packets of eight (`packet8.rs`).
//!
//! [`Bvh4::occluded4`] is the any-hit twin for shadow rays (the direct pass's, in every build):
//! the single-ray `any` traversal's order (children in slot order, leaves tested as they are
//! met, inner nodes pushed), each stack entry with the rays that entered it; a ray leaves the
//! packet at its first hit, the packet ends when all four are blocked or the stack is empty.
//! Whether a ray is blocked does not depend on the order of visits, so the answers are the
//! single ray's exactly.

use super::super::bvh::FAR_SCALE;
#[cfg(feature = "trace")]
use super::super::bvh::Hit;
use super::super::bvh::Ray;
use super::{Bvh4, F4, INLINE_STACK, LAST, LEAF, Node, octant, triangles};

/// `N` rays (4 or 8) as the slab tests read them, one ray per lane.
struct Lanes<const N: usize> {
    origin: [[f32; N]; 3],
    inv: [[f32; N]; 3],
}

/// Lane-wise `f` on `N` lanes (unrolled: `N` is a constant).
#[inline(always)]
fn zip<const N: usize>(a: [f32; N], b: [f32; N], f: impl Fn(f32, f32) -> f32) -> [f32; N] {
    let mut out = a;
    for (o, b) in out.iter_mut().zip(b) {
        *o = f(*o, b);
    }
    out
}

/// Lane `i` of the result is bit `i`: whether `f` holds in that lane.
#[inline(always)]
fn mask<const N: usize>(a: [f32; N], b: [f32; N], f: impl Fn(f32, f32) -> bool) -> u32 {
    let mut bits = 0;
    for (i, (a, b)) in a.into_iter().zip(b).enumerate() {
        bits |= u32::from(f(a, b)) << i;
    }
    bits
}

impl<const N: usize> Lanes<N> {
    fn new(rays: &[Ray; N]) -> Self {
        Lanes {
            origin: std::array::from_fn(|a| std::array::from_fn(|r| rays[r].origin[a])),
            inv: std::array::from_fn(|a| std::array::from_fn(|r| rays[r].inv[a])),
        }
    }

    /// Child `c`'s entry distance for each ray within `(0, t_max)` and the rays that enter it:
    /// `BoxRay::enter`'s operations in its order, with the rays in the lanes.
    #[inline(always)]
    fn enter<const OCT: usize>(&self, node: &Node, c: usize, t_max: [f32; N]) -> ([f32; N], u32) {
        let side = |a: usize| (OCT >> a) & 1;
        let slab = |a: usize, s: usize| {
            let d = zip([node.bounds[s][a][c]; N], self.origin[a], |b, o| b - o);
            zip(d, self.inv[a], |d, inv| d * inv)
        };
        // `if a > b { a } else { b }` (`maxps`; `f32::max`'s NaN rule would cost more).
        let hi = |a, b| zip(a, b, |a, b| if a > b { a } else { b });
        let lo = |a, b| zip(a, b, |a, b| if a < b { a } else { b });
        let near = hi(
            hi(hi([0.0; N], slab(0, side(0))), slab(1, side(1))),
            slab(2, side(2)),
        );
        let scaled = |a: usize| zip(slab(a, side(a) ^ 1), [FAR_SCALE; N], |s, f| s * f);
        let far = lo(lo(lo(t_max, scaled(0)), scaled(1)), scaled(2));
        (near, mask(near, far, |n, f| n <= f))
    }
}

/// A stack entry: a node or leaf slot, the rays that entered it, and their entry distances.
#[cfg(feature = "trace")]
#[derive(Clone, Copy)]
pub(super) struct Entry<const N: usize> {
    at: u32,
    rays: u32,
    t: [f32; N],
}

#[cfg(feature = "trace")]
impl<const N: usize> Entry<N> {
    pub(super) const EMPTY: Self = Entry {
        at: 0,
        rays: 0,
        t: [0.0; N],
    };
}

impl Bvh4 {
    /// The closest hit of each of four rays in `(t_min, t_max[i])`: the same answers as
    /// [`Bvh4::closest_hit`] ray by ray.
    #[cfg(feature = "trace")]
    pub(crate) fn closest_hit4(&self, rays: &[Ray; 4], t_min: f32, t_max: F4) -> [Option<Hit>; 4] {
        let oct = octant(&rays[0]);
        let kz = rays[0].kz;
        if self.nodes.is_empty() || rays.iter().any(|r| octant(r) != oct || r.kz != kz) {
            return std::array::from_fn(|i| self.closest_hit(&rays[i], t_min, t_max[i]));
        }
        let (mut inline, mut heap);
        let stack: &mut [Entry<4>] = if self.stack <= INLINE_STACK {
            inline = [Entry::EMPTY; INLINE_STACK];
            &mut inline
        } else {
            heap = vec![Entry::EMPTY; self.stack];
            &mut heap
        };
        match kz {
            0 => self.closest4_kz::<0>(stack, rays, t_min, t_max, oct),
            1 => self.closest4_kz::<1>(stack, rays, t_min, t_max, oct),
            _ => self.closest4_kz::<2>(stack, rays, t_min, t_max, oct),
        }
    }

    #[cfg(feature = "trace")]
    fn closest4_kz<const KZ: usize>(
        &self,
        stack: &mut [Entry<4>],
        rays: &[Ray; 4],
        t_min: f32,
        t_max: F4,
        oct: usize,
    ) -> [Option<Hit>; 4] {
        match oct {
            0 => self.closest4::<KZ, 0>(stack, rays, t_min, t_max),
            1 => self.closest4::<KZ, 1>(stack, rays, t_min, t_max),
            2 => self.closest4::<KZ, 2>(stack, rays, t_min, t_max),
            3 => self.closest4::<KZ, 3>(stack, rays, t_min, t_max),
            4 => self.closest4::<KZ, 4>(stack, rays, t_min, t_max),
            5 => self.closest4::<KZ, 5>(stack, rays, t_min, t_max),
            6 => self.closest4::<KZ, 6>(stack, rays, t_min, t_max),
            _ => self.closest4::<KZ, 7>(stack, rays, t_min, t_max),
        }
    }

    /// [`Bvh4::closest_hit4`] for rays whose dominant axis is `KZ`, in octant `OCT`.
    #[cfg(feature = "trace")]
    fn closest4<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry<4>],
        rays: &[Ray; 4],
        t_min: f32,
        t_max: F4,
    ) -> [Option<Hit>; 4] {
        self.closest_packet::<4, KZ, OCT>(stack, rays, t_min, t_max)
    }

    /// The closest hits of `N` rays (4 or 8) whose dominant axis is `KZ`, in octant `OCT`. A
    /// hot loop, kept in one piece and inlined into its callers (`closest4`, and the two
    /// builds of `packet8.rs`'s `closest8`).
    #[cfg(feature = "trace")]
    #[inline(always)]
    pub(super) fn closest_packet<const N: usize, const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry<N>],
        rays: &[Ray; N],
        t_min: f32,
        t_max: [f32; N],
    ) -> [Option<Hit>; N] {
        let lanes = Lanes::new(rays);
        let (mut best_t, mut best_tri) = (t_max, [u32::MAX; N]);
        let mut sp = 0usize;
        let mut at = 0u32;
        let mut active = (1u32 << N) - 1;
        loop {
            if at & LEAF == 0 {
                let node = &self.nodes[at as usize];
                // Per child one slab test of the rays (a ray in each lane: the values of
                // `BoxRay::enter`, lane for lane), masked to the active rays.
                let mut near = [[0.0f32; N]; 4];
                let mut child_rays = [0u32; 4];
                for (c, (t, rays)) in near.iter_mut().zip(&mut child_rays).enumerate() {
                    let (n, mask) = lanes.enter::<OCT>(node, c, best_t);
                    (*t, *rays) = (n, mask & active);
                }
                // The entered children ordered by the entry distance of the first ray active
                // in each: nearest next, the others pushed farthest first.
                let mut order = [(0usize, 0.0f32); 4];
                let mut n = 0;
                for (c, &rays) in child_rays.iter().enumerate() {
                    if rays != 0 {
                        let key = near[c][rays.trailing_zeros() as usize];
                        let mut j = n;
                        while j > 0 && order[j - 1].1 < key {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = (c, key);
                        n += 1;
                    }
                }
                if n != 0 {
                    for &(c, _) in &order[..n - 1] {
                        stack[sp] = Entry {
                            at: node.child[c],
                            rays: child_rays[c],
                            t: near[c],
                        };
                        sp += 1;
                    }
                    let c = order[n - 1].0;
                    (at, active) = (node.child[c], child_rays[c]);
                    continue;
                }
            } else {
                let mut g = (at & !LEAF) as usize;
                loop {
                    let group = &self.groups[g];
                    let mut each = active;
                    while each != 0 {
                        let r = each.trailing_zeros() as usize;
                        each &= each - 1;
                        let (t, mut hit) = triangles::<KZ>(&rays[r], group, t_min, t_max[r]);
                        while hit != 0 {
                            let i = hit.trailing_zeros();
                            hit &= hit - 1;
                            let tri = group.first + i;
                            let t = t[i as usize];
                            if t < best_t[r] || (t == best_t[r] && tri < best_tri[r]) {
                                (best_t[r], best_tri[r]) = (t, tri);
                            }
                        }
                    }
                    if group.info & LAST != 0 {
                        break;
                    }
                    g += 1;
                }
            }
            // Pop the next entry with a ray whose best hit is not before it.
            loop {
                if sp == 0 {
                    return std::array::from_fn(|r| {
                        (best_tri[r] != u32::MAX).then_some(Hit {
                            t: best_t[r],
                            tri: best_tri[r],
                        })
                    });
                }
                sp -= 1;
                let e = stack[sp];
                let rays = mask(e.t, best_t, |t, best| t <= best) & e.rays;
                if rays != 0 {
                    (at, active) = (e.at, rays);
                    break;
                }
            }
        }
    }

    /// Whether any triangle blocks each of four rays in `(t_min, t_max[i])`: the same answers
    /// as [`Bvh4::occluded`] ray by ray.
    pub(crate) fn occluded4(&self, rays: &[Ray; 4], t_min: f32, t_max: F4) -> [bool; 4] {
        let oct = octant(&rays[0]);
        let kz = rays[0].kz;
        if self.nodes.is_empty() || rays.iter().any(|r| octant(r) != oct || r.kz != kz) {
            return std::array::from_fn(|i| self.occluded(&rays[i], t_min, t_max[i]));
        }
        let (mut inline, mut heap);
        let stack: &mut [(u32, u32)] = if self.stack <= INLINE_STACK {
            inline = [(0, 0); INLINE_STACK];
            &mut inline
        } else {
            heap = vec![(0, 0); self.stack];
            &mut heap
        };
        match kz {
            0 => self.any4_kz::<0>(stack, rays, t_min, t_max, oct),
            1 => self.any4_kz::<1>(stack, rays, t_min, t_max, oct),
            _ => self.any4_kz::<2>(stack, rays, t_min, t_max, oct),
        }
    }

    fn any4_kz<const KZ: usize>(
        &self,
        stack: &mut [(u32, u32)],
        rays: &[Ray; 4],
        t_min: f32,
        t_max: F4,
        oct: usize,
    ) -> [bool; 4] {
        match oct {
            0 => self.any4::<KZ, 0>(stack, rays, t_min, t_max),
            1 => self.any4::<KZ, 1>(stack, rays, t_min, t_max),
            2 => self.any4::<KZ, 2>(stack, rays, t_min, t_max),
            3 => self.any4::<KZ, 3>(stack, rays, t_min, t_max),
            4 => self.any4::<KZ, 4>(stack, rays, t_min, t_max),
            5 => self.any4::<KZ, 5>(stack, rays, t_min, t_max),
            6 => self.any4::<KZ, 6>(stack, rays, t_min, t_max),
            _ => self.any4::<KZ, 7>(stack, rays, t_min, t_max),
        }
    }

    /// [`Bvh4::occluded4`] for rays whose dominant axis is `KZ`, in octant `OCT`.
    fn any4<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [(u32, u32)],
        rays: &[Ray; 4],
        t_min: f32,
        t_max: F4,
    ) -> [bool; 4] {
        let lanes = Lanes::new(rays);
        let mut blocked = 0u32;
        let mut sp = 0usize;
        let (mut at, mut active) = (0u32, 0b1111u32);
        loop {
            let node = &self.nodes[at as usize];
            for c in 0..4 {
                let (_, mask) = lanes.enter::<OCT>(node, c, t_max);
                let entered = mask & active & !blocked;
                if entered == 0 {
                    continue;
                }
                let child = node.child[c];
                if child & LEAF == 0 {
                    stack[sp] = (child, entered);
                    sp += 1;
                    continue;
                }
                let mut g = (child & !LEAF) as usize;
                loop {
                    let group = &self.groups[g];
                    let mut each = entered & !blocked;
                    while each != 0 {
                        let r = each.trailing_zeros() as usize;
                        each &= each - 1;
                        if triangles::<KZ>(&rays[r], group, t_min, t_max[r]).1 != 0 {
                            blocked |= 1 << r;
                        }
                    }
                    if blocked == 0b1111 {
                        return [true; 4];
                    }
                    if group.info & LAST != 0 || entered & !blocked == 0 {
                        break;
                    }
                    g += 1;
                }
            }
            loop {
                if sp == 0 {
                    return std::array::from_fn(|r| blocked & (1 << r) != 0);
                }
                sp -= 1;
                let (node, entered) = stack[sp];
                let left = entered & !blocked;
                if left != 0 {
                    (at, active) = (node, left);
                    break;
                }
            }
        }
    }
}
