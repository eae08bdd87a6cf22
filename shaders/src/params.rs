//! The per-dispatch uniform shared by every pass.
//!
//! Mirrored by `struct Params` in `wgsl/common.wgsl`: same fields, same order, all `u32`, so the
//! offsets agree without padding rules. `naga_tests.rs` parses the WGSL struct and compares its
//! member names and offsets with [`Params::FIELDS`].

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
        }
    };
}

gpu_struct! {
    /// The uniform at binding 0 of every pass (`var<uniform> params: Params` in
    /// `wgsl/common.wgsl`, its twin). [`Params::SIZE`] = 32 bytes: eight `u32`, a multiple of 16
    /// as every backend's uniform rules accept. Upload [`Params::to_bytes`].
    pub struct Params {
        /// Elements: rows of `F_k`, entries of `E`, `ρ` and `B`.
        pub n: u32,
        /// Patches: columns of `F_k`, rows of the cores, entries of `X` and `Z`.
        pub k: u32,
        /// `k × k` cores: 1 (serving all three channels) or 3 (one per channel).
        pub channels: u32,
        /// Gather: the first element (row of `F_k`) this dispatch writes.
        pub row_offset: u32,
        /// Gather: how many rows this dispatch writes, from `row_offset` on.
        pub row_count: u32,
        /// Gather: the index, in entries of the bound `F_k` view (halves for binary16), where row
        /// `row_offset` starts. 0 when the view starts at that row.
        pub fk_offset: u32,
        /// Zero.
        pub reserved0: u32,
        /// Zero.
        pub reserved1: u32,
    }
}

impl Params {
    /// Size in bytes, on the host and in WGSL.
    pub const SIZE: usize = 32;

    /// Parameters for the whole operator: the gather covers rows `0..n` with `F_k` bound whole.
    pub fn new(n: u32, k: u32, channels: u32) -> Self {
        Params {
            n,
            k,
            channels,
            row_count: n,
            ..Params::default()
        }
    }

    /// The same operator, for a gather over rows `row_offset..row_offset + row_count` whose
    /// first row starts at entry `fk_offset` of the bound `F_k` view.
    pub fn rows(self, row_offset: u32, row_count: u32, fk_offset: u32) -> Self {
        Params {
            row_offset,
            row_count,
            fk_offset,
            ..self
        }
    }

    /// The bytes to upload: the fields in order, in the host's byte order (what the GPU reads on
    /// every wgpu target, all little-endian).
    pub fn to_bytes(&self) -> [u8; Self::SIZE] {
        let fields = [
            self.n,
            self.k,
            self.channels,
            self.row_offset,
            self.row_count,
            self.fk_offset,
            self.reserved0,
            self.reserved1,
        ];
        let mut bytes = [0; Self::SIZE];
        for (chunk, field) in bytes.chunks_exact_mut(4).zip(fields) {
            chunk.copy_from_slice(&field.to_ne_bytes());
        }
        bytes
    }
}

const _: () = assert!(size_of::<Params>() == Params::SIZE);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_is_32_bytes_and_fields_are_packed_u32() {
        assert_eq!(size_of::<Params>(), Params::SIZE);
        assert_eq!(Params::SIZE, 32);
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
        let p = Params::new(10, 3, 1).rows(4, 6, 2);
        let words: Vec<u32> = p
            .to_bytes()
            .chunks_exact(4)
            .map(|c| u32::from_ne_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(words, [10, 3, 1, 4, 6, 2, 0, 0]);
    }
}
