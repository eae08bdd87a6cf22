//! The per-dispatch uniform shared by every pass.
//!
//! Mirrored by `struct Params` in `wgsl/common.wgsl`: same fields, same order, all `u32`, so the
//! offsets agree without padding rules. `naga_tests.rs` lays the WGSL struct out with naga and
//! compares its member names, offsets and size with [`Params::FIELDS`] (`offset_of!`). Also the
//! gather's pipeline constants, [`GatherConstants`].

/// Declares the `#[repr(C)]` struct and its field table from one list, so the names the layout
/// test compares are the Rust field names themselves.
macro_rules! gpu_struct {
    ($(#[$meta:meta])* pub struct $name:ident { $($(#[$field_meta:meta])* pub $field:ident: u32,)* }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub struct $name {
            $($(#[$field_meta])* pub $field: u32,)*
        }

        impl $name {
            /// Every field's name and byte offset, in declaration order.
            pub const FIELDS: &'static [(&'static str, usize)] =
                &[$((stringify!($field), core::mem::offset_of!($name, $field)),)*];

            /// Size in bytes, on the host and in WGSL (four per `u32` field; a naga test
            /// compares it with the WGSL struct's).
            pub const SIZE: usize = core::mem::size_of::<$name>();

            /// The bytes to upload: the fields in order, little-endian (what the GPU reads on
            /// every wgpu target).
            pub fn to_bytes(&self) -> [u8; Self::SIZE] {
                let fields = [$(self.$field,)*];
                let mut bytes = [0; Self::SIZE];
                for (chunk, field) in bytes.chunks_exact_mut(4).zip(fields) {
                    chunk.copy_from_slice(&field.to_le_bytes());
                }
                bytes
            }
        }

        const _: () = assert!(core::mem::size_of::<$name>() == 4 * [$(stringify!($field),)*].len());
    };
}
pub(crate) use gpu_struct;

gpu_struct! {
    /// The uniform at binding 0 of every pass (`var<uniform> params: Params` in
    /// `wgsl/common.wgsl`, its twin). [`Params::SIZE`] = 32 bytes: eight `u32`, a multiple of 16
    /// as every backend's uniform rules accept. Upload [`Params::to_bytes`].
    pub struct Params {
        /// Elements: rows of `F_k`, entries of `E`, `ρ` and `B`.
        pub n: u32,
        /// Patches: columns of `F_k`, rows of the cores, entries of `X` and `Z`.
        pub k: u32,
        /// Gather: the first stored row of the chunk bound to the dispatch (plain RGB `Y_k`:
        /// rows run over the three blocks, block `c` holding rows `c·n .. c·n + n`).
        pub first_row: u32,
        /// Gather: the rows of that chunk.
        pub row_count: u32,
        /// Light-group passes: the number of groups.
        pub groups: u32,
        /// `group_emission`: distinct file positions lit by some group.
        pub positions: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
    }
}

/// The gather's pipeline constants (`override` declarations in `wgsl/gather.wgsl`, plus `KP`
/// from `wgsl/common.wgsl`). A test checks the names against the parsed WGSL.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GatherConstants {
    /// `KP`: padded row length, a multiple of 8 (see [`padded_k`](crate::padded_k)).
    pub kp: u32,
    /// `ROW_LANES`: lanes per row, a power of two from 1 to 32 (at most the adapter's smallest
    /// subgroup with [`Reduce::Subgroup`](crate::Reduce::Subgroup)).
    pub row_lanes: u32,
    /// `Z_SHARED`: copy `Z` into workgroup memory (`12·KP` bytes of it).
    pub z_shared: bool,
    /// `FACTORED`: `B = E + ρ W`; else `B = E - W` (plain `Y_k`).
    pub factored: bool,
    /// `PER_BLOCK`: plain RGB, stored row block `c` serves channel `c` alone.
    pub per_block: bool,
    /// `ROWS`: rows each lane takes per iteration of the gather's loop, 1 to
    /// [`MAX_GATHER_ROWS`](crate::MAX_GATHER_ROWS) (more independent loads in flight).
    pub rows: u32,
}

impl GatherConstants {
    /// Constants for rows of `kp` entries: Z shared, [`row_lanes_for`](Self::row_lanes_for)
    /// with subgroups of 32.
    pub fn new(kp: u32, factored: bool, per_block: bool) -> Self {
        GatherConstants {
            kp,
            row_lanes: Self::row_lanes_for(kp, 32),
            z_shared: true,
            factored,
            per_block,
            rows: 1,
        }
    }

    /// Lanes per row for rows of `kp` entries: about four octets per lane (enough independent
    /// loads in flight, few idle lanes at a row's end), a power of two up to
    /// `min(32, max_lanes)`.
    pub fn row_lanes_for(kp: u32, max_lanes: u32) -> u32 {
        let cap = max_lanes.clamp(1, 32);
        (kp / 8 / 4).max(1).next_power_of_two().min(cap)
    }

    /// `OCTETS_PER_LANE`: octets of a row each lane loads, `⌈KP / 8 / ROW_LANES⌉`.
    pub fn octets_per_lane(&self) -> u32 {
        (self.kp / 8).div_ceil(self.row_lanes.max(1)).max(1)
    }

    /// Rows a workgroup takes per iteration: `GATHER_SIZE / ROW_LANES · ROWS`.
    pub fn rows_per_iteration(&self) -> u32 {
        crate::GATHER_SIZE / self.row_lanes.max(1) * self.rows
    }

    /// `ZS_QUADS`: the vec4s of the workgroup copy of `Z` (1 when not shared).
    pub fn zs_quads(&self) -> u32 {
        if self.z_shared { 3 * self.kp / 4 } else { 1 }
    }

    /// Bytes of workgroup memory the gather declares: `Z` and the workgroup reduction's
    /// partial sums (16 bytes per invocation, counted for both reductions).
    pub fn workgroup_bytes(&self) -> u32 {
        16 * self.zs_quads() + 16 * crate::GATHER_SIZE
    }

    /// The `(name, value)` pairs for `wgpu::PipelineCompilationOptions::constants`.
    pub fn constants(&self) -> [(&'static str, f64); 8] {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        [
            ("KP", f64::from(self.kp)),
            ("ROW_LANES", f64::from(self.row_lanes)),
            ("OCTETS_PER_LANE", f64::from(self.octets_per_lane())),
            ("ROWS", f64::from(self.rows)),
            ("Z_SHARED", flag(self.z_shared)),
            ("ZS_QUADS", f64::from(self.zs_quads())),
            ("FACTORED", flag(self.factored)),
            ("PER_BLOCK", flag(self.per_block)),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_is_32_bytes_and_fields_are_packed_u32() {
        assert_eq!(size_of::<Params>(), Params::SIZE);
        assert_eq!(align_of::<Params>(), 4);
        assert_eq!(
            Params::SIZE % 16,
            0,
            "uniform buffers want 16-byte multiples"
        );
        for (i, &(_, offset)) in Params::FIELDS.iter().enumerate() {
            assert_eq!(offset, 4 * i);
        }
        assert_eq!(4 * Params::FIELDS.len(), Params::SIZE);
    }

    #[test]
    fn bytes_follow_the_field_order() {
        let p = Params {
            n: 10,
            k: 3,
            first_row: 4,
            row_count: 6,
            groups: 2,
            positions: 5,
            ..Params::default()
        };
        let words: Vec<u32> = p
            .to_bytes()
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(words, [10, 3, 4, 6, 2, 5, 0, 0]);
    }

    #[test]
    fn row_lanes_are_powers_of_two_within_the_subgroup() {
        for kp in (8..5000).step_by(8) {
            for max in [1, 4, 8, 16, 32, 64, 128] {
                let l = GatherConstants::row_lanes_for(kp, max);
                assert!(
                    l.is_power_of_two() && l <= 32 && l <= max.max(1),
                    "{kp} {max}: {l}"
                );
            }
        }
        assert_eq!(GatherConstants::row_lanes_for(216, 32), 8);
        assert_eq!(GatherConstants::row_lanes_for(3744, 32), 32);
    }
}
