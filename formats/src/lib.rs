//! The lrr operator file: written by the precompute (`lrr bake`), read by the runtime.
//!
//! A versioned little-endian container of checksummed, 64-byte aligned sections (payloads can be
//! used in place, e.g. uploaded to a GPU buffer as they lie). No third-party dependencies, no
//! `unsafe`. The reader is built for hostile input: on any bytes it returns an error instead of
//! panicking, reading out of bounds or allocating more than about the size of the input.
//!
//! Two levels:
//! - [`Container`] / [`ContainerWriter`]: header, section table, payload bytes.
//! - [`OperatorFile`]: the decoded, validated operator (see DESIGN.md §2 for the maths:
//!   `B~_c = E_c + rho_c ⊙ F_k M_c (Vᵀ E_c)`, or `B~_c = E_c - Y_c (Vᵀ E_c)` in the plain layout).
//!
//! # Layout, version 1.4
//!
//! All integers little-endian. The header (64 bytes):
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 8 | magic [`MAGIC`] = `89 4C 52 52 0D 0A 1A 0A` (`\x89LRR\r\n\x1a\n`) |
//! | 8 | 2 | major version ([`VERSION_MAJOR`]) |
//! | 10 | 2 | minor version ([`VERSION_MINOR`]) |
//! | 12 | 4 | section count |
//! | 16 | 4 | flags (0) |
//! | 20 | 8 | header checksum: of bytes 0 up to the end of the padded table, this field read as 0 |
//! | 28 | 36 | zeros |
//!
//! Like PNG's, the magic catches the usual transfer accidents: the high bit of `0x89` is lost by
//! 7-bit channels, `\r\n` is mangled by newline conversion, `0x1a` stops a DOS `type`.
//!
//! The section table follows at byte 64: one 40-byte entry per section, zero-padded to a multiple
//! of 64 bytes.
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | kind (see [`kind`]) |
//! | 4 | 4 | flags: bit 0 = required ([`FLAG_REQUIRED`]) |
//! | 8 | 8 | payload offset from the start of the file, a multiple of 64 |
//! | 16 | 8 | payload length in bytes |
//! | 24 | 8 | payload checksum ([`checksum()`]: XXH64, seed 0) |
//! | 32 | 8 | reserved (0) |
//!
//! Then the payloads, in table order, each at the next multiple of 64 (gaps zero-filled); the file
//! ends with the last payload. The checksums detect corruption (any single changed byte for
//! certain), not tampering: anyone can recompute them.
//!
//! The sections of an operator file, all written as required except LIGHTS and the display
//! sections 13 to 18, which are optional (FACES, 19, is for display too but written as required
//! when present, see [Compatibility](#compatibility)):
//!
//! | kind | name | payload |
//! |-----:|------|---------|
//! | 1 | [`METADATA`](kind::METADATA) | UTF-8 JSON text |
//! | 2 | [`DIMS`](kind::DIMS) | `n, k, channels, precision (0 f32, 1 f16), layout (0 factored, 1 plain Y_k)`, 3 reserved: 8 × u32 |
//! | 3 | [`ORDER`](kind::ORDER) | `n` × u32: file position -> element id |
//! | 4 | [`INDEX`](kind::INDEX) | `k + 1` × u32: patch offsets |
//! | 5 | [`WEIGHTS`](kind::WEIGHTS) | `n` × f32 |
//! | 6 | [`FK`](kind::FK) | factored layout only: `n * k` × f32 or u16 (binary16), row-major |
//! | 7 | [`CORES`](kind::CORES) | factored layout only: `channels * k * k` × f64, row-major |
//! | 8 | [`REFLECTANCE`](kind::REFLECTANCE) | `n * 3` × f32 |
//! | 9 | [`EMISSION`](kind::EMISSION) | `n * 3` × f32 |
//! | 10 | [`GEOMETRY`](kind::GEOMETRY) | `n` × u8 vertex counts, zero-padded to 4 bytes; `n * 12` × f32 vertices; `n * 3` × f32 normals: one polygon per element, the one its form factors were computed on ([`Geometry`]) |
//! | 11 | [`YK`](kind::YK) | plain layout only (1.1): `channels * n * k` × f32 or u16 (binary16): channel-major, each channel `n x k` row-major, rows in file order |
//! | 12 | [`LIGHTS`](kind::LIGHTS) | optional (1.1), absent when there are no groups: the light groups, see below |
//! | 13 | [`SMOOTH`](kind::SMOOTH) | optional (1.2): smooth reconstruction weights ([`Smooth`]), 4 corners per display face, see below |
//! | 14 | [`MATERIALS`](kind::MATERIALS) | optional (1.2): materials for display and each element's ([`Materials`]) |
//! | 15 | [`POINT_LIGHTS`](kind::POINT_LIGHTS) | optional (1.2), absent when there are none: [`PointLight`]s |
//! | 16 | [`CAMERAS`](kind::CAMERAS) | optional (1.2), absent when there are none: [`Camera`]s |
//! | 17 | [`BVH`](kind::BVH) | optional (1.2): the flattened BVH over the display triangles ([`Bvh`]) |
//! | 18 | [`LIGHTMAP`](kind::LIGHTMAP) | optional (1.3): `F * 4 * 2` × f32, lightmap `u, v` of each display face corner, a triangle's 4th zero ([`LightmapUv`]) |
//! | 19 | [`FACES`](kind::FACES) | 1.4, absent when elements are drawn as their GEOMETRY, **required** when present: the display faces ([`Faces`]), see below |
//! | 20 | [`DIRECT_LIGHTS`](kind::DIRECT_LIGHTS) | optional (1.5), absent when there are none: spot and directional lights and the sky ([`DirectLight`]) |
//! | 21 | [`SKY_TRANSFER`](kind::SKY_TRANSFER) | optional (1.5), written with a sky: `9 n` × f32 in file order, each element's order-2 spherical harmonic sky transfer ([`Display::sky_transfer`]) |
//! | 22 | [`ATLAS`](kind::ATLAS) | optional (1.6), only with LIGHTMAP: width, height, padding, source (u32: 0 the scene's coordinates, 1 generated charts), density (f64, texels per scene unit; 0 for the scene's) ([`LightmapAtlas`]) |
//!
//! The factored layout stores FK and CORES and no YK; the plain layout stores YK and neither FK
//! nor CORES. A file holding a section of the other layout is refused.
//!
//! ## LIGHTS
//!
//! A count and one record per [`LightGroup`]; every record starts at a multiple of 8 bytes from
//! the start of the payload, so every field is naturally aligned:
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | group count `G` |
//! | 4 | 4 | reserved (0, ignored) |
//! | 8 | | `G` records |
//!
//! A record, with `L` the length of the name in bytes and `m` the number of positions:
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | `L` (at least 1) |
//! | 4 | 4 | `m` (at least 1) |
//! | 8 | `24 k` | `x = Vᵀ E_g`: `k * 3` × f64, `x[3 p + c]` |
//! | `8 + 24 k` | `L` rounded up to 8 | name, UTF-8, zero-padded |
//! | then | `4 m` | file positions: `m` × u32, strictly increasing |
//! | then | `12 m` | emission at intensity 1: `m * 3` × f32 (RGB per position) |
//!
//! The payload ends with the last record.
//!
//! ## The display sections (1.2)
//!
//! What a renderer needs beyond the radiosity (see [`Display`] for their meaning, the display
//! faces, the fan triangulation of the faces that numbers the display triangles, and every
//! invariant). Every field is naturally aligned: each payload is a head of two u32, fixed-size
//! records of 4-byte fields, and (last) names as UTF-8 bytes. A reader skips a reserved word.
//!
//! The *display faces* are the polygons of FACES when the file has it (`F` of them, face `f`
//! showing the element at file position `element[f]`), else GEOMETRY's (`F = n`, face `f` showing
//! element `f`); [`OperatorFile::faces`] gives them either way. SMOOTH's corners, LIGHTMAP's
//! coordinates and the BVH's triangles are those of the display faces.
//!
//! FACES (1.4), with `F` faces (at least one; every file position shown by at least one face):
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | `F` |
//! | 4 | 4 | reserved (0) |
//! | 8 | `4 F` | element: `F` × u32, the file position (`< n`) each face shows |
//! | then | `F` rounded up to 4 | vertex counts: `F` × u8 (3 or 4), zero-padded |
//! | then | `48 F` | vertices: `F * 12` × f32, as GEOMETRY's (a triangle's 4th zero) |
//! | then | `12 F` | normals: `F * 3` × f32, unit |
//!
//! SMOOTH, with `V` smooth vertices and `P` (element, weight) pairs:
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | `V` |
//! | 4 | 4 | `P` |
//! | 8 | `16 F` | corners: `F * 4` × u32, the smooth vertex of each display face corner ([`Smooth::NONE`] for a triangle's 4th) |
//! | then | `4 (V + 1)` | offsets: u32, vertex `v` sums pairs `offsets[v]..offsets[v + 1]` |
//! | then | `4 P` | positions: u32, file positions |
//! | then | `4 P` | weights: f32 |
//!
//! MATERIALS, POINT_LIGHTS, CAMERAS and DIRECT_LIGHTS share one shape: a head of the record count and a
//! reserved word, the records, a block (MATERIALS only: `n` × u32, the material of each file
//! position), then every record's name in record order, back to back (the record holds its
//! byte length `L`; no padding); the payload ends with the last name. Records:
//!
//! | section | bytes | fields (offset: f32 × 3 or one 4-byte word) |
//! |---------|------:|--------|
//! | MATERIALS | 64 | 0 diffuse, 12 shininess, 16 specular, 28 ior, 32 mirror, 44 `L` (u32), 48 transmission, 60 reserved |
//! | POINT_LIGHTS | 32 | 0 position, 12 group (u32; [`PointLight::FIXED`]: none), 16 intensity, 28 `L` (u32) |
//! | CAMERAS | 48 | 0 eye, 12 fov_y_deg, 16 target, 28 `L` (u32), 32 up, 44 reserved |
//! | DIRECT_LIGHTS (1.5) | 64 | 0 position, 12 kind (u32: 0 spot, 1 directional, 2 uniform sky, 3 gradient sky), 16 direction, 28 `L` (u32), 32 strength, 44 reserved, 48 extra, 60 reserved ([`DirectLight`] says which field means what per kind) |
//!
//! BVH, with `N` nodes over `T` display triangles:
//!
//! | offset | size | field |
//! |-------:|-----:|-------|
//! | 0 | 4 | `N` |
//! | 4 | 4 | `T` (the fan triangle count of the display faces) |
//! | 8 | `32 N` | nodes: min (f32 × 3), first (u32), max (f32 × 3), count (u32); node 0 the root |
//! | then | `4 T` | triangle ids (u32) in leaf order |
//!
//! # Compatibility
//!
//! A reader refuses another major version, naming both versions. It reads any minor version of
//! its major: a newer minor may add sections, which older readers skip when they are optional and
//! refuse, with an error, when they are marked required. Version 1.1 added the plain layout
//! (layout code 1, section YK, required) and light groups (LIGHTS, optional): a 1.0 reader
//! refuses plain files and reads factored files with light groups as if they had none; this
//! reader reads 1.0 files unchanged. Version 1.2 added the display sections SMOOTH, MATERIALS,
//! POINT_LIGHTS, CAMERAS and BVH, all optional: a 1.1 reader evaluates a 1.2 file as if they
//! were not there. Version 1.3 added LIGHTMAP (optional), the scene's own lightmap coordinates.
//! Version 1.4 added FACES, the display faces of elements drawn as other polygons than their
//! GEOMETRY entry (a dense mesh's elements, each a cluster of many small input faces whose form
//! factors were computed on a planar proxy polygon). With FACES, SMOOTH and LIGHTMAP hold 4
//! corners per face and the BVH's `T` counts the faces' triangles, so a 1.3 reader that skipped
//! FACES would mis-size them (and draw the proxies): FACES is therefore written as *required*,
//! and an older reader refuses the file with its "unknown required section" error
//! ([`ErrorKind::UnsupportedVersion`]) instead of misreading it. A file is stamped with the
//! lowest minor version that describes it: 1.1 without display sections (the bytes a 1.1 writer
//! gave), 1.2 with any but LIGHTMAP and FACES, 1.3 with LIGHTMAP but no FACES, 1.4 with FACES,
//! 1.5 with DIRECT_LIGHTS or SKY_TRANSFER, 1.6 with ATLAS. Version 1.5 added DIRECT_LIGHTS (optional): spot
//! and directional lights and a sky, which the runtime's direct pass turns into emission every
//! frame, and SKY_TRANSFER (optional): the sky's visibility per element, projected at bake
//! time; a 1.4 reader evaluates the file and draws it without them. Version 1.6 added ATLAS
//! (optional, only beside LIGHTMAP): the atlas size and padding LIGHTMAP's coordinates were
//! made for, so that a runtime fills the lightmap the bake laid out; since 1.6 every bake
//! writes LIGHTMAP, the scene's `TEXCOORD_1` or charts packed at bake time. A 1.5 reader
//! keeps the coordinates and chooses a size itself.
//!
//! A reader also refuses ([`ErrorKind`] says which kind of fault): a wrong magic; a table or
//! payload past the end of the file; a payload offset that is misaligned or inside the table;
//! overlapping payloads; bytes after the last payload; a checksum mismatch (naming the section);
//! a duplicate kind; a missing section or a payload length that disagrees with DIMS; sizes that
//! overflow; values that break an invariant of [`OperatorFile`].
//!
//! # Example
//!
//! ```
//! use lrr_formats::{Geometry, Layout, OperatorData, OperatorFile, Precision, StoredMatrix};
//!
//! // Two triangles forming one patch, the first one emitting.
//! let mut file = OperatorFile {
//!     metadata_json: r#"{"scene":"two triangles"}"#.to_string(),
//!     n: 2,
//!     k: 1,
//!     channels: 1,
//!     precision: Precision::F32,
//!     order: vec![1, 0],
//!     index: vec![0, 2],
//!     weights: vec![0.5, 0.5],
//!     operator: OperatorData::Factored {
//!         fk: StoredMatrix::F32(vec![0.0, 0.0]),
//!         cores: vec![1.0],
//!     },
//!     reflectance: vec![0.5; 6],
//!     emission: vec![1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
//!     geometry: Geometry {
//!         vertex_count: vec![3, 3],
//!         vertices: vec![
//!             0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, //
//!             0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
//!         ],
//!         normals: vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
//!     },
//!     lights: Vec::new(),
//!     display: Default::default(),
//! };
//! // A light group: file position 0 at intensity 1 (x = Vᵀ E_g is computed from the file).
//! let lamp = file.light_group("lamp", vec![0], vec![1.0, 1.0, 1.0])?;
//! assert_eq!(lamp.x, [0.5, 0.5, 0.5]);
//! file.lights.push(lamp);
//!
//! let bytes = file.to_bytes()?;
//! assert_eq!(&bytes[..8], &lrr_formats::MAGIC);
//! assert_eq!(OperatorFile::from_bytes(&bytes)?, file);
//!
//! let path = std::env::temp_dir().join(format!("lrr-doc-{}.lrr", std::process::id()));
//! file.write(&path)?; // atomic
//! assert_eq!(OperatorFile::read(&path)?, file);
//! std::fs::remove_file(&path).unwrap();
//!
//! // Damage is detected.
//! let mut damaged = bytes.clone();
//! let last = damaged.len() - 1;
//! damaged[last] ^= 1;
//! assert!(OperatorFile::from_bytes(&damaged).is_err());
//!
//! // The papers' plain layout, for comparison: Y_k = -diag(rho) F_k M (n x k per channel).
//! let plain = file.to_plain_yk(1)?;
//! assert_eq!(plain.layout(), Layout::PlainYk);
//! # Ok::<(), lrr_formats::FormatError>(())
//! ```

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod atomic;
mod bvh;
mod bytes;
mod cameras;
mod checksum;
mod codec;
mod container;
mod convert;
mod direct_lights;
mod display;
mod error;
mod faces;
mod file;
mod geometry;
mod half;
pub mod kind;
mod lightmap;
mod lights;
mod materials;
mod point_lights;
mod records;
mod smooth;
#[cfg(test)]
mod testdata;
mod validate;
mod writer;

pub use atomic::{write_atomic, write_atomic_with};
pub use checksum::{Xxh64, checksum};
pub use codec::FK_PIECE;
pub use container::{
    ALIGN, Container, FLAG_REQUIRED, HEADER_CHECKSUM_OFFSET, HEADER_LEN, MAGIC, SECTION_ENTRY_LEN,
    Section, VERSION_MAJOR, VERSION_MINOR,
};
pub use display::{
    Bvh, BvhNode, Camera, DirectLight, DirectLightKind, Display, LightmapAtlas, LightmapSource,
    LightmapUv, MAX_ATLAS_PADDING, MAX_ATLAS_SIDE, Material, Materials, PointLight, Smooth,
};
pub use error::{ErrorKind, FormatError};
pub use file::{
    Layout, LightGroup, MAX_CONDITION, OperatorData, OperatorFile, Precision, StoredMatrix,
};
pub use geometry::{Faces, FacesRef, Geometry};
pub use half::{f16_to_f32, f32_to_f16};
pub use writer::ContainerWriter;
