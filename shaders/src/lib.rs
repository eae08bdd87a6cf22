//! WGSL sources of lrr's per-frame evaluation, their contracts (bindings, pipeline constants,
//! the shared uniform) and their CPU mirrors. The runtime's `gpu` feature
//! (`lrr_runtime::gpu`) executes exactly these sources.
//!
//! A frame relights the scene with the factored low-rank operator (DESIGN.md §2, "RGB without
//! tripling the operator"):
//!
//! ```text
//! B = E + ρ ⊙ F_k M (Vᵀ E)        per channel c:  B_c = E_c + ρ_c ⊙ F_k M_c Vᵀ E_c
//! ```
//!
//! in passes, each a WGSL file under `shaders/wgsl/` and a function of the same name in [`cpu`]:
//!
//! | pass | file | computes | cost |
//! |---|---|---|---|
//! | [`Pass::SegmentSums`] | `segment_sums.wgsl` | `X_c[p] = Σ_{s=I[p]}^{I[p+1]-1} w[s] E[order[s]][c]` | O(n) |
//! | [`Pass::GroupSums`], [`Pass::GroupEmission`] | `light_groups.wgsl` | `X = Σ_g a_g x_g`, `E = Σ_g a_g E_g` on the lit elements | O(kG + lit) |
//! | [`Pass::CoreProduct`] | `core_product.wgsl` | `Z_c = M_c X_c` | O(k²) |
//! | [`Pass::Gather`] | `gather.wgsl` + a loader `fk_*.wgsl` + a reduction `reduce_*.wgsl` | `W = F_k Z`, `B = E + ρ ⊙ W` (plain: `B = E - Y X`) | O(nk) |
//!
//! The ray tracer's pass (`trace.wgsl`, [`TRACE`], [`TraceParams`], [`TraceConstants`]) shades
//! with the radiosity `B` these passes leave on the GPU; it does not use `common.wgsl` (its
//! source is `bvh.wgsl`, the file's BVH with its traversal and watertight test, and
//! `direct_light.wgsl`, lights that are not surfaces, joined with its own file) and its CPU
//! mirror is the runtime's CPU tracer (`lrr_runtime::trace`). Smooth shading adds
//! one pass before it, `smooth.wgsl` ([`SMOOTH_VERTICES`], mirror [`cpu::smooth_vertices`]):
//! the smooth-vertex values from `B`, which `trace.wgsl` interpolates by mean value coordinates
//! at each hit (mirror [`cpu::mean_value_weights`]). Lights that are not surfaces (point, spot,
//! sun) are shaded per hit by its `DIRECT` variant ([`direct_light`] records, the reflectance
//! per element), as the CPU twin's `Lighting::direct` does. The same lights enter a frame's
//! emission through the direct pass (`direct_pass.wgsl`, [`DIRECT_PASS`], [`DirectParams`],
//! [`direct_sample`]; it shares `bvh.wgsl` and `direct_light.wgsl` with the tracer): per element,
//! each light's irradiance averaged over fixed sample points behind any-hit shadow rays, `E =
//! base + ρ ⊙ H` written where the passes above read the emission; its CPU mirror is the
//! runtime's `DirectLighting`. A sky adds its light there too (`sky.wgsl`, [`SKY_PASS`],
//! [`SkyParams`]): per element `ρ ⊙ max(0, Σ L_lm T_lm)`, the transfer `T` (order-2 spherical
//! harmonics, the bake's or the CPU pass's projection) uploaded once, no ray.
//!
//! An engine that rasterises the scene takes the light as a lightmap: `lightmap.wgsl`
//! ([`LIGHTMAP_FILL`], [`LightmapParams`]) fills an `rgba16float` storage texture from `B` (smooth:
//! after `smooth.wgsl`, four smooth-vertex values per texel; flat: the element's value) and its
//! dilation rings (each ring texel expanded once into the same sources) in one dispatch; its
//! CPU twin is the runtime's `Lightmap`.
//!
//! [`Pass::Read`] (`read.wgsl`) is not a step of a frame: it reads the gather's bytes and
//! nothing else, the roofline the benchmark compares the gather with.
//!
//! The gather reads the stored matrix once for all three channels. `common.wgsl` holds what the
//! passes share: [`Params`] (the uniform at binding 0), `KP`, `reduce_lanes`.
//!
//! # Buffer layouts
//!
//! - Emission `E` and radiosity `B`: 3 `f32` per element in **original id** order (the caller's
//!   `[[f32; 3]]`, uploaded and read back as they are); the passes go through `order` (file
//!   position → id, a permutation).
//! - Reflectance `ρ`, weights `w`, index `I`: file order, as in the operator file.
//! - Per patch (`X`, `Z`, `x_g`): three planes of [`padded_k`]`(k)` = `KP` floats, channel `c` at
//!   `c·KP`, zero past `k`.
//! - Stored matrices (`F_k`, plain `Y_k` blocks, cores): rows of `KP` entries, `k` values then
//!   zeros, so every row is whole 32-byte octets and vector loads need no tail; `f32` or
//!   binary16 (entry `2m` in the low half of word `m`: the file's little-endian `u16` array).
//!   The rows of `F_k` (and the `blocks · n` rows of a plain `Y_k`) come in chunks of whole rows,
//!   each its own buffer and binding ([`Params::first_row`], [`Params::row_count`]), so an
//!   operator larger than the device's binding or buffer limit still runs.
//!
//! # Variants and pipeline constants
//!
//! Pipelines are specialised by WGSL `override` constants ([`GatherConstants`], `KP`), not by
//! string templates. What an adapter may lack is a separate file instead, because naga
//! validates a whole module: the binary16 loader (`fk_f16.wgsl` native `f16`,
//! `fk_f16_unpack.wgsl` `unpack2x16float`, `fk_f16_bits.wgsl` integer widening) and the row
//! reduction (`reduce_subgroup.wgsl` shuffles, `reduce_workgroup.wgsl` workgroup memory).
//!
//! # Example
//!
//! The CPU mirrors run the passes on the host, with the shaders' summation order:
//!
//! ```
//! use lrr_shaders::{GatherConstants, Params, cpu, padded_k};
//!
//! // Two elements in one patch (w = 1/2 each), a 1 x 1 core M = [2], grey ρ = 0.5.
//! let (n, k) = (2, 1);
//! let kp = padded_k(k) as usize;
//! let params = Params { n: n as u32, k: k as u32, row_count: n as u32, ..Params::default() };
//! let (index, weights, order) = ([0, 2], [0.5, 0.5], [0, 1]);
//! let emission = [[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
//! let mut core = vec![0.0; kp];
//! core[0] = 2.0;
//! let mut fk = vec![0.0; n * kp];
//! (fk[0], fk[kp]) = (0.25, 0.5);
//! let rho = [[0.5; 3]; 2];
//!
//! let mut x = vec![0.0; 3 * kp];
//! cpu::segment_sums(&params, kp, &index, &weights, &order, &emission, &mut x);
//! let mut z = vec![0.0; 3 * kp];
//! cpu::core_product(&params, kp, [&core, &core, &core], &x, &mut z);
//! let mut b = [[0.0; 3]; 2];
//! let gather = GatherConstants::new(kp as u32, true, false);
//! cpu::gather(&params, &gather, &cpu::Rows::F32(&fk), &z, &emission, &rho, &order, &mut b);
//!
//! assert_eq!(x[0], 2.0); // (1 + 3) / 2
//! assert_eq!(z[0], 4.0); // 2 * 2
//! assert_eq!(b[0][0], 1.5); // 1 + 0.5 * 0.25 * 4
//! assert_eq!(b[1][0], 4.0); // 3 + 0.5 * 0.5 * 4
//! ```
//!
//! # Why this is its own crate
//!
//! The runtime's `gpu` module is the only code that executes these sources, yet they live
//! here: the sources, their Rust twins and their mirrors form one contract that is tested on
//! any machine by `cargo test -p lrr-shaders` (naga parses and validates every variant; the
//! mirrors run against f64) without building wgpu or finding an adapter, and the default
//! runtime build stays free of them. The crate has no third-party dependency.

#![forbid(unsafe_code)]

pub mod cpu;
mod direct;
mod lightmap;
mod params;
mod sky;
mod smooth;
mod trace;

#[cfg(test)]
mod naga_tests;

pub use direct::{
    DIRECT_BINDINGS, DIRECT_ENTRY, DIRECT_LANES, DIRECT_NO_SLOT, DIRECT_PASS, DIRECT_SAMPLE_BYTES,
    DIRECT_SAMPLE_FIELDS, DIRECT_TRACE, DirectConstants, DirectParams, direct_cache_word,
    direct_sample,
};
pub use lightmap::{
    LIGHTMAP_BINDINGS, LIGHTMAP_ENTRY, LIGHTMAP_FILL, LIGHTMAP_FLAT, LIGHTMAP_LANES,
    LIGHTMAP_SMOOTH, LIGHTMAP_TILES, LightmapParams, TILE_DILATED, TILE_LANES, TILE_VERTICES,
    TILES_BINDINGS, TILES_ENTRY, TileParams,
};
pub use params::{GatherConstants, Params};
pub use sky::{SKY_BINDINGS, SKY_ENTRY, SKY_LANES, SKY_PASS, SkyParams};
pub use smooth::{SMOOTH_BINDINGS, SMOOTH_ENTRY, SMOOTH_LANES, SMOOTH_VERTICES, SmoothParams};
pub use trace::{
    DIRECT_LIGHT_BYTES, DIRECT_LIGHT_CACHE_WORD, DIRECT_LIGHT_FIELDS, DirectKind, LIGHT_BYTES,
    NO_CORNER, NODE_BYTES, OPTICS_BYTES, SMOOTH_ELEMENT_BYTES, SMOOTH_ELEMENT_FIELDS, TRACE,
    TRACE_BINDINGS, TRACE_ENTRY, TRACE_LANES, TraceConstants, TraceParams, direct_light,
    smooth_element,
};

/// Invocations per workgroup in segment_sums, core_product and the light-group passes.
/// Mirrored by `LANES` in `wgsl/common.wgsl` (a test checks they agree).
pub const LANES: u32 = 64;

/// Invocations per workgroup of the gather. Mirrored by `GATHER_SIZE` in `wgsl/gather.wgsl`.
pub const GATHER_SIZE: u32 = 256;

/// The most rows a gather lane takes per iteration ([`GatherConstants::rows`]). Mirrored by
/// `MAX_ROWS` in `wgsl/gather.wgsl`.
pub const MAX_GATHER_ROWS: u32 = 4;

/// The most workgroups a dispatch may have in one dimension (WebGPU's default
/// `max_compute_workgroups_per_dimension`; also lavapipe's).
pub const MAX_WORKGROUPS_PER_DIMENSION: u32 = 65535;

/// Shared declarations: [`Params`], `KP`, `LANES`, `reduce_lanes`.
pub const COMMON: &str = include_str!("../wgsl/common.wgsl");
/// [`Pass::SegmentSums`].
pub const SEGMENT_SUMS: &str = include_str!("../wgsl/segment_sums.wgsl");
/// [`Pass::GroupSums`] and [`Pass::GroupEmission`].
pub const LIGHT_GROUPS: &str = include_str!("../wgsl/light_groups.wgsl");
/// [`Pass::CoreProduct`].
pub const CORE_PRODUCT: &str = include_str!("../wgsl/core_product.wgsl");
/// The body of [`Pass::Gather`].
pub const GATHER: &str = include_str!("../wgsl/gather.wgsl");
/// [`Pass::Read`].
pub const READ: &str = include_str!("../wgsl/read.wgsl");
/// [`Storage::F32`] loader.
pub const FK_F32: &str = include_str!("../wgsl/fk_f32.wgsl");
/// [`Storage::F16`] loader (native `f16`; starts with `enable f16;`).
pub const FK_F16: &str = include_str!("../wgsl/fk_f16.wgsl");
/// [`Storage::F16Unpack`] loader.
pub const FK_F16_UNPACK: &str = include_str!("../wgsl/fk_f16_unpack.wgsl");
/// [`Storage::F16Bits`] loader.
pub const FK_F16_BITS: &str = include_str!("../wgsl/fk_f16_bits.wgsl");
/// [`Reduce::Subgroup`] row sums.
pub const REDUCE_SUBGROUP: &str = include_str!("../wgsl/reduce_subgroup.wgsl");
/// [`Reduce::Workgroup`] row sums.
pub const REDUCE_WORKGROUP: &str = include_str!("../wgsl/reduce_workgroup.wgsl");

/// How the gather reads the stored matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Storage {
    /// `f32` (`fk_f32.wgsl`).
    F32,
    /// binary16 as WGSL `f16` (`fk_f16.wgsl`): needs the adapter's `SHADER_F16`.
    F16,
    /// binary16 widened by `unpack2x16float` (`fk_f16_unpack.wgsl`): needs
    /// `DownlevelFlags::SHADER_F16_IN_F32`.
    F16Unpack,
    /// binary16 widened with integer operations (`fk_f16_bits.wgsl`): needs nothing.
    F16Bits,
}

/// How the gather adds a row's partial sums across its lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Reduce {
    /// Subgroup shuffles (`reduce_subgroup.wgsl`): needs the adapter's `SUBGROUP`.
    Subgroup,
    /// Workgroup memory and barriers (`reduce_workgroup.wgsl`): needs nothing.
    Workgroup,
}

/// One compute pass (entry point) of the per-frame evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pass {
    /// `X = Vᵀ E`: mirror [`cpu::segment_sums`].
    SegmentSums,
    /// `X = Σ_g a_g x_g`: mirror [`cpu::group_sums`].
    GroupSums,
    /// `E = Σ_g a_g E_g` on the lit elements: mirror [`cpu::group_emission`].
    GroupEmission,
    /// `Z_c = M_c X_c`: mirror [`cpu::core_product`].
    CoreProduct,
    /// `B = E + ρ ⊙ F_k Z` (or `E - Y X`): mirror [`cpu::gather`].
    Gather(Storage, Reduce),
    /// Not a step of a frame: the gather's read roofline over the same bytes, mirror
    /// [`cpu::read_matrix`].
    Read,
}

/// How a pass accesses one binding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Access {
    /// `var<uniform>`.
    Uniform,
    /// `var<storage, read>`.
    Read,
    /// `var<storage, read_write>`.
    ReadWrite,
    /// `texture_storage_2d<rgba16float, write>`: a 2D storage texture the pass writes.
    WriteTexture,
}

/// One binding of a pass, in group 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Binding {
    /// The `@binding` number.
    pub binding: u32,
    /// The WGSL variable's name.
    pub name: &'static str,
    /// How the pass accesses it.
    pub access: Access,
}

pub(crate) const fn bind(binding: u32, name: &'static str, access: Access) -> Binding {
    Binding {
        binding,
        name,
        access,
    }
}

use Access::{Read, ReadWrite, Uniform};

const SEGMENT_SUMS_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "index", Read),
    bind(2, "weights", Read),
    bind(3, "order", Read),
    bind(4, "emission", Read),
    bind(5, "x", ReadWrite),
];
const GROUP_SUMS_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "intensities", Read),
    bind(2, "group_x", Read),
    bind(8, "x", ReadWrite),
];
const GROUP_EMISSION_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "intensities", Read),
    bind(3, "position", Read),
    bind(4, "starts", Read),
    bind(5, "members", Read),
    bind(6, "member_emission", Read),
    bind(7, "order", Read),
    bind(9, "emission", ReadWrite),
];
const CORE_PRODUCT_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "core_r", Read),
    bind(2, "core_g", Read),
    bind(3, "core_b", Read),
    bind(4, "x", Read),
    bind(5, "z", ReadWrite),
];
const GATHER_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "fk", Read),
    bind(2, "z", Read),
    bind(3, "emission", Read),
    bind(4, "reflectance", Read),
    bind(5, "order", Read),
    bind(6, "radiosity", ReadWrite),
];
const READ_BINDINGS: &[Binding] = &[bind(1, "fk", Read), bind(2, "sink", ReadWrite)];

impl Pass {
    /// Every pass and variant.
    pub const ALL: [Pass; 13] = [
        Pass::SegmentSums,
        Pass::GroupSums,
        Pass::GroupEmission,
        Pass::CoreProduct,
        Pass::Gather(Storage::F32, Reduce::Subgroup),
        Pass::Gather(Storage::F32, Reduce::Workgroup),
        Pass::Gather(Storage::F16, Reduce::Subgroup),
        Pass::Gather(Storage::F16, Reduce::Workgroup),
        Pass::Gather(Storage::F16Unpack, Reduce::Subgroup),
        Pass::Gather(Storage::F16Unpack, Reduce::Workgroup),
        Pass::Gather(Storage::F16Bits, Reduce::Subgroup),
        Pass::Gather(Storage::F16Bits, Reduce::Workgroup),
        Pass::Read,
    ];

    /// The compute entry point's name (also the CPU mirror's).
    pub fn entry_point(self) -> &'static str {
        match self {
            Pass::SegmentSums => "segment_sums",
            Pass::GroupSums => "group_sums",
            Pass::GroupEmission => "group_emission",
            Pass::CoreProduct => "core_product",
            Pass::Gather(..) => "gather",
            Pass::Read => "read_matrix",
        }
    }

    /// The files concatenated into this pass's source, in order. A loader comes first: it may
    /// carry `enable f16;`, which must precede every declaration.
    pub fn parts(self) -> Vec<&'static str> {
        match self {
            Pass::SegmentSums => vec![COMMON, SEGMENT_SUMS],
            Pass::GroupSums | Pass::GroupEmission => vec![COMMON, LIGHT_GROUPS],
            Pass::CoreProduct => vec![COMMON, CORE_PRODUCT],
            Pass::Read => vec![COMMON, READ],
            Pass::Gather(storage, reduce) => {
                let loader = match storage {
                    Storage::F32 => FK_F32,
                    Storage::F16 => FK_F16,
                    Storage::F16Unpack => FK_F16_UNPACK,
                    Storage::F16Bits => FK_F16_BITS,
                };
                let reduce = match reduce {
                    Reduce::Subgroup => REDUCE_SUBGROUP,
                    Reduce::Workgroup => REDUCE_WORKGROUP,
                };
                vec![loader, COMMON, GATHER, reduce]
            }
        }
    }

    /// The bindings the entry point uses (all in group 0), by binding number. The light-group
    /// entry points share one file and use a part of its bindings each.
    pub fn bindings(self) -> &'static [Binding] {
        match self {
            Pass::SegmentSums => SEGMENT_SUMS_BINDINGS,
            Pass::GroupSums => GROUP_SUMS_BINDINGS,
            Pass::GroupEmission => GROUP_EMISSION_BINDINGS,
            Pass::CoreProduct => CORE_PRODUCT_BINDINGS,
            Pass::Gather(..) => GATHER_BINDINGS,
            Pass::Read => READ_BINDINGS,
        }
    }

    /// Whether the pass needs the adapter's `SHADER_F16` feature.
    pub fn needs_f16(self) -> bool {
        matches!(self, Pass::Gather(Storage::F16, _))
    }

    /// Whether the pass needs `DownlevelFlags::SHADER_F16_IN_F32`.
    pub fn needs_f16_in_f32(self) -> bool {
        matches!(self, Pass::Gather(Storage::F16Unpack, _))
    }

    /// Whether the pass needs the adapter's `SUBGROUP` feature.
    pub fn needs_subgroups(self) -> bool {
        matches!(self, Pass::Gather(_, Reduce::Subgroup))
    }
}

/// The complete WGSL source of `pass`: its parts joined.
pub fn source(pass: Pass) -> String {
    pass.parts().join("\n")
}

/// `KP`: the padded row length of the stored matrices and the plane stride of `X` and `Z`, for
/// `k` patches: `k` rounded up to a multiple of 8 (one octet: 32 bytes of f32, 16 of binary16).
pub fn padded_k(k: u32) -> u32 {
    k.next_multiple_of(8)
}

/// The dispatch size for `count` workgroups (patches): `[count, 1, 1]` while that fits
/// [`MAX_WORKGROUPS_PER_DIMENSION`], else a 2D grid whose surplus groups (at most one row's
/// worth) return at once. Covers up to 65535² ≈ 4.29e9 groups.
pub fn workgroups(count: u32) -> [u32; 3] {
    if count <= MAX_WORKGROUPS_PER_DIMENSION {
        [count, 1, 1]
    } else {
        let x = MAX_WORKGROUPS_PER_DIMENSION;
        [x, count.div_ceil(x), 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_dispatches_are_one_dimensional() {
        assert_eq!(workgroups(0), [0, 1, 1]);
        assert_eq!(workgroups(1), [1, 1, 1]);
        assert_eq!(workgroups(65535), [65535, 1, 1]);
    }

    #[test]
    fn large_dispatches_cover_every_group_once() {
        for count in [65536, 131070, 131071, 1_000_000, 65535 * 65535] {
            let [x, y, z] = workgroups(count);
            assert!(x <= MAX_WORKGROUPS_PER_DIMENSION && y <= MAX_WORKGROUPS_PER_DIMENSION);
            assert_eq!(z, 1);
            let groups = u64::from(x) * u64::from(y);
            assert!(groups >= u64::from(count), "{count}: {x} x {y}");
            assert!(
                groups - u64::from(count) < u64::from(x),
                "{count}: a whole row spare"
            );
        }
    }

    #[test]
    fn sources_hold_common_and_their_entry_point() {
        for pass in Pass::ALL {
            let wgsl = source(pass);
            assert!(wgsl.contains(COMMON), "{pass:?}");
            assert!(wgsl.contains(&format!("fn {}(", pass.entry_point())));
        }
    }

    #[test]
    fn padding_is_whole_octets() {
        assert_eq!(padded_k(1), 8);
        assert_eq!(padded_k(8), 8);
        assert_eq!(padded_k(216), 216);
        assert_eq!(padded_k(217), 224);
    }
}
