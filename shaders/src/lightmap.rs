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

/// [`LightmapParams::mode`]: smooth samples (four smooth vertices and weights each).
pub const LIGHTMAP_SMOOTH: u32 = 0;
/// [`LightmapParams::mode`]: flat samples (the element's radiosity).
pub const LIGHTMAP_FLAT: u32 = 1;

use Access::{Read, Uniform, WriteTexture};

/// The bindings of `lightmap_fill`, all in group 0 (seven storage buffers: within WebGPU's
/// default of eight per stage).
pub const LIGHTMAP_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "samples", Read),
    bind(2, "run_base", Read),
    bind(3, "run_index", Read),
    bind(4, "rings", Read),
    bind(5, "ring_source", Read),
    bind(6, "ring_weight", Read),
    bind(7, "table", Read),
    bind(8, "atlas", WriteTexture),
];

crate::params::gpu_struct! {
    /// The uniform at binding 0 of `lightmap_fill` (`struct LightmapParams` of
    /// `wgsl/lightmap.wgsl`, its twin): 32 bytes. Upload [`LightmapParams::to_bytes`].
    pub struct LightmapParams {
        /// Samples: the invocations before the dilated texels.
        pub samples: u32,
        /// Invocations that compute (samples and dilated texels; the rest return).
        pub count: u32,
        /// Texels across the atlas.
        pub width: u32,
        /// [`LIGHTMAP_SMOOTH`] or [`LIGHTMAP_FLAT`].
        pub mode: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
        /// Zero.
        pub reserved2: u32,
        /// Zero.
        pub reserved3: u32,
    }
}
