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

/// The smooth fill in tiles (`wgsl/lightmap_tiles.wgsl`): the smooth vertices computed by each
/// tile's workgroup in its own memory, then its texels, in one dispatch with no smooth pass.
pub const LIGHTMAP_TILES: &str = include_str!("../wgsl/lightmap_tiles.wgsl");

/// Its entry point.
pub const TILES_ENTRY: &str = "lightmap_tiles";

/// Texels a tile holds at most: invocations per workgroup. Mirrored by `TILE_LANES` in
/// `wgsl/lightmap_tiles.wgsl`.
pub const TILE_LANES: u32 = 128;

/// Smooth vertices a tile reads at most (its workgroup memory: 16 bytes each; a byte indexes
/// them). Mirrored by `TILE_VERTICES` in `wgsl/lightmap_tiles.wgsl`.
pub const TILE_VERTICES: u32 = 256;

/// The bit of a texel item's texel that marks a dilated texel (atlases hold under 2³¹
/// texels). Mirrored by `DILATED` in `wgsl/lightmap_tiles.wgsl`.
pub const TILE_DILATED: u32 = 1 << 31;

/// The bindings of `lightmap_tiles`, all in group 0 (seven storage buffers: within WebGPU's
/// default of eight per stage).
pub const TILES_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "tiles", Read),
    bind(2, "tile_vertices", Read),
    bind(3, "entries", Read),
    bind(4, "radiosity", Read),
    bind(5, "items", Read),
    bind(6, "slots", Read),
    bind(7, "terms", Read),
    bind(8, "atlas", WriteTexture),
];

crate::params::gpu_struct! {
    /// The uniform at binding 0 of `lightmap_tiles` (`struct TileParams` of
    /// `wgsl/lightmap_tiles.wgsl`, its twin): 16 bytes. Upload [`TileParams::to_bytes`].
    pub struct TileParams {
        /// Texels across the atlas.
        pub width: u32,
        /// Tiles: the workgroups that compute (the rest return).
        pub tiles: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
    }
}
