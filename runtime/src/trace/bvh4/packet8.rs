//! Eight rays through the 4-wide BVH together: `packet.rs`'s closest-hit traversal with eight
//! rays in the lanes instead of four (one node fetch, one child ordering and one set of
//! branches for eight neighbouring rays), the same answers ray by ray (each ray tests the leaves
//! whose box it enters, with the single-ray triangle test and its own best distance).
//!
//! The same safe code is compiled twice: for the build's target (generic x86-64: two SSE
//! registers per eight lanes) and, inlined into a `#[target_feature(enable = "avx2")]`
//! function, for AVX2 (one register, three-operand forms), chosen at run time. The operations
//! and their order are the same and Rust fuses no product and sum, so both give the same bits
//! (a test holds them to each other and to the single ray). The batch API and the renderer use
//! packets of eight only where the CPU has AVX2 ([`Bvh4::packets_of_eight`]): built for SSE
//! they measured no faster than packets of four, with AVX2 ×1.1–1.2 on camera rays and their
//! reflections (`lrr bench render`, docs/PERFORMANCE.md round 4). Shadow rays stay in packets
//! of four: an any-hit twin on eight lanes with AVX2 measured no faster.
//!
//! The batch API's camera rays come in blocks of 4 × 2 pixels (`batch.rs`). Tried and dropped:
//! the triangles of a leaf tested one at a time against the eight rays in the lanes (fewer
//! tests when more rays than triangles are active; measured slower).

use super::super::bvh::FAR_SCALE;
use super::super::bvh::{Hit, Ray};
use super::{Bvh4, INLINE_STACK, LAST, LEAF, Node, octant, triangles};

/// Eight lanes.
type F8 = [f32; 8];

#[inline(always)]
fn splat8(x: f32) -> F8 {
    [x; 8]
}

#[inline(always)]
fn zip8(a: F8, b: F8, f: impl Fn(f32, f32) -> f32) -> F8 {
    [
        f(a[0], b[0]),
        f(a[1], b[1]),
        f(a[2], b[2]),
        f(a[3], b[3]),
        f(a[4], b[4]),
        f(a[5], b[5]),
        f(a[6], b[6]),
        f(a[7], b[7]),
    ]
}

#[inline(always)]
fn bits8(a: F8, b: F8, f: impl Fn(f32, f32) -> bool) -> u32 {
    (f(a[0], b[0]) as u32)
        | ((f(a[1], b[1]) as u32) << 1)
        | ((f(a[2], b[2]) as u32) << 2)
        | ((f(a[3], b[3]) as u32) << 3)
        | ((f(a[4], b[4]) as u32) << 4)
        | ((f(a[5], b[5]) as u32) << 5)
        | ((f(a[6], b[6]) as u32) << 6)
        | ((f(a[7], b[7]) as u32) << 7)
}

#[inline(always)]
fn sub8(a: F8, b: F8) -> F8 {
    zip8(a, b, |a, b| a - b)
}

#[inline(always)]
fn mul8(a: F8, b: F8) -> F8 {
    zip8(a, b, |a, b| a * b)
}

#[inline(always)]
fn hi8(a: F8, b: F8) -> F8 {
    zip8(a, b, |a, b| if a > b { a } else { b })
}

#[inline(always)]
fn lo8(a: F8, b: F8) -> F8 {
    zip8(a, b, |a, b| if a < b { a } else { b })
}

/// Eight rays as the slab tests read them, one ray per lane.
struct Lanes8 {
    origin: [F8; 3],
    inv: [F8; 3],
}

impl Lanes8 {
    fn new(rays: &[Ray; 8]) -> Self {
        Lanes8 {
            origin: std::array::from_fn(|a| std::array::from_fn(|r| rays[r].origin[a])),
            inv: std::array::from_fn(|a| std::array::from_fn(|r| rays[r].inv[a])),
        }
    }

    /// `packet.rs`'s `Lanes::enter` on eight lanes.
    #[inline(always)]
    fn enter<const OCT: usize>(&self, node: &Node, c: usize, t_max: F8) -> (F8, u32) {
        let side = |a: usize| (OCT >> a) & 1;
        let slab = |a: usize, s: usize| {
            mul8(
                sub8(splat8(node.bounds[s][a][c]), self.origin[a]),
                self.inv[a],
            )
        };
        let near = hi8(
            hi8(hi8(splat8(0.0), slab(0, side(0))), slab(1, side(1))),
            slab(2, side(2)),
        );
        let scaled = |a: usize| mul8(slab(a, side(a) ^ 1), splat8(FAR_SCALE));
        let far = lo8(lo8(lo8(t_max, scaled(0)), scaled(1)), scaled(2));
        (near, bits8(near, far, |n, f| n <= f))
    }
}

#[derive(Clone, Copy)]
struct Entry8 {
    at: u32,
    rays: u32,
    t: F8,
}

/// `closest_hit8_with`'s stack, rays, `t_min`, `t_max` and whether to use AVX2.
type Args8<'a> = (&'a mut [Entry8], &'a [Ray; 8], f32, F8, bool);

const NO_ENTRY: Entry8 = Entry8 {
    at: 0,
    rays: 0,
    t: [0.0; 8],
};

/// Whether this CPU has AVX2 (the eight lanes in one register).
pub(super) fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

impl Bvh4 {
    /// Whether closest hits go eight rays at a time ([`Bvh4::closest_hit8`]) rather than four:
    /// where the CPU has AVX2 (without it the eight lanes take two SSE registers and measured
    /// no faster than packets of four).
    pub(crate) fn packets_of_eight() -> bool {
        avx2_available()
    }

    /// The closest hit of each of eight rays in `(t_min, t_max[i])`: the same answers as
    /// [`Bvh4::closest_hit`] ray by ray.
    pub(crate) fn closest_hit8(&self, rays: &[Ray; 8], t_min: f32, t_max: F8) -> [Option<Hit>; 8] {
        self.closest_hit8_with(rays, t_min, t_max, avx2_available())
    }

    /// [`Bvh4::closest_hit8`], compiled for AVX2 when `avx2` (which only a CPU with AVX2 may
    /// pass: [`avx2_available`]), else for the build's target.
    pub(super) fn closest_hit8_with(
        &self,
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
        avx2: bool,
    ) -> [Option<Hit>; 8] {
        let oct = octant(&rays[0]);
        let kz = rays[0].kz;
        if self.nodes.is_empty() || rays.iter().any(|r| octant(r) != oct || r.kz != kz) {
            let half = |h: usize| {
                let r = std::array::from_fn(|i| rays[4 * h + i]);
                self.closest_hit4(&r, t_min, std::array::from_fn(|i| t_max[4 * h + i]))
            };
            let (a, b) = (half(0), half(1));
            return std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] });
        }
        let (mut inline, mut heap);
        let stack: &mut [Entry8] = if self.stack <= INLINE_STACK {
            inline = [NO_ENTRY; INLINE_STACK];
            &mut inline
        } else {
            heap = vec![NO_ENTRY; self.stack];
            &mut heap
        };
        let args = (stack, rays, t_min, t_max, avx2);
        match kz {
            0 => self.closest8_kz::<0>(args, oct),
            1 => self.closest8_kz::<1>(args, oct),
            _ => self.closest8_kz::<2>(args, oct),
        }
    }

    #[inline(always)]
    fn closest8_kz<const KZ: usize>(&self, args: Args8, oct: usize) -> [Option<Hit>; 8] {
        match oct {
            0 => self.closest8_isa::<KZ, 0>(args),
            1 => self.closest8_isa::<KZ, 1>(args),
            2 => self.closest8_isa::<KZ, 2>(args),
            3 => self.closest8_isa::<KZ, 3>(args),
            4 => self.closest8_isa::<KZ, 4>(args),
            5 => self.closest8_isa::<KZ, 5>(args),
            6 => self.closest8_isa::<KZ, 6>(args),
            _ => self.closest8_isa::<KZ, 7>(args),
        }
    }

    #[inline(always)]
    fn closest8_isa<const KZ: usize, const OCT: usize>(
        &self,
        (stack, rays, t_min, t_max, avx2): Args8,
    ) -> [Option<Hit>; 8] {
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: `avx2` is true only on a CPU with AVX2 (`closest_hit8_with`).
            #[allow(unsafe_code)]
            return unsafe { self.closest8_avx2::<KZ, OCT>(stack, rays, t_min, t_max) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = avx2;
        self.closest8_portable::<KZ, OCT>(stack, rays, t_min, t_max)
    }

    /// [`Bvh4::closest8`] for the build's target, a function of its own as its AVX2 twin is
    /// (not inlined 24 times into `closest_hit8_with`).
    #[inline(never)]
    fn closest8_portable<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry8],
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
    ) -> [Option<Hit>; 8] {
        self.closest8::<KZ, OCT>(stack, rays, t_min, t_max)
    }

    /// [`Bvh4::closest8`] compiled for AVX2: the same operations in the same order (Rust
    /// contracts no product and sum into a fused one), so the same bits, in three-operand
    /// instructions on eight lanes at once.
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    #[target_feature(enable = "avx2")]
    unsafe fn closest8_avx2<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry8],
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
    ) -> [Option<Hit>; 8] {
        self.closest8::<KZ, OCT>(stack, rays, t_min, t_max)
    }

    /// [`Bvh4::closest_hit8`] for rays whose dominant axis is `KZ`, in octant `OCT`:
    /// `packet.rs`'s `closest4` on eight lanes (inlined into its AVX2 twin).
    #[inline(always)]
    fn closest8<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry8],
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
    ) -> [Option<Hit>; 8] {
        let lanes = Lanes8::new(rays);
        let (mut best_t, mut best_tri) = (t_max, [u32::MAX; 8]);
        let mut sp = 0usize;
        let mut at = 0u32;
        let mut active = 0xffu32;
        loop {
            if at & LEAF == 0 {
                let node = &self.nodes[at as usize];
                let mut near = [[0.0f32; 8]; 4];
                let mut child_rays = [0u32; 4];
                for (c, (t, rays)) in near.iter_mut().zip(&mut child_rays).enumerate() {
                    let (n, mask) = lanes.enter::<OCT>(node, c, best_t);
                    (*t, *rays) = (n, mask & active);
                }
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
                        stack[sp] = Entry8 {
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
                let rays = bits8(e.t, best_t, |t, best| t <= best) & e.rays;
                if rays != 0 {
                    (at, active) = (e.at, rays);
                    break;
                }
            }
        }
    }
}
