//! Eight rays through the 4-wide BVH together: `packet.rs`'s closest-hit traversal
//! (`closest_packet`, generic over the lane count) with eight rays in the lanes instead of
//! four (one node fetch, one child ordering and one set of branches for eight neighbouring
//! rays), the same answers ray by ray (each ray tests the leaves whose box it enters, with the
//! single-ray triangle test and its own best distance). This file holds what only eight lanes
//! need: the choice between the two builds below.
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
//! Compiled with the feature `trace` only (closest hits are the tracer's). The batch API's
//! camera rays come in blocks of 4 × 2 pixels (`trace/batch.rs`). Tried and dropped:
//! the triangles of a leaf tested one at a time against the eight rays in the lanes (fewer
//! tests when more rays than triangles are active; measured slower).

use super::super::bvh::{Hit, Ray};
use super::packet::Entry;
use super::{Bvh4, INLINE_STACK, octant};

/// Eight lanes.
type F8 = [f32; 8];

/// `closest_hit8_with`'s stack, rays, `t_min`, `t_max` and whether to use AVX2.
type Args8<'a> = (&'a mut [Entry<8>], &'a [Ray; 8], f32, F8, bool);

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
        let stack: &mut [Entry<8>] = if self.stack <= INLINE_STACK {
            inline = [Entry::EMPTY; INLINE_STACK];
            &mut inline
        } else {
            heap = vec![Entry::EMPTY; self.stack];
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
        stack: &mut [Entry<8>],
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
        stack: &mut [Entry<8>],
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
    ) -> [Option<Hit>; 8] {
        self.closest8::<KZ, OCT>(stack, rays, t_min, t_max)
    }

    /// [`Bvh4::closest_hit8`] for rays whose dominant axis is `KZ`, in octant `OCT`:
    /// `packet.rs`'s traversal on eight lanes (inlined into its AVX2 twin).
    #[inline(always)]
    fn closest8<const KZ: usize, const OCT: usize>(
        &self,
        stack: &mut [Entry<8>],
        rays: &[Ray; 8],
        t_min: f32,
        t_max: F8,
    ) -> [Option<Hit>; 8] {
        self.closest_packet::<8, KZ, OCT>(stack, rays, t_min, t_max)
    }
}
