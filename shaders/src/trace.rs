//! The ray tracer's pass (`wgsl/trace.wgsl`): the GPU twin of the CPU tracer
//! (`lrr_runtime::trace`), its per-tile uniform [`TraceParams`], its bindings and its pipeline
//! constants [`TraceConstants`], and the records of lights that are not surfaces
//! ([`direct_light`]) it shares with the direct pass. Its CPU mirror is the CPU tracer itself (the runtime's
//! `tests/gpu_trace.rs` compares the images); this crate's naga tests parse, validate, specialise
//! and compile it for every combination of effects.

use crate::{Access, Binding, bind};

/// The source: `bvh.wgsl` (the BVH, its traversal and watertight test), `direct_light.wgsl`
/// (lights that are not surfaces) and `trace.wgsl` joined, no `common.wgsl`; the first two are
/// shared with the direct pass ([`DIRECT_PASS`](crate::DIRECT_PASS)).
pub const TRACE: &str = concat!(
    include_str!("../wgsl/bvh.wgsl"),
    "\n",
    include_str!("../wgsl/direct_light.wgsl"),
    "\n",
    include_str!("../wgsl/trace.wgsl"),
);

/// The entry point.
pub const TRACE_ENTRY: &str = "trace";

/// Invocations per workgroup (one per pixel). Mirrored by `TRACE_LANES` in `wgsl/trace.wgsl`.
pub const TRACE_LANES: u32 = 64;

/// Size of the element of `nodes`, `optics`, `lights` and `direct_lights` in bytes (`struct
/// Node`, `Optics`, `Light`, `DirectLight` of `trace.wgsl`; a naga test checks).
pub const NODE_BYTES: usize = 32;
/// See [`NODE_BYTES`].
pub const OPTICS_BYTES: usize = 48;
/// See [`NODE_BYTES`].
pub const LIGHT_BYTES: usize = 32;
/// See [`NODE_BYTES`] (`struct SmoothElement`: [`smooth_element`]'s 16 words).
pub const SMOOTH_ELEMENT_BYTES: usize = 64;
/// See [`NODE_BYTES`] (`struct DirectLight`: [`direct_light`]'s 16 words).
pub const DIRECT_LIGHT_BYTES: usize = 64;

/// What a [`direct_light`] record is (`DIRECT_POINT`, `DIRECT_SPOT`, `DIRECT_SUN` in
/// `trace.wgsl`): the runtime's `Light` variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectKind {
    /// A point light: `I max(0, n·ω) / d²`.
    Point = 0,
    /// A spot light: the point light's irradiance times glTF's cone falloff.
    Spot = 1,
    /// A directional light (a sun): `E max(0, n·ω)`, its shadow ray unbounded.
    Sun = 2,
}

/// Names and byte offsets of `struct DirectLight` in `trace.wgsl` (a naga test compares).
pub const DIRECT_LIGHT_FIELDS: &[(&str, usize)] = &[
    ("position", 0),
    ("kind", 12),
    ("direction", 16),
    ("cos_inner", 28),
    ("strength", 32),
    ("cos_outer", 44),
    ("falloff_scale", 48),
    ("cache", 52),
    ("reserved1", 56),
    ("reserved2", 60),
];

/// One light that is not a surface as the tracer's `DIRECT` variant reads it (`struct
/// DirectLight`, binding `direct_lights`): the 16 words to upload, at the offsets of
/// [`DIRECT_LIGHT_FIELDS`]. Everything the CPU twin computes per light rather than per point is
/// computed by the caller on the host, in the CPU's f32 operations, so that the shader does not
/// round it otherwise: `direction` is a spot's unit axis (`normalize(direction)`) or, for a sun,
/// the unit direction towards it (`-normalize(direction)`); a spot's `cos_inner`, `cos_outer`
/// (the cones' cosines) and `falloff_scale` (`1 / max(cos_inner − cos_outer, 1e-3)`); zero
/// where a kind has no such value. The word `cache` is zero here: the direct pass's
/// [`direct_cache_word`] (the tracer does not read it).
#[allow(clippy::too_many_arguments)]
pub fn direct_light(
    kind: DirectKind,
    position: [f32; 3],
    direction: [f32; 3],
    strength: [f32; 3],
    cos_inner: f32,
    cos_outer: f32,
    falloff_scale: f32,
) -> [u32; 16] {
    let [p0, p1, p2] = position.map(f32::to_bits);
    let [d0, d1, d2] = direction.map(f32::to_bits);
    let [s0, s1, s2] = strength.map(f32::to_bits);
    [
        p0,
        p1,
        p2,
        kind as u32,
        d0,
        d1,
        d2,
        cos_inner.to_bits(),
        s0,
        s1,
        s2,
        cos_outer.to_bits(),
        falloff_scale.to_bits(),
        0,
        0,
        0,
    ]
}

/// Word index of `cache` in a [`direct_light`] record (byte 52).
pub const DIRECT_LIGHT_CACHE_WORD: usize = 13;

/// A triangle's unused fourth corner in [`smooth_element`] (`NO_CORNER` in `trace.wgsl`).
pub const NO_CORNER: u32 = u32::MAX;

/// Names and byte offsets of `struct SmoothElement` in `trace.wgsl` (a naga test compares).
pub const SMOOTH_ELEMENT_FIELDS: &[(&str, usize)] = &[
    ("v0", 0),
    ("c0", 12),
    ("v1", 16),
    ("c1", 28),
    ("v2", 32),
    ("c2", 44),
    ("v3", 48),
    ("c3", 60),
];

/// One display face as the tracer's smooth shading reads it (`struct SmoothElement`, binding
/// `smooth_faces`, one per display face: the file's section FACES, else its elements in file
/// order): its `count` (3 or 4) corners, each followed by its smooth vertex (the index into
/// `vertex_values`); a triangle's fourth corner is zero with vertex [`NO_CORNER`]. The 16 words
/// to upload, at the offsets of [`SMOOTH_ELEMENT_FIELDS`].
pub fn smooth_element(corners: [[f32; 3]; 4], vertices: [u32; 4], count: u8) -> [u32; 16] {
    let mut words = [0u32; 16];
    for i in 0..usize::from(count.min(4)) {
        let [x, y, z] = corners[i].map(f32::to_bits);
        words[4 * i..4 * i + 4].copy_from_slice(&[x, y, z, vertices[i]]);
    }
    if count < 4 {
        words[15] = NO_CORNER;
    }
    words
}

use Access::{Read, ReadWrite, Uniform};

/// The bindings of `trace`, all in group 0.
pub const TRACE_BINDINGS: &[Binding] = &[
    bind(0, "params", Uniform),
    bind(1, "nodes", Read),
    bind(2, "tris", Read),
    bind(3, "tri_face", Read),
    bind(4, "face_id", Read),
    bind(5, "normals", Read),
    bind(6, "face_material", Read),
    bind(7, "optics", Read),
    bind(8, "lights", Read),
    bind(9, "radiosity", Read),
    bind(10, "image", ReadWrite),
    bind(11, "counts", ReadWrite),
    bind(12, "smooth_faces", Read),
    bind(13, "vertex_values", Read),
    bind(14, "direct_lights", Read),
    bind(15, "reflectance", Read),
];

/// The effects a frame simulates, as the `override` constants of `trace.wgsl` (the CPU's
/// `lrr_runtime::trace::Effects` without the depth limit, which is a uniform), plus ray counting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TraceConstants {
    /// `HIGHLIGHTS`: Phong highlights behind shadow rays.
    pub highlights: bool,
    /// `SECONDARY`: mirror reflection and refraction.
    pub secondary: bool,
    /// `SMOOTH`: the smooth reconstruction at hit points (mean value coordinates over the
    /// element's corners, from the values [`SMOOTH_ENTRY`](crate::SMOOTH_ENTRY) computed).
    pub smooth: bool,
    /// `COUNT_RAYS`: count rays by kind (atomics; off for timed frames).
    pub count_rays: bool,
    /// `DIRECT`: lights that are not surfaces shaded at every hit, `ρ H(x) / π` added to the
    /// radiosity's radiance, each light behind its own shadow ray (bindings `direct_lights` and
    /// `reflectance`); off, a frame without such lights runs none of it.
    pub direct: bool,
}

impl TraceConstants {
    /// The pipeline constants by name.
    pub fn constants(&self) -> [(&'static str, f64); 5] {
        let b = |v: bool| if v { 1.0 } else { 0.0 };
        [
            ("HIGHLIGHTS", b(self.highlights)),
            ("SECONDARY", b(self.secondary)),
            ("SMOOTH", b(self.smooth)),
            ("COUNT_RAYS", b(self.count_rays)),
            ("DIRECT", b(self.direct)),
        ]
    }
}

/// The per-tile uniform at binding 0 of `trace` (`struct TraceParams` of `trace.wgsl`, its
/// twin: 96 bytes, each `vec3<f32>` followed by a 4-byte field in its padding, the struct
/// padded to 16 bytes). Upload
/// [`TraceParams::to_bytes`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceParams {
    /// The camera's eye.
    pub eye: [f32; 3],
    /// Offset of secondary and shadow ray origins off their surface.
    pub epsilon: f32,
    /// Unit view direction.
    pub forward: [f32; 3],
    /// Bounces below a camera ray.
    pub max_depth: u32,
    /// Right, scaled by the half width of the image plane at distance 1.
    pub right: [f32; 3],
    /// Point lights.
    pub light_count: u32,
    /// Up, scaled by the half height of the image plane at distance 1.
    pub up: [f32; 3],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// First pixel of this dispatch (row-major from the top left).
    pub first_pixel: u32,
    /// Pixels of this dispatch.
    pub pixel_count: u32,
    /// Index of this tile's ray counters.
    pub tile: u32,
    /// Lights that are not surfaces in `direct_lights` (read with `DIRECT` only).
    pub direct_count: u32,
}

impl TraceParams {
    /// Size in bytes, on the host and in WGSL.
    pub const SIZE: usize = 96;

    /// Every field's name and byte offset in WGSL, in declaration order (a naga test compares).
    pub const FIELDS: &'static [(&'static str, usize)] = &[
        ("eye", 0),
        ("epsilon", 12),
        ("forward", 16),
        ("max_depth", 28),
        ("right", 32),
        ("light_count", 44),
        ("up", 48),
        ("width", 60),
        ("height", 64),
        ("first_pixel", 68),
        ("pixel_count", 72),
        ("tile", 76),
        ("direct_count", 80),
    ];

    /// The bytes to upload, little-endian, at the [`FIELDS`](Self::FIELDS) offsets.
    pub fn to_bytes(&self) -> [u8; Self::SIZE] {
        let f = |v: [f32; 3]| v.map(f32::to_bits);
        let [e0, e1, e2] = f(self.eye);
        let [f0, f1, f2] = f(self.forward);
        let [r0, r1, r2] = f(self.right);
        let [u0, u1, u2] = f(self.up);
        let words = [
            e0,
            e1,
            e2,
            self.epsilon.to_bits(),
            f0,
            f1,
            f2,
            self.max_depth,
            r0,
            r1,
            r2,
            self.light_count,
            u0,
            u1,
            u2,
            self.width,
            self.height,
            self.first_pixel,
            self.pixel_count,
            self.tile,
            self.direct_count,
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
        let p = TraceParams {
            epsilon: 0.5,
            max_depth: 7,
            up: [0.0, 0.0, 2.0],
            width: 640,
            tile: 9,
            ..TraceParams::default()
        };
        let b = p.to_bytes();
        let word = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
        assert_eq!(word(12), 0.5f32.to_bits());
        assert_eq!(word(28), 7);
        assert_eq!(word(56), 2.0f32.to_bits());
        assert_eq!(word(60), 640);
        assert_eq!(word(76), 9);
        assert_eq!(word(80), 0);
        let p = TraceParams {
            direct_count: 3,
            ..p
        };
        assert_eq!(p.to_bytes()[80..84], 3u32.to_le_bytes());
        assert!(p.to_bytes()[84..].iter().all(|&b| b == 0));
    }

    #[test]
    fn direct_lights_sit_at_their_offsets() {
        let words = direct_light(
            DirectKind::Spot,
            [1.0, 2.0, 3.0],
            [0.0, -1.0, 0.0],
            [4.0, 5.0, 6.0],
            0.9,
            0.8,
            10.0,
        );
        assert_eq!(4 * words.len(), DIRECT_LIGHT_BYTES);
        let at = |name: &str| {
            let (_, offset) = DIRECT_LIGHT_FIELDS
                .iter()
                .find(|(n, _)| *n == name)
                .unwrap();
            words[offset / 4]
        };
        assert_eq!(at("position"), 1.0f32.to_bits());
        assert_eq!(at("kind"), DirectKind::Spot as u32);
        assert_eq!(at("direction"), 0.0f32.to_bits());
        assert_eq!(words[5], (-1.0f32).to_bits());
        assert_eq!(at("cos_inner"), 0.9f32.to_bits());
        assert_eq!(at("strength"), 4.0f32.to_bits());
        assert_eq!(at("cos_outer"), 0.8f32.to_bits());
        assert_eq!(at("falloff_scale"), 10.0f32.to_bits());
        assert_eq!(words[13..], [0, 0, 0]);
    }

    #[test]
    fn smooth_elements_put_each_corner_before_its_vertex() {
        let c = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0], [9.0; 3]];
        let quad = smooth_element(c, [10, 11, 12, 13], 4);
        assert_eq!(4 * quad.len(), SMOOTH_ELEMENT_BYTES);
        let bits = |x: f32| x.to_bits();
        assert_eq!(quad[..4], [bits(1.0), bits(2.0), bits(3.0), 10]);
        assert_eq!((quad[7], quad[11], quad[15]), (11, 12, 13));
        assert_eq!(quad[12], 9.0f32.to_bits());
        let tri = smooth_element(c, [10, 11, 12, 13], 3);
        assert_eq!(tri[12..], [0, 0, 0, NO_CORNER]);
        for (name, at) in SMOOTH_ELEMENT_FIELDS {
            let corner = at / 16;
            assert_eq!(name[1..].parse::<usize>().unwrap(), corner);
            assert_eq!(at % 16, if name.starts_with('v') { 0 } else { 12 });
        }
    }

    #[test]
    fn constants_name_every_override() {
        let c = TraceConstants {
            secondary: true,
            ..TraceConstants::default()
        };
        assert_eq!(
            c.constants(),
            [
                ("HIGHLIGHTS", 0.0),
                ("SECONDARY", 1.0),
                ("SMOOTH", 0.0),
                ("COUNT_RAYS", 0.0),
                ("DIRECT", 0.0)
            ]
        );
    }
}
