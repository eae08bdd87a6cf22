//! Hashing for deterministic sampling: every random choice of a bake is a hash of what it is
//! for (an element-patch pair, a point), so results do not depend on threads or order.

/// A 64-bit finaliser (SplitMix64) used to derive per-pair shifts.
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}
