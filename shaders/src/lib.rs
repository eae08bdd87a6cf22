//! WGSL sources of lrr's per-frame evaluation, with their CPU mirrors.
//!
//! A frame relights the scene with the factored low-rank operator (DESIGN.md §2, "RGB without
//! tripling the operator"):
//!
//! ```text
//! B = E + ρ ⊙ F_k M (Vᵀ E)        per channel c:  B_c = E_c + ρ_c ⊙ F_k M_c Vᵀ E_c
//! ```
//!
//! in three passes, each a WGSL file under `shaders/wgsl/` and a function of the same name in
//! [`cpu`]:
//!
//! | pass | computes | cost |
//! |---|---|---|
//! | [`Pass::SegmentSums`] | `X[p][c] = Σ_{s=I[p]}^{I[p+1]-1} w[s] E[s][c]` (`X = Vᵀ E`, sparse `V`) | O(n) |
//! | [`Pass::CoreProduct`] | `Z[p][c] = Σ_q M_c[p][q] X[q][c]` (`Z_c = M_c X_c`) | O(k²) |
//! | [`Pass::Gather`] | `W[s][c] = Σ_q F_k[s][q] Z[q][c]`, `B[s][c] = E[s][c] + ρ[s][c] W[s][c]` | O(nk) |
//! | [`Pass::GatherF16`] | the same with `F_k` stored as IEEE binary16 | O(nk) |
//!
//! The gather reads `F_k` once for all three channels: the bytes a frame reads are those of one
//! `F_k`, not three `Y_k`.
//!
//! # Buffer layouts
//!
//! Everything is in file order (elements sorted by patch), little-endian, tightly packed:
//!
//! - RGB quantities (`E`, `ρ`, `B` per element; `X`, `Z` per patch) are 3 consecutive `f32` per
//!   entry, entry `s` at `3s..3s + 3`: the layout of `[[f32; 3]]` and of the file's reflectance,
//!   which therefore upload as they are. (`array<vec3<f32>>` would have a 16-byte stride; a
//!   `vec4` padding would cost a repack of every emission upload.)
//! - `I`: `k + 1` `u32` offsets, non-decreasing, `I[0] = 0`, `I[k] = n`; `w`: `n` `f32`.
//! - Cores: `channels` (1 or 3) `k × k` row-major `f32` matrices, core `c` at `c·k²`; with one
//!   core it serves all three channels. The file stores the cores as `f64`: narrow them once at
//!   load.
//! - `F_k`: `n × k` row-major `f32`, or binary16 packed two per `u32` (see [`Pass::GatherF16`]).
//!
//! # Bindings
//!
//! All in group 0; binding 0 of every pass is the [`Params`] uniform. [`Pass::bindings`] lists
//! them (a test checks the list against the parsed WGSL):
//!
//! | binding | segment_sums | core_product | gather, gather_f16 |
//! |---|---|---|---|
//! | 0 | `params` (uniform) | `params` | `params` |
//! | 1 | `index` `I` | `cores` `M` | `fk` `F_k` (`array<f32>` or `array<u32>`) |
//! | 2 | `weights` `w` | `x` `X` | `z` `Z` |
//! | 3 | `emission` `E` | `z` `Z` (read_write) | `emission` `E` |
//! | 4 | `x` `X` (read_write) | | `reflectance` `ρ` |
//! | 5 | | | `radiosity` `B` (read_write) |
//!
//! Every pass runs [`LANES`] invocations per workgroup and one workgroup per patch (segment_sums,
//! core_product) or per row of `F_k` (gather): lane `l` sums terms `l, l + LANES, …` (so a
//! workgroup reads its row in consecutive runs), then a binary tree adds the lanes. Dispatch
//! [`workgroups`]`(k)` or [`workgroups`]`(row_count)`.
//!
//! # F_k in row chunks
//!
//! lavapipe binds at most 128 MiB per storage buffer, less than `F_k` of a large scene. The
//! gather then runs once per chunk of rows with [`Params::rows`]: `row_offset` and `row_count`
//! say which rows of `B` the dispatch writes, `fk_offset` where the first of those rows starts
//! inside the bound view of `F_k` (the binding offset must be a multiple of the device's
//! `min_storage_buffer_offset_alignment`, so a chunk need not start on a binding boundary).
//! `E`, `ρ` and `B` (12 bytes per element) stay bound whole.
//!
//! # Why binary16 is packed in `u32`
//!
//! The file may store `F_k` as binary16, halving the bytes of the O(nk) pass. WGSL's `f16`
//! needs `enable f16;` (the optional `shader-f16` feature, missing on many adapters), and storage
//! buffers are arrays of 32-bit words, so the gather reads `u32` words: entry `2j` in the low
//! half of word `j`, entry `2j + 1` in the high half. That is exactly the file's little-endian
//! `u16` array read as words (padded with a zero half to a whole word; [`pack_f16`] does it for
//! a `&[u16]`).
//!
//! The shader widens a half with integer operations ([`cpu::f16_to_f32`] mirrors them), not
//! with `unpack2x16float`: naga accepts that builtin only with the `SHADER_FLOAT16_IN_FLOAT32`
//! capability, which wgpu grants from `DownlevelFlags::SHADER_F16_IN_F32`, documented as missing
//! on Mesa's Vulkan drivers (lavapipe among them) without `shader-f16`. The widening is exact,
//! subnormal halves included (they are normal f32s, out of reach of any flush-to-zero mode), so
//! every pass validates with no naga capability at all.
//!
//! # Example
//!
//! The CPU mirrors run the passes on the host, with the shaders' arithmetic and summation order:
//!
//! ```
//! use lrr_shaders::{Params, cpu};
//!
//! // Two elements in one patch (w = 1/2 each), a 1 x 1 core M = [2], grey ρ = 0.5.
//! let params = Params::new(2, 1, 1);
//! let (index, weights) = ([0, 2], [0.5, 0.5]);
//! let emission = [[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]];
//! let (cores, fk) = ([2.0], [0.25, 0.5]);
//! let rho = [[0.5; 3]; 2];
//!
//! let mut x = [[0.0; 3]; 1];
//! cpu::segment_sums(&params, &index, &weights, &emission, &mut x);
//! let mut z = [[0.0; 3]; 1];
//! cpu::core_product(&params, &cores, &x, &mut z);
//! let mut b = [[0.0; 3]; 2];
//! cpu::gather(&params, &fk, &z, &emission, &rho, &mut b);
//!
//! assert_eq!(x[0][0], 2.0); // (1 + 3) / 2
//! assert_eq!(z[0][0], 4.0); // 2 * 2
//! assert_eq!(b[0][0], 1.5); // 1 + 0.5 * 0.25 * 4
//! assert_eq!(b[1][0], 4.0); // 3 + 0.5 * 0.5 * 4
//! ```
//!
//! Getting a pass's source for `wgpu::ShaderSource::Wgsl`:
//!
//! ```
//! use lrr_shaders::{Pass, source};
//! let wgsl = source(Pass::Gather);
//! assert!(wgsl.contains("struct Params"));
//! assert!(wgsl.contains("fn gather("));
//! ```

#![forbid(unsafe_code)]

pub mod cpu;
mod half;
mod params;

#[cfg(test)]
mod naga_tests;

pub use half::pack_f16;
pub use params::Params;

/// Invocations per workgroup in every pass. Mirrored by `LANES` in `wgsl/common.wgsl` (a test
/// checks they agree); the CPU mirrors reduce over the same lanes in the same order.
pub const LANES: u32 = 64;

/// The most workgroups a dispatch may have in one dimension (WebGPU's default
/// `max_compute_workgroups_per_dimension`; also lavapipe's).
pub const MAX_WORKGROUPS_PER_DIMENSION: u32 = 65535;

/// Shared declarations, in front of every pass.
pub const COMMON: &str = include_str!("../wgsl/common.wgsl");
/// [`Pass::SegmentSums`] body.
pub const SEGMENT_SUMS: &str = include_str!("../wgsl/segment_sums.wgsl");
/// [`Pass::CoreProduct`] body.
pub const CORE_PRODUCT: &str = include_str!("../wgsl/core_product.wgsl");
/// `F_k` binding and loader for f32 storage ([`Pass::Gather`]).
pub const FK_F32: &str = include_str!("../wgsl/fk_f32.wgsl");
/// `F_k` binding and loader for packed binary16 storage ([`Pass::GatherF16`]).
pub const FK_F16: &str = include_str!("../wgsl/fk_f16.wgsl");
/// The gather body, shared by [`Pass::Gather`] and [`Pass::GatherF16`].
pub const GATHER: &str = include_str!("../wgsl/gather.wgsl");

/// One compute pass of the per-frame evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pass {
    /// `X = Vᵀ E`: `wgsl/segment_sums.wgsl`, mirror [`cpu::segment_sums`].
    SegmentSums,
    /// `Z_c = M_c X_c`: `wgsl/core_product.wgsl`, mirror [`cpu::core_product`].
    CoreProduct,
    /// `B = E + ρ ⊙ F_k Z`, `F_k` in f32: `wgsl/fk_f32.wgsl` + `wgsl/gather.wgsl`, mirror
    /// [`cpu::gather`].
    Gather,
    /// `B = E + ρ ⊙ F_k Z`, `F_k` in binary16 packed two per `u32`: `wgsl/fk_f16.wgsl` +
    /// `wgsl/gather.wgsl`, mirror [`cpu::gather_f16`].
    GatherF16,
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

const fn bind(binding: u32, name: &'static str, access: Access) -> Binding {
    Binding {
        binding,
        name,
        access,
    }
}

impl Pass {
    /// Every pass, in dispatch order (one of the two gathers runs).
    pub const ALL: [Pass; 4] = [
        Pass::SegmentSums,
        Pass::CoreProduct,
        Pass::Gather,
        Pass::GatherF16,
    ];

    /// The compute entry point's name.
    pub fn entry_point(self) -> &'static str {
        match self {
            Pass::SegmentSums => "segment_sums",
            Pass::CoreProduct => "core_product",
            Pass::Gather | Pass::GatherF16 => "gather",
        }
    }

    /// The files concatenated into this pass's source, in order.
    pub fn parts(self) -> &'static [&'static str] {
        match self {
            Pass::SegmentSums => &[COMMON, SEGMENT_SUMS],
            Pass::CoreProduct => &[COMMON, CORE_PRODUCT],
            Pass::Gather => &[COMMON, FK_F32, GATHER],
            Pass::GatherF16 => &[COMMON, FK_F16, GATHER],
        }
    }

    /// The pass's bindings (all in group 0), by binding number.
    pub fn bindings(self) -> &'static [Binding] {
        use Access::{Read, ReadWrite, Uniform};
        match self {
            Pass::SegmentSums => {
                const {
                    &[
                        bind(0, "params", Uniform),
                        bind(1, "index", Read),
                        bind(2, "weights", Read),
                        bind(3, "emission", Read),
                        bind(4, "x", ReadWrite),
                    ]
                }
            }
            Pass::CoreProduct => {
                const {
                    &[
                        bind(0, "params", Uniform),
                        bind(1, "cores", Read),
                        bind(2, "x", Read),
                        bind(3, "z", ReadWrite),
                    ]
                }
            }
            Pass::Gather | Pass::GatherF16 => {
                const {
                    &[
                        bind(0, "params", Uniform),
                        bind(1, "fk", Read),
                        bind(2, "z", Read),
                        bind(3, "emission", Read),
                        bind(4, "reflectance", Read),
                        bind(5, "radiosity", ReadWrite),
                    ]
                }
            }
        }
    }
}

/// The complete WGSL source of `pass`: `common.wgsl` followed by the pass's own files.
pub fn source(pass: Pass) -> String {
    pass.parts().join("\n")
}

/// The dispatch size for `count` workgroups (patches or rows): `[count, 1, 1]` while that fits
/// [`MAX_WORKGROUPS_PER_DIMENSION`], else a 2D grid whose surplus groups (at most one row's
/// worth) return at once. Covers up to 65535² ≈ 4.29e9 groups (`y` would pass the limit
/// beyond, for the last 131070 values of `u32`).
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
    fn sources_start_with_the_common_declarations() {
        for pass in Pass::ALL {
            let wgsl = source(pass);
            assert!(wgsl.starts_with(COMMON), "{pass:?}");
            assert!(wgsl.contains(&format!("fn {}(", pass.entry_point())));
        }
    }
}
