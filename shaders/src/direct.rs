//! The direct pass of lights that are not surfaces (`wgsl/direct_pass.wgsl`): per element, each
//! light's irradiance averaged over the element's fixed sample points behind any-hit shadow rays
//! through the file's BVH, reflected into the emission the evaluator bounces next. Its uniform
//! [`DirectParams`], its bindings, its per-sample record [`direct_sample`] and its pipeline
//! constants [`DirectConstants`]. Its CPU mirror is the runtime's CPU pass itself
//! (`lrr_runtime::lights::DirectLighting::irradiance` and `reflected`; the runtime's
//! `tests/gpu_direct.rs` compares them); this crate's naga tests parse, validate, specialise and
//! compile it.
//!
//! The source shares the BVH's traversal and watertight test (`wgsl/bvh.wgsl`) and the lights'
//! records and geometry (`wgsl/direct_light.wgsl`, [`direct_light`](crate::direct_light)) with
//! the ray tracer's pass ([`TRACE`](crate::TRACE)): naga validates whole modules, so each pass's
//! source is the shared parts joined with its own file.

use crate::{Access, Binding, bind};

/// The source: `bvh.wgsl`, `direct_light.wgsl` and `direct_pass.wgsl` joined (no
/// `common.wgsl`).
pub const DIRECT_PASS: &str = concat!(
    include_str!("../wgsl/bvh.wgsl"),
    "\n",
    include_str!("../wgsl/direct_light.wgsl"),
    "\n",
    include_str!("../wgsl/direct_pass.wgsl"),
);

/// The entry point.
pub const DIRECT_ENTRY: &str = "direct_pass";

/// Invocations per workgroup (one per element). Mirrored by `DIRECT_LANES` in
/// `wgsl/direct_pass.wgsl`.
pub const DIRECT_LANES: u32 = 64;

/// Size of an element of `samples` in bytes (`struct Sample` of `direct_pass.wgsl`:
/// [`direct_sample`]'s 8 words; a naga test checks).
pub const DIRECT_SAMPLE_BYTES: usize = 32;

/// Names and byte offsets of `struct Sample` in `direct_pass.wgsl` (a naga test compares).
pub const DIRECT_SAMPLE_FIELDS: &[(&str, usize)] = &[
    ("point", 0),
    ("valid", 12),
    ("normal", 16),
    ("reserved", 28),
];

/// One sample point of an element as the direct pass reads it (`struct Sample`, binding
/// `samples`): the 8 words to upload, at the offsets of [`DIRECT_SAMPLE_FIELDS`]. A point that is
/// not finite (the CPU pass's mark for an element drawn by no triangle of area, whose samples see
/// no light) is uploaded as the origin with `valid` 0, which the shader skips before any ray.
pub fn direct_sample(point: [f32; 3], normal: [f32; 3]) -> [u32; 8] {
    let valid = point.iter().chain(&normal).all(|c| c.is_finite());
    let (point, normal) = if valid {
        (point, normal)
    } else {
        ([0.0; 3], [0.0; 3])
    };
    let [p0, p1, p2] = point.map(f32::to_bits);
    let [n0, n1, n2] = normal.map(f32::to_bits);
    [p0, p1, p2, u32::from(valid), n0, n1, n2, 0]
}

use Access::{Read, ReadWrite, Uniform};

/// The bindings of `direct_pass`, all in group 0 (1 and 2 are `bvh.wgsl`'s, as in
/// [`TRACE_BINDINGS`](crate::TRACE_BINDINGS)).
pub const DIRECT_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "nodes", Read),
    bind(2, "tris", Read),
    bind(3, "samples", Read),
    bind(4, "direct_lights", Read),
    bind(5, "reflectance", Read),
    bind(6, "emission", ReadWrite),
    bind(7, "irradiance", ReadWrite),
    bind(8, "terms", ReadWrite),
];

/// Bit 31 of a light's cache word ([`direct_cache_word`]): trace the light this frame.
pub const DIRECT_TRACE: u32 = 1 << 31;

/// The slot of a light whose term is not stored (traced every frame): bits 0–30 all set.
pub const DIRECT_NO_SLOT: u32 = DIRECT_TRACE - 1;

/// The word `cache` of a light's record (`struct DirectLight`, word
/// [`DIRECT_LIGHT_CACHE_WORD`](crate::DIRECT_LIGHT_CACHE_WORD)) in the direct pass: `slot` is
/// where the light's term per element (its irradiance per unit strength, averaged over the
/// element's samples) lives in `terms` (`terms[n + slot n + e]`, as f32 bits), `None` for a
/// light whose term is not stored; `trace`: trace the light this frame and store its term in
/// its slot, else read the term stored by an earlier frame (no ray). A light without a slot is
/// always traced.
pub fn direct_cache_word(slot: Option<u32>, trace: bool) -> u32 {
    match slot {
        None => DIRECT_TRACE | DIRECT_NO_SLOT,
        Some(s) => {
            assert!(s < DIRECT_NO_SLOT, "direct pass: slot {s} out of range");
            if trace { DIRECT_TRACE | s } else { s }
        }
    }
}

/// The `override` constants of `direct_pass.wgsl`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct DirectConstants {
    /// `COUNT_RAYS`: the shadow rays cast per element written to `rays` (off for timed frames).
    pub count_rays: bool,
}

impl DirectConstants {
    /// The pipeline constants by name.
    pub fn constants(&self) -> [(&'static str, f64); 1] {
        [("COUNT_RAYS", if self.count_rays { 1.0 } else { 0.0 })]
    }
}

/// The per-dispatch uniform at binding 0 of `direct_pass` (`struct DirectParams` of
/// `direct_pass.wgsl`, its twin: 32 bytes). Upload [`DirectParams::to_bytes`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DirectParams {
    /// The first element (original id) of this dispatch.
    pub first_element: u32,
    /// Elements of this dispatch.
    pub element_count: u32,
    /// Sample points per element.
    pub samples_per_element: u32,
    /// Lights in `direct_lights`.
    pub light_count: u32,
    /// Offset of shadow ray origins off their surface.
    pub epsilon: f32,
    /// Elements in all (the stride of `terms`' slots).
    pub n: u32,
}

impl DirectParams {
    /// Size in bytes, on the host and in WGSL.
    pub const SIZE: usize = 32;

    /// Every field's name and byte offset in WGSL, in declaration order (a naga test compares).
    pub const FIELDS: &'static [(&'static str, usize)] = &[
        ("first_element", 0),
        ("element_count", 4),
        ("samples_per_element", 8),
        ("light_count", 12),
        ("epsilon", 16),
        ("n", 20),
        ("reserved1", 24),
        ("reserved2", 28),
    ];

    /// The bytes to upload, little-endian, at the [`FIELDS`](Self::FIELDS) offsets (the
    /// reserved words zero).
    pub fn to_bytes(&self) -> [u8; Self::SIZE] {
        let words = [
            self.first_element,
            self.element_count,
            self.samples_per_element,
            self.light_count,
            self.epsilon.to_bits(),
            self.n,
        ];
        let mut bytes = [0; Self::SIZE];
        for (chunk, w) in bytes.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        bytes
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_bytes_sit_at_their_offsets() {
        let p = DirectParams {
            first_element: 64,
            element_count: 5,
            samples_per_element: 4,
            light_count: 3,
            epsilon: 0.25,
            n: 1000,
        };
        let b = p.to_bytes();
        let word = |name: &str| {
            let (_, at) = DirectParams::FIELDS
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap();
            u32::from_le_bytes(b[*at..at + 4].try_into().unwrap())
        };
        assert_eq!(word("first_element"), 64);
        assert_eq!(word("element_count"), 5);
        assert_eq!(word("samples_per_element"), 4);
        assert_eq!(word("light_count"), 3);
        assert_eq!(word("epsilon"), 0.25f32.to_bits());
        assert_eq!(word("n"), 1000);
        assert!(b[24..].iter().all(|&x| x == 0));
    }

    #[test]
    fn samples_sit_at_their_offsets_and_bad_points_are_skipped() {
        let words = direct_sample([1.0, 2.0, 3.0], [0.0, 1.0, 0.0]);
        assert_eq!(4 * words.len(), DIRECT_SAMPLE_BYTES);
        let at = |name: &str| {
            let (_, offset) = DIRECT_SAMPLE_FIELDS
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap();
            words[offset / 4]
        };
        assert_eq!(at("point"), 1.0f32.to_bits());
        assert_eq!(words[2], 3.0f32.to_bits());
        assert_eq!(at("valid"), 1);
        assert_eq!(words[5], 1.0f32.to_bits());
        assert_eq!(at("reserved"), 0);
        let bad = direct_sample([f32::NAN; 3], [0.0; 3]);
        assert_eq!(bad, [0; 8]);
    }

    #[test]
    fn cache_words_say_slot_and_trace() {
        assert_eq!(direct_cache_word(Some(3), false), 3);
        assert_eq!(direct_cache_word(Some(3), true), DIRECT_TRACE | 3);
        assert_eq!(direct_cache_word(None, false), u32::MAX);
        assert_eq!(direct_cache_word(None, true), u32::MAX);
    }

    #[test]
    fn constants_name_every_override() {
        let c = DirectConstants { count_rays: true };
        assert_eq!(c.constants(), [("COUNT_RAYS", 1.0)]);
    }
}
