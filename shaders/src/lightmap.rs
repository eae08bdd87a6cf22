//! The lightmap fill (`wgsl/lightmap.wgsl`): a frame's radiosity as lightmap texels in an
//! `rgba16float` storage texture, the GPU twin of the runtime's `Lightmap::fill` (whose CPU
//! code is its mirror). Its uniform [`LightmapParams`], modes, bindings and workgroup size.

use crate::{Access, Binding, bind};

/// The source (self-contained: no `common.wgsl`).
pub const LIGHTMAP_FILL: &str = include_str!("../wgsl/lightmap.wgsl");

/// The entry point.
pub const LIGHTMAP_ENTRY: &str = "lightmap_fill";

/// Invocations per workgroup. Mirrored by `LIGHTMAP_LANES` in `wgsl/lightmap.wgsl`.
pub const LIGHTMAP_LANES: u32 = 64;

/// [`LightmapParams::mode`]: samples, smooth (four smooth vertices each).
pub const LIGHTMAP_SMOOTH: u32 = 0;
/// [`LightmapParams::mode`]: samples, flat (the element's radiosity).
pub const LIGHTMAP_FLAT: u32 = 1;
/// [`LightmapParams::mode`]: one dilation ring.
pub const LIGHTMAP_RING: u32 = 2;

use Access::{Read, ReadWrite, Uniform, WriteTexture};

/// The bindings of `lightmap_fill`, all in group 0.
pub const LIGHTMAP_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "texel", Read),
    bind(2, "index", Read),
    bind(3, "weight", Read),
    bind(4, "table", Read),
    bind(5, "values", ReadWrite),
    bind(6, "neighbour_ends", Read),
    bind(7, "neighbours", Read),
    bind(8, "atlas", WriteTexture),
];

crate::params::gpu_struct! {
    /// The uniform at binding 0 of `lightmap_fill` (`struct LightmapParams` of
    /// `wgsl/lightmap.wgsl`, its twin): 32 bytes. Upload [`LightmapParams::to_bytes`].
    pub struct LightmapParams {
        /// Invocations that compute (the rest return).
        pub count: u32,
        /// The compact id of the first (samples, then dilated texels in ring order).
        pub first: u32,
        /// Texels across the atlas.
        pub width: u32,
        /// [`LIGHTMAP_SMOOTH`], [`LIGHTMAP_FLAT`] or [`LIGHTMAP_RING`].
        pub mode: u32,
        /// Samples: the compact id of the first dilated texel.
        pub samples: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
        /// Zero.
        pub reserved2: u32,
    }
}
