//! The smooth reconstruction's per-frame pass (`wgsl/smooth.wgsl`): each smooth vertex's value
//! from the relighting's radiosity buffer, what the ray tracer's `SMOOTH` variant
//! (`wgsl/trace.wgsl`) interpolates at its hits. Its uniform [`SmoothParams`], bindings and
//! workgroup size; the CPU mirror is [`cpu::smooth_vertices`](crate::cpu::smooth_vertices), and
//! the runtime's `Reconstruction::vertex_values` (f64 sums) is what both approximate.

use crate::{Access, Binding, bind};

/// The source (self-contained: no `common.wgsl`).
pub const SMOOTH_VERTICES: &str = include_str!("../wgsl/smooth.wgsl");

/// The entry point (also the CPU mirror's name).
pub const SMOOTH_ENTRY: &str = "smooth_vertices";

/// Invocations per workgroup (one per smooth vertex). Mirrored by `SMOOTH_LANES` in
/// `wgsl/smooth.wgsl`.
pub const SMOOTH_LANES: u32 = 64;

use Access::{Read, ReadWrite, Uniform};

/// The bindings of `smooth_vertices`, all in group 0.
pub const SMOOTH_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "offsets", Read),
    bind(2, "elements", Read),
    bind(3, "weights", Read),
    bind(4, "radiosity", Read),
    bind(5, "vertex_values", ReadWrite),
];

crate::params::gpu_struct! {
    /// The uniform at binding 0 of `smooth_vertices` (`struct SmoothParams` of
    /// `wgsl/smooth.wgsl`, its twin): 16 bytes. Upload [`SmoothParams::to_bytes`].
    pub struct SmoothParams {
        /// Smooth vertices (invocations that compute; the rest return).
        pub vertex_count: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
        /// Zero.
        pub reserved2: u32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_are_16_bytes_in_field_order() {
        let p = SmoothParams {
            vertex_count: 77,
            ..SmoothParams::default()
        };
        assert_eq!(&p.to_bytes()[..4], &77u32.to_le_bytes());
        assert_eq!(SmoothParams::FIELDS[0], ("vertex_count", 0));
        assert_eq!(4 * SmoothParams::FIELDS.len(), SmoothParams::SIZE);
    }
}
