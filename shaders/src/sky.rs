//! A sky's direct light (`wgsl/sky.wgsl`): per element the sky's irradiance from its order-2
//! spherical-harmonic transfer and the frame's sky coefficients, reflected into the emission
//! the GPU evaluator bounces next. The GPU twin of the runtime's
//! `DirectLighting::sky_irradiance` + `reflected`; its uniform [`SkyParams`], bindings and
//! workgroup size.

use crate::{Access, Binding, bind};

/// The source (self-contained: no `common.wgsl`).
pub const SKY_PASS: &str = include_str!("../wgsl/sky.wgsl");

/// The entry point.
pub const SKY_ENTRY: &str = "sky_pass";

/// Invocations per workgroup. Mirrored by `SKY_LANES` in `wgsl/sky.wgsl`.
pub const SKY_LANES: u32 = 64;

use Access::{Read, ReadWrite, Uniform};

/// The bindings of `sky_pass`, all in group 0.
pub const SKY_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "coefficients", Read),
    bind(2, "transfer", Read),
    bind(3, "reflectance", Read),
    bind(4, "emission", ReadWrite),
];

crate::params::gpu_struct! {
    /// The uniform at binding 0 of `sky_pass` (`struct SkyParams` of `wgsl/sky.wgsl`, its
    /// twin): 16 bytes. Upload [`SkyParams::to_bytes`].
    pub struct SkyParams {
        /// The first element (original id) of the dispatch.
        pub first_element: u32,
        /// Elements of the dispatch.
        pub element_count: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
    }
}
