//! Section payloads <-> [`OperatorFile`] fields, and the file's reading and writing.
//!
//! [`OperatorFile::from_bytes`] runs the container checks, then checks each payload length
//! against the dimensions, then [`validate`](OperatorFile::validate): a value that comes back
//! from `from_bytes` satisfies every invariant documented on the fields.
//!
//! Decoding checks every payload length against DIMS with overflow-checked arithmetic *before*
//! decoding it, so no vector is larger than the bytes it comes from. Values are checked later, by
//! [`validate`](OperatorFile::validate).

use std::path::Path;

use crate::atomic::write_atomic_with;
use crate::bytes::{self, checked_product};
use crate::container::{Container, VERSION_MAJOR};
use crate::display::Display;
use crate::error::{ErrorKind, FormatError};
use crate::file::{Layout, OperatorData, OperatorFile, Precision, StoredMatrix};
use crate::geometry::Geometry;
use crate::kind;
use crate::validate::{Sizes, check_dims, check_fk};
use crate::writer::{ContainerWriter, Streamed};
use crate::{
    bvh, cameras, direct_lights, faces, lightmap, lights, materials, point_lights, smooth,
};

/// Bytes in the DIMS payload: n, k, channels, precision, layout, 3 reserved, all u32.
pub(crate) const DIMS_LEN: usize = 32;

impl OperatorFile {
    /// Encodes the file. Runs [`validate`](Self::validate) first: an inconsistent struct gives an
    /// `Invalid` error and no bytes.
    pub fn to_bytes(&self) -> Result<Vec<u8>, FormatError> {
        self.validate()?;
        Ok(encode(self))
    }

    /// Decodes and validates a file. Never panics, never reads out of bounds, and allocates about
    /// the size of `bytes` at most, whatever the bytes are.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, FormatError> {
        let container = Container::parse(bytes)?;
        let file = decode(&container)?;
        file.validate()?;
        Ok(file)
    }

    /// Reads and decodes the file at `path`; every error message starts with the path.
    pub fn read(path: &Path) -> Result<Self, FormatError> {
        let bytes = std::fs::read(path).map_err(|e| {
            FormatError::new(
                ErrorKind::Io,
                format!("cannot read {}: {e}", path.display()),
            )
        })?;
        Self::from_bytes(&bytes).map_err(|e| e.context(path.display()))
    }

    /// Validates, encodes and writes the file atomically (see
    /// [`write_atomic`](crate::write_atomic)): readers see the old file or the new one, never a
    /// mix. The bytes are [`to_bytes`](Self::to_bytes)'s, but each section is encoded as it is
    /// written and dropped after, and the matrix (`F_k` or `Y_k`, most of the file) goes to the
    /// file in pieces of [`FK_PIECE`] values: writing holds the largest section but the matrix,
    /// and one piece, rather than a copy of the file.
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        self.validate().map_err(|e| e.context(path.display()))?;
        let writer = encoder(self, true);
        write_atomic_with(path, &mut |file| writer.write_to(file, None))
            .map_err(|e| e.context(path.display()))
    }

    /// Writes the file atomically, every section but FK encoded from `self` (checked by the
    /// caller) and FK's `len` payload bytes handed out in pieces by `fill`.
    #[allow(clippy::type_complexity)]
    fn write_fk_streamed(
        &self,
        path: &Path,
        len: u64,
        fill: &mut dyn FnMut(
            &mut dyn FnMut(&[u8]) -> Result<(), FormatError>,
        ) -> Result<(), FormatError>,
    ) -> Result<(), FormatError> {
        let writer = encoder(self, false);
        write_atomic_with(path, &mut |file| {
            writer.write_streamed(
                file,
                Streamed {
                    at: SECTIONS_BEFORE_FK,
                    kind: kind::FK,
                    required: true,
                    len,
                    fill: &mut *fill,
                },
            )
        })
        .map_err(|e| e.context(path.display()))
    }
}

/// The minor version stamped on files without display sections: the version that describes
/// them completely, so that they keep the bytes a 1.1 writer gave them.
pub(crate) const MINOR_WITHOUT_DISPLAY: u16 = 1;
/// The minor version of files with display sections but no LIGHTMAP or FACES (what a 1.2 writer
/// gave).
pub(crate) const MINOR_WITHOUT_LIGHTMAP: u16 = 2;
/// The minor version of files with LIGHTMAP but no FACES (what a 1.3 writer gave).
pub(crate) const MINOR_WITHOUT_FACES: u16 = 3;
/// The minor version of a file with FACES but no DIRECT_LIGHTS (format 1.4).
pub(crate) const MINOR_WITHOUT_DIRECT_LIGHTS: u16 = 4;
/// The minor version of a file with DIRECT_LIGHTS or SKY_TRANSFER but no ATLAS (format 1.5).
pub(crate) const MINOR_WITHOUT_ATLAS: u16 = 5;

/// Values of `F_k` [`OperatorFile::write`] encodes at a time (1 MiB of f32).
pub const FK_PIECE: usize = 1 << 18;

/// Sections before FK in a factored file: METADATA, DIMS, ORDER, INDEX, WEIGHTS.
const SECTIONS_BEFORE_FK: usize = 5;

impl OperatorFile {
    /// Writes a factored file whose `F_k` is too large to hold, atomically: the bytes
    /// [`write`](Self::write) gives for the complete file. `self` holds everything else, its
    /// `F_k` an empty matrix of the file's precision; `rows` hands `F_k`'s n·k values, in row
    /// order and the file's precision, to its argument in pieces of whole rows, each checked
    /// as it passes. An error (of the pieces, or returned by `rows`) leaves `path` untouched.
    #[allow(clippy::type_complexity)]
    pub fn write_streamed(
        &self,
        path: &Path,
        rows: &mut dyn FnMut(
            &mut dyn FnMut(&StoredMatrix) -> Result<(), FormatError>,
        ) -> Result<(), FormatError>,
    ) -> Result<(), FormatError> {
        let context = |e: FormatError| e.context(path.display());
        let OperatorData::Factored { fk, .. } = &self.operator else {
            return Err(context(FormatError::invalid(
                "write_streamed writes the factored layout only",
            )));
        };
        if !fk.is_empty() {
            return Err(context(FormatError::invalid(
                "write_streamed: F_k comes from the rows, the file's own must be empty",
            )));
        }
        self.check(true).map_err(context)?;
        let (k, precision) = (self.k as usize, self.precision);
        let sizes = Sizes::new(self.n, self.k, self.channels).map_err(context)?;
        let mut row = 0usize;
        self.write_fk_streamed(path, (sizes.fk * precision.size()) as u64, &mut |emit| {
            rows(&mut |piece: &StoredMatrix| {
                if piece.precision() != precision || !piece.len().is_multiple_of(k.max(1)) {
                    return Err(FormatError::invalid(format!(
                        "section FK: a piece of {} {:?} values is not whole rows of {k} {precision:?} values",
                        piece.len(),
                        piece.precision()
                    )));
                }
                check_fk(piece, k).map_err(|e| e.context(format_args!("rows from element {row}")))?;
                row += piece.len() / k.max(1);
                matrix_pieces(piece, emit)
            })
        })
    }
}

/// Builds the container; `file` has been validated.
pub(crate) fn encode(file: &OperatorFile) -> Vec<u8> {
    encoder(file, true).to_bytes()
}

/// The container's sections, each encoded when the container is written; `with_fk: false`
/// leaves FK out (to be streamed in at [`SECTIONS_BEFORE_FK`]).
fn encoder(file: &OperatorFile, with_fk: bool) -> ContainerWriter<'_> {
    let mut w = ContainerWriter::new();
    w.add_encoded(kind::METADATA, true, || {
        file.metadata_json.as_bytes().to_vec()
    });
    w.add(kind::DIMS, true, encode_dims(file));
    w.add_encoded(kind::ORDER, true, || u32_payload(&file.order));
    w.add_encoded(kind::INDEX, true, || u32_payload(&file.index));
    w.add_encoded(kind::WEIGHTS, true, || f32_payload(&file.weights));
    if let OperatorData::Factored { fk, cores } = &file.operator {
        debug_assert_eq!(w.len(), SECTIONS_BEFORE_FK);
        if with_fk {
            w.add_pieces(kind::FK, true, |emit| matrix_pieces(fk, emit));
        }
        w.add_encoded(kind::CORES, true, || {
            let mut payload = Vec::new();
            bytes::put_f64s(&mut payload, cores);
            payload
        });
    }
    w.add_encoded(kind::REFLECTANCE, true, || f32_payload(&file.reflectance));
    w.add_encoded(kind::EMISSION, true, || f32_payload(&file.emission));
    w.add_encoded(kind::GEOMETRY, true, || encode_geometry(&file.geometry));
    if let OperatorData::PlainYk { yk } = &file.operator {
        w.add_pieces(kind::YK, true, |emit| matrix_pieces(yk, emit));
    }
    if !file.lights.is_empty() {
        // Optional: a reader of format 1.0 skips it and still evaluates per-element emission.
        w.add_encoded(kind::LIGHTS, false, || lights::encode(&file.lights));
    }
    add_display(&mut w, &file.display);
    let d = &file.display;
    if *d == Display::default() {
        w.set_version(VERSION_MAJOR, MINOR_WITHOUT_DISPLAY);
    } else if d.lightmap.as_ref().is_some_and(|l| l.atlas.is_some()) {
        // VERSION_MINOR: 1.6.
    } else if !d.direct_lights.is_empty() || d.sky_transfer.is_some() {
        w.set_version(VERSION_MAJOR, MINOR_WITHOUT_ATLAS);
    } else if d.faces.is_none() && d.lightmap.is_none() {
        w.set_version(VERSION_MAJOR, MINOR_WITHOUT_LIGHTMAP);
    } else if d.faces.is_none() {
        w.set_version(VERSION_MAJOR, MINOR_WITHOUT_FACES);
    } else {
        w.set_version(VERSION_MAJOR, MINOR_WITHOUT_DIRECT_LIGHTS);
    }
    w
}

/// A matrix's payload in pieces of [`FK_PIECE`] values.
fn matrix_pieces(
    m: &StoredMatrix,
    emit: &mut dyn FnMut(&[u8]) -> Result<(), FormatError>,
) -> Result<(), FormatError> {
    let mut piece = Vec::new();
    match m {
        StoredMatrix::F32(v) => v.chunks(FK_PIECE).try_for_each(|values| {
            piece.clear();
            bytes::put_f32s(&mut piece, values);
            emit(&piece)
        }),
        StoredMatrix::F16(v) => v.chunks(FK_PIECE).try_for_each(|values| {
            piece.clear();
            bytes::put_u16s(&mut piece, values);
            emit(&piece)
        }),
    }
}

/// The display sections of `d` (format 1.2), all optional (a reader that only evaluates skips
/// them) but FACES (1.4), which is required: SMOOTH, LIGHTMAP and the BVH are defined on the
/// faces when it is present, and a reader that does not know it would misread them.
fn add_display<'a>(w: &mut ContainerWriter<'a>, d: &'a Display) {
    if let Some(s) = &d.smooth {
        w.add_encoded(kind::SMOOTH, false, || smooth::encode(s));
    }
    if let Some(m) = &d.materials {
        w.add_encoded(kind::MATERIALS, false, || materials::encode(m));
    }
    if !d.point_lights.is_empty() {
        w.add_encoded(kind::POINT_LIGHTS, false, || {
            point_lights::encode(&d.point_lights)
        });
    }
    if !d.cameras.is_empty() {
        w.add_encoded(kind::CAMERAS, false, || cameras::encode(&d.cameras));
    }
    if let Some(b) = &d.bvh {
        w.add_encoded(kind::BVH, false, || bvh::encode(b));
    }
    if let Some(l) = &d.lightmap {
        w.add_encoded(kind::LIGHTMAP, false, || lightmap::encode(l));
    }
    if let Some(f) = &d.faces {
        w.add_encoded(kind::FACES, true, || faces::encode(f));
    }
    if !d.direct_lights.is_empty() {
        w.add_encoded(kind::DIRECT_LIGHTS, false, || {
            direct_lights::encode(&d.direct_lights)
        });
    }
    if let Some(t) = &d.sky_transfer {
        w.add_encoded(kind::SKY_TRANSFER, false, || {
            let mut payload = Vec::new();
            bytes::put_f32s(&mut payload, t);
            payload
        });
    }
    if let Some(a) = d.lightmap.as_ref().and_then(|l| l.atlas.as_ref()) {
        w.add_encoded(kind::ATLAS, false, || lightmap::encode_atlas(a));
    }
}

/// The display sections of `c` for `n` elements; lengths are checked, values are not. FACES
/// first: SMOOTH and LIGHTMAP hold 4 corners per display face (`F` of FACES, else `n`).
fn decode_display(c: &Container<'_>, n: usize) -> Result<Display, FormatError> {
    let faces = c.section(kind::FACES).map(faces::decode).transpose()?;
    let face_count = faces.as_ref().map_or(n, |f| f.element.len());
    Ok(Display {
        smooth: c
            .section(kind::SMOOTH)
            .map(|p| smooth::decode(p, face_count))
            .transpose()?,
        materials: c
            .section(kind::MATERIALS)
            .map(|p| materials::decode(p, n))
            .transpose()?,
        point_lights: match c.section(kind::POINT_LIGHTS) {
            Some(p) => point_lights::decode(p)?,
            None => Vec::new(),
        },
        direct_lights: match c.section(kind::DIRECT_LIGHTS) {
            Some(p) => direct_lights::decode(p)?,
            None => Vec::new(),
        },
        sky_transfer: c
            .section(kind::SKY_TRANSFER)
            .map(|p| sky_transfer(p, n))
            .transpose()?,
        cameras: match c.section(kind::CAMERAS) {
            Some(p) => cameras::decode(p)?,
            None => Vec::new(),
        },
        bvh: c.section(kind::BVH).map(bvh::decode).transpose()?,
        lightmap: match (c.section(kind::LIGHTMAP), c.section(kind::ATLAS)) {
            (None, Some(_)) => {
                return Err(FormatError::corrupt(
                    "section ATLAS without LIGHTMAP: the atlas of no lightmap coordinates",
                ));
            }
            (None, None) => None,
            (Some(p), atlas) => {
                let mut l = lightmap::decode(p, face_count)?;
                l.atlas = atlas.map(lightmap::decode_atlas).transpose()?;
                Some(l)
            }
        },
        faces,
    })
}

impl Display {
    /// The display sections alone, in a container of their own: the payloads an operator file
    /// holds, for tools that carry them apart from a file (the sharded bake's part files). Not
    /// validated: the invariants need the file ([`OperatorFile::validate`]).
    pub fn to_container_bytes(&self) -> Vec<u8> {
        let mut w = ContainerWriter::new();
        add_display(&mut w, self);
        w.to_bytes()
    }

    /// Reads what [`to_container_bytes`](Self::to_container_bytes) wrote, for a file of `n`
    /// elements. The container and the lengths are checked (never a panic, whatever the bytes),
    /// the values are not: [`OperatorFile::validate`] checks them against the file.
    pub fn from_container_bytes(bytes: &[u8], n: u32) -> Result<Self, FormatError> {
        decode_display(&Container::parse(bytes)?, n as usize)
    }
}

/// SKY_TRANSFER's payload: `9 n` f32 (values checked by `validate`).
fn sky_transfer(payload: &[u8], n: usize) -> Result<Vec<f32>, FormatError> {
    let want = n.checked_mul(36);
    if want != Some(payload.len()) {
        return Err(FormatError::corrupt(format!(
            "section SKY_TRANSFER: {} bytes, expected 9 × 4 bytes for each of the {n} elements",
            payload.len()
        )));
    }
    Ok(payload
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// A matrix's payload whole (what [`matrix_pieces`] hands over, joined).
#[cfg(test)]
fn matrix_payload(m: &StoredMatrix) -> Vec<u8> {
    let mut out = Vec::new();
    match m {
        StoredMatrix::F32(v) => bytes::put_f32s(&mut out, v),
        StoredMatrix::F16(v) => bytes::put_u16s(&mut out, v),
    }
    out
}

fn encode_dims(file: &OperatorFile) -> Vec<u8> {
    let words = [
        file.n,
        file.k,
        file.channels,
        file.precision.code(),
        file.layout().code(),
        0,
        0,
        0,
    ];
    u32_payload(&words)
}

fn encode_geometry(g: &Geometry) -> Vec<u8> {
    let mut out = g.vertex_count.clone();
    out.resize(g.vertex_count.len().next_multiple_of(4), 0);
    bytes::put_f32s(&mut out, &g.vertices);
    bytes::put_f32s(&mut out, &g.normals);
    out
}

fn u32_payload(values: &[u32]) -> Vec<u8> {
    let mut out = Vec::new();
    bytes::put_u32s(&mut out, values);
    out
}

fn f32_payload(values: &[f32]) -> Vec<u8> {
    let mut out = Vec::new();
    bytes::put_f32s(&mut out, values);
    out
}

/// Decodes the sections of `c`; lengths are checked, values are not.
pub(crate) fn decode(c: &Container<'_>) -> Result<OperatorFile, FormatError> {
    let dims = require(c, kind::DIMS)?;
    if dims.len() != DIMS_LEN {
        return Err(length_error(
            kind::DIMS,
            DIMS_LEN,
            dims.len(),
            "8 u32 words",
        ));
    }
    let word = |i: usize| bytes::u32_at(dims, 4 * i).unwrap_or_default();
    let (n, k, channels) = (word(0), word(1), word(2));
    let precision =
        Precision::from_code(word(3)).ok_or_else(|| unknown_code("precision", word(3)))?;
    let layout = Layout::from_code(word(4)).ok_or_else(|| unknown_code("layout", word(4)))?;
    check_dims(n, k, channels)?;
    let sizes = Sizes::new(n, k, channels)?;

    let metadata = require(c, kind::METADATA)?;
    let metadata_json = String::from_utf8(metadata.to_vec()).map_err(|e| {
        FormatError::corrupt(format!(
            "section METADATA: not valid UTF-8 (at byte {})",
            e.utf8_error().valid_up_to()
        ))
    })?;
    let operator = decode_operator(c, layout, precision, &sizes)?;
    let lights = match c.section(kind::LIGHTS) {
        Some(payload) => lights::decode(payload, sizes.index - 1)?,
        None => Vec::new(),
    };
    let display = decode_display(c, sizes.n)?;
    Ok(OperatorFile {
        metadata_json,
        n,
        k,
        channels,
        precision,
        order: bytes::u32s(exact(c, kind::ORDER, sizes.n, 4, "n")?),
        index: bytes::u32s(exact(c, kind::INDEX, sizes.index, 4, "k + 1")?),
        weights: bytes::f32s(exact(c, kind::WEIGHTS, sizes.n, 4, "n")?),
        operator,
        reflectance: bytes::f32s(exact(c, kind::REFLECTANCE, sizes.rgb, 4, "n * 3")?),
        emission: bytes::f32s(exact(c, kind::EMISSION, sizes.rgb, 4, "n * 3")?),
        geometry: decode_geometry(require(c, kind::GEOMETRY)?, &sizes)?,
        lights,
        display,
    })
}

/// FK and CORES, or YK; the sections of the other layout must be absent.
fn decode_operator(
    c: &Container<'_>,
    layout: Layout,
    precision: Precision,
    sizes: &Sizes,
) -> Result<OperatorData, FormatError> {
    let (present, absent): (&[u32], &[u32]) = match layout {
        Layout::Factored => (&[kind::FK, kind::CORES], &[kind::YK]),
        Layout::PlainYk => (&[kind::YK], &[kind::FK, kind::CORES]),
    };
    if let Some(&other) = absent.iter().find(|&&kind| c.section(kind).is_some()) {
        return Err(FormatError::corrupt(format!(
            "section {} is present, but DIMS says the layout is {layout:?}, which stores {}",
            kind::describe(other),
            present
                .iter()
                .map(|&k| kind::name(k).unwrap_or("?"))
                .collect::<Vec<_>>()
                .join(" and ")
        )));
    }
    let matrix = |kind, count, formula| -> Result<StoredMatrix, FormatError> {
        let size = precision.size() as u64;
        let payload = exact(c, kind, count, size, formula)?;
        Ok(match precision {
            Precision::F32 => StoredMatrix::F32(bytes::f32s(payload)),
            Precision::F16 => StoredMatrix::F16(bytes::u16s(payload)),
        })
    };
    Ok(match layout {
        Layout::Factored => OperatorData::Factored {
            fk: matrix(kind::FK, sizes.fk, "n * k")?,
            cores: bytes::f64s(exact(c, kind::CORES, sizes.cores, 8, "channels * k * k")?),
        },
        Layout::PlainYk => OperatorData::PlainYk {
            yk: matrix(kind::YK, sizes.yk, "channels * n * k")?,
        },
    })
}

/// GEOMETRY: `n` u8 vertex counts padded to 4 bytes, `n * 12` f32 vertices, `n * 3` f32 normals.
fn decode_geometry(payload: &[u8], sizes: &Sizes) -> Result<Geometry, FormatError> {
    let counts_len = sizes.n.next_multiple_of(4);
    let vertices_len =
        checked_product("section GEOMETRY (n * 12 * 4)", &[sizes.vertices as u64, 4])?;
    let normals_len = checked_product("section GEOMETRY (n * 3 * 4)", &[sizes.rgb as u64, 4])?;
    let expected = counts_len
        .checked_add(vertices_len)
        .and_then(|x| x.checked_add(normals_len))
        .ok_or_else(|| FormatError::limits("section GEOMETRY: size overflows"))?;
    if payload.len() != expected {
        let what = "n vertex counts padded to 4 bytes, n * 12 + n * 3 f32";
        return Err(length_error(kind::GEOMETRY, expected, payload.len(), what));
    }
    let (counts, rest) = payload.split_at(counts_len);
    let (vertices, normals) = rest.split_at(vertices_len);
    Ok(Geometry {
        vertex_count: counts.get(..sizes.n).unwrap_or_default().to_vec(),
        vertices: bytes::f32s(vertices),
        normals: bytes::f32s(normals),
    })
}

fn require<'a>(c: &Container<'a>, kind: u32) -> Result<&'a [u8], FormatError> {
    c.section(kind)
        .ok_or_else(|| FormatError::corrupt(format!("section {} is missing", kind::describe(kind))))
}

/// The payload of `kind`, which must hold exactly `count` values of `size` bytes.
fn exact<'a>(
    c: &Container<'a>,
    kind: u32,
    count: usize,
    size: u64,
    formula: &str,
) -> Result<&'a [u8], FormatError> {
    let payload = require(c, kind)?;
    let name = kind::name(kind).unwrap_or("?");
    let expected = checked_product(
        &format!("section {name} ({formula})"),
        &[count as u64, size],
    )?;
    if payload.len() != expected {
        let what = format!("{formula} = {count} values of {size} bytes");
        return Err(length_error(kind, expected, payload.len(), &what));
    }
    Ok(payload)
}

fn length_error(kind: u32, expected: usize, found: usize, what: &str) -> FormatError {
    FormatError::corrupt(format!(
        "section {}: expected {expected} bytes ({what}), found {found}",
        kind::describe(kind)
    ))
}

fn unknown_code(field: &str, code: u32) -> FormatError {
    FormatError::new(
        ErrorKind::UnsupportedVersion,
        format!(
            "section DIMS: {field} code {code} is unknown to this reader: re-bake with this \
             version of lrr or upgrade the runtime"
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::display::{DirectLight, DirectLightKind};
    use crate::testdata::{display_sample, faces_sample, plain_sample, sample};

    #[test]
    fn round_trip_is_exact() {
        for file in [
            sample(Precision::F32, 3),
            sample(Precision::F16, 1),
            display_sample(),
            faces_sample(),
        ] {
            let bytes = encode(&file);
            let back = decode(&Container::parse(&bytes).unwrap()).unwrap();
            assert_eq!(back, file);
            assert_eq!(encode(&back), bytes);
        }
    }

    #[test]
    fn version_is_the_lowest_that_describes_the_file() {
        let plain = encode(&sample(Precision::F32, 3));
        assert_eq!(Container::parse(&plain).unwrap().version(), (1, 1));
        let full = encode(&display_sample());
        let c = Container::parse(&full).unwrap();
        assert_eq!(c.version(), (1, 2));
        let display = [
            kind::SMOOTH,
            kind::MATERIALS,
            kind::POINT_LIGHTS,
            kind::CAMERAS,
            kind::BVH,
        ];
        assert_eq!(c.kinds().collect::<Vec<_>>()[11..], display);
        assert!(c.sections()[11..].iter().all(|s| !s.required()));
        // Any one display section makes a 1.2 file.
        let mut one = sample(Precision::F32, 3);
        one.display.cameras = display_sample().display.cameras;
        let c_bytes = encode(&one);
        assert_eq!(Container::parse(&c_bytes).unwrap().version(), (1, 2));
        // LIGHTMAP makes a 1.3 file, written last of the optional sections: the lowest minor
        // that describes it (lib.rs, "Compatibility"), so 3, not VERSION_MINOR, since 1.4.
        let mut lit = display_sample();
        lit.display.lightmap = Some(crate::LightmapUv {
            uv: lit_uv(&lit),
            atlas: None,
        });
        let bytes = encode(&lit);
        let c = Container::parse(&bytes).unwrap();
        assert_eq!(c.version(), (1, 3));
        assert_eq!(c.kinds().last(), Some(kind::LIGHTMAP));
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), lit);
        // FACES makes a 1.4 file (the newest), with or without LIGHTMAP; written last, and
        // required (a 1.3 reader would mis-size SMOOTH, LIGHTMAP and the BVH without it).
        let mut faced = faces_sample();
        for lightmap in [
            None,
            Some(crate::LightmapUv {
                uv: lit_uv(&faced),
                atlas: None,
            }),
        ] {
            faced.display.lightmap = lightmap;
            let bytes = encode(&faced);
            let c = Container::parse(&bytes).unwrap();
            assert_eq!(c.version(), (1, 4));
            assert_eq!(c.kinds().last(), Some(kind::FACES));
            let last = c.sections().last().unwrap();
            assert!(last.required());
            assert!(
                c.sections()[11..c.sections().len() - 1]
                    .iter()
                    .all(|s| !s.required())
            );
            assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), faced);
        }
    }

    #[test]
    fn direct_lights_make_a_1_5_file_and_are_optional() {
        use crate::{DirectLight, DirectLightKind};
        for mut file in [display_sample(), faces_sample()] {
            file.display.direct_lights = vec![DirectLight {
                name: "sun".into(),
                kind: DirectLightKind::Directional,
                position: [0.0; 3],
                direction: [0.0, -1.0, 0.5],
                strength: [3.0; 3],
                extra: [0.0; 3],
            }];
            let bytes = encode(&file);
            let c = Container::parse(&bytes).unwrap();
            assert_eq!(c.version(), (1, 5));
            assert_eq!(crate::VERSION_MINOR, 6);
            let section = c
                .sections()
                .iter()
                .find(|s| s.kind == kind::DIRECT_LIGHTS)
                .unwrap();
            assert!(!section.required(), "a 1.4 reader skips it");
            assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
            // The sky's transfer: 9 floats per element, optional, 1.5; a wrong length or a
            // non-finite value is refused.
            file.display.sky_transfer =
                Some((0..9 * file.n).map(|i| (i % 9) as f32 * 0.25).collect());
            let bytes = encode(&file);
            let c = Container::parse(&bytes).unwrap();
            assert_eq!(c.version(), (1, 5));
            assert!(
                !c.sections()
                    .iter()
                    .find(|s| s.kind == kind::SKY_TRANSFER)
                    .unwrap()
                    .required()
            );
            assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
            let mut bad = file.clone();
            bad.display.sky_transfer.as_mut().unwrap().pop();
            assert!(bad.validate().is_err());
            let mut bad = file.clone();
            bad.display.sky_transfer.as_mut().unwrap()[4] = f32::NAN;
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains("element 0 coefficient 4"), "{e}");
        }
    }

    /// Lightmap coordinates for every used corner of `f`'s display faces (a triangle's fourth
    /// left zero).
    fn lit_uv(f: &OperatorFile) -> Vec<f32> {
        let faces = f.faces();
        let mut uv = vec![0.0; 8 * faces.len()];
        for e in 0..faces.len() {
            for c in 0..usize::from(faces.geometry.vertex_count[e]) {
                uv[8 * e + 2 * c] = e as f32 / 8.0;
                uv[8 * e + 2 * c + 1] = c as f32 / 4.0;
            }
        }
        uv
    }

    #[test]
    fn lightmap_coordinates_are_checked() {
        let mut lit = display_sample();
        let good = lit_uv(&lit);
        let triangle = (0..lit.n as usize)
            .find(|&e| lit.geometry.vertex_count[e] == 3)
            .expect("the sample has a triangle");
        let nan = |uv: &mut Vec<f32>| uv[1] = f32::NAN;
        let fourth = |uv: &mut Vec<f32>| uv[8 * triangle + 6] = 0.5;
        let short = |uv: &mut Vec<f32>| {
            uv.pop();
        };
        type Edit<'a> = &'a dyn Fn(&mut Vec<f32>);
        let edits: [(Edit, &str); 3] = [
            (&nan, "not finite"),
            (&fourth, "unused fourth corner"),
            (&short, "expected n * 8"),
        ];
        for (edit, want) in edits {
            let mut uv = good.clone();
            edit(&mut uv);
            lit.display.lightmap = Some(crate::LightmapUv { uv, atlas: None });
            let e = lit
                .validate()
                .expect_err("bad lightmap coordinates accepted");
            assert!(e.to_string().contains(want), "{e}");
        }
        // A payload of the wrong length is corrupt, not a panic.
        assert!(crate::lightmap::decode(&[0u8; 31], 1).is_err());
        assert!(crate::lightmap::decode(&[0u8; 32], 1).is_ok());
    }

    #[test]
    fn an_atlas_makes_a_1_6_file_is_optional_and_is_checked() {
        use crate::{LightmapAtlas, LightmapSource};
        let mut file = faces_sample();
        let generated = LightmapAtlas {
            width: 512,
            height: 256,
            padding: 2,
            source: LightmapSource::Generated,
            density: 12.5,
        };
        file.display.lightmap = Some(crate::LightmapUv {
            uv: lit_uv(&file),
            atlas: Some(generated),
        });
        let bytes = encode(&file);
        let c = Container::parse(&bytes).unwrap();
        assert_eq!(c.version(), (1, 6));
        let section = c.sections().iter().find(|s| s.kind == kind::ATLAS).unwrap();
        assert!(!section.required(), "a 1.5 reader keeps the coordinates");
        assert_eq!(OperatorFile::from_bytes(&bytes).unwrap(), file);
        type Edit = fn(&mut LightmapAtlas);
        let edits: [(Edit, &str); 5] = [
            (|a| a.width = 0, "width 0"),
            (|a| a.height = crate::MAX_ATLAS_SIDE + 1, "height 16385"),
            (|a| a.padding = 65, "padding 65"),
            (|a| a.density = f64::NAN, "density NaN"),
            (
                |a| a.source = LightmapSource::Scene,
                "density 12.5; must be 0",
            ),
        ];
        for (edit, want) in edits {
            let mut bad = file.clone();
            edit(
                bad.display
                    .lightmap
                    .as_mut()
                    .unwrap()
                    .atlas
                    .as_mut()
                    .unwrap(),
            );
            let e = bad
                .validate()
                .expect_err("a bad atlas accepted")
                .to_string();
            assert!(e.contains(want), "{e}");
        }
        assert!(crate::lightmap::decode_atlas(&[0u8; 23]).is_err());
        let mut unknown = crate::lightmap::encode_atlas(&generated);
        unknown[12] = 7;
        let e = crate::lightmap::decode_atlas(&unknown)
            .unwrap_err()
            .to_string();
        assert!(e.contains("source 7"), "{e}");
        // An atlas without coordinates is refused.
        let mut w = ContainerWriter::new();
        w.add(
            kind::ATLAS,
            false,
            crate::lightmap::encode_atlas(&generated),
        );
        let e = Display::from_container_bytes(&w.to_bytes(), 6).unwrap_err();
        assert!(e.to_string().contains("ATLAS without LIGHTMAP"), "{e}");
    }

    #[test]
    fn display_container_round_trips() {
        let d = faces_sample().display;
        let bytes = d.to_container_bytes();
        assert_eq!(Display::from_container_bytes(&bytes, 6).unwrap(), d);
        for len in 0..bytes.len() {
            assert!(Display::from_container_bytes(&bytes[..len], 6).is_err());
        }
        let d = display_sample().display;
        let bytes = d.to_container_bytes();
        assert_eq!(Display::from_container_bytes(&bytes, 6).unwrap(), d);
        let empty = Display::default().to_container_bytes();
        assert_eq!(
            Display::from_container_bytes(&empty, 6).unwrap(),
            Display::default()
        );
        assert!(Display::from_container_bytes(&bytes, 7).is_err());
        for len in 0..bytes.len() {
            assert!(Display::from_container_bytes(&bytes[..len], 6).is_err());
        }
    }

    #[test]
    fn streamed_writes_are_the_bytes_of_whole_files() {
        let dir = std::env::temp_dir().join(format!("lrr-formats-stream-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("streamed.lrr");
        for file in [sample(Precision::F32, 3), sample(Precision::F16, 1)] {
            let OperatorData::Factored { fk, cores } = &file.operator else {
                unreachable!()
            };
            let rows: Vec<StoredMatrix> = (0..6)
                .map(|r| match fk {
                    StoredMatrix::F32(v) => StoredMatrix::F32(v[2 * r..2 * r + 2].to_vec()),
                    StoredMatrix::F16(v) => StoredMatrix::F16(v[2 * r..2 * r + 2].to_vec()),
                })
                .collect();
            let mut skeleton = file.clone();
            skeleton.operator = OperatorData::Factored {
                fk: StoredMatrix::from_f32(&[], file.precision),
                cores: cores.clone(),
            };
            skeleton
                .write_streamed(&path, &mut |emit| rows.iter().try_for_each(&mut *emit))
                .unwrap();
            assert_eq!(std::fs::read(&path).unwrap(), encode(&file));
            // Too few rows: an error, and the file written before stays.
            let e = skeleton
                .write_streamed(&path, &mut |emit| rows[1..].iter().try_for_each(&mut *emit))
                .unwrap_err();
            assert!(e.to_string().contains("announced"), "{e}");
            // A bad value names its row.
            let bad = StoredMatrix::from_f32(&[0.5, f32::NAN], file.precision);
            let e = skeleton
                .write_streamed(&path, &mut |emit| {
                    emit(&rows[0])?;
                    emit(&bad)
                })
                .unwrap_err();
            assert!(e.to_string().contains("rows from element 1"), "{e}");
            assert_eq!(std::fs::read(&path).unwrap(), encode(&file));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn written_files_are_the_bytes_of_to_bytes() {
        let dir = std::env::temp_dir().join(format!("lrr-formats-write-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("written.lrr");
        for file in [
            sample(Precision::F32, 3),
            sample(Precision::F16, 1),
            plain_sample(Precision::F32, 3),
            plain_sample(Precision::F16, 1),
            display_sample(),
            faces_sample(),
        ] {
            file.write(&path).unwrap();
            assert_eq!(std::fs::read(&path).unwrap(), file.to_bytes().unwrap());
        }
        std::fs::remove_dir_all(&dir).unwrap();
        // A matrix of several pieces: the pieces, one after another, are its payload.
        let values: Vec<f32> = (0..2 * FK_PIECE + 5).map(|i| i as f32 / 7.0).collect();
        for m in [
            StoredMatrix::F32(values.clone()),
            StoredMatrix::from_f32(&values, Precision::F16),
        ] {
            let (mut joined, mut pieces) = (Vec::new(), 0);
            matrix_pieces(&m, &mut |piece| {
                joined.extend_from_slice(piece);
                pieces += 1;
                Ok(())
            })
            .unwrap();
            assert_eq!(pieces, 3);
            assert_eq!(joined, matrix_payload(&m));
        }
    }

    #[test]
    fn the_largest_display_payload_is_what_encoding_gives() {
        for file in [display_sample(), faces_sample(), sample(Precision::F32, 3)] {
            let d = &file.display;
            let bytes = d.to_container_bytes();
            let c = Container::parse(&bytes).unwrap();
            let largest = c
                .kinds()
                .map(|kind| c.section(kind).unwrap().len())
                .max()
                .unwrap_or(0);
            assert_eq!(d.largest_payload_bytes(), largest);
        }
        // Every record section and the sky, each alone the largest.
        let mut d = display_sample().display;
        d.smooth = None;
        d.bvh = None;
        d.direct_lights = (0..9)
            .map(|i| DirectLight {
                name: format!("sun {i}"),
                kind: DirectLightKind::Directional,
                position: [0.0; 3],
                direction: [0.0, 0.0, -1.0],
                strength: [1.0; 3],
                extra: [0.0; 3],
            })
            .collect();
        let bytes = d.to_container_bytes();
        let c = Container::parse(&bytes).unwrap();
        let lights = c.section(kind::DIRECT_LIGHTS).unwrap().len();
        assert_eq!(d.largest_payload_bytes(), lights);
        for kind in [kind::MATERIALS, kind::POINT_LIGHTS, kind::CAMERAS] {
            let alone = Display {
                direct_lights: Vec::new(),
                materials: (kind == kind::MATERIALS)
                    .then(|| d.materials.clone())
                    .flatten(),
                point_lights: match kind == kind::POINT_LIGHTS {
                    true => d.point_lights.clone(),
                    false => Vec::new(),
                },
                cameras: match kind == kind::CAMERAS {
                    true => d.cameras.clone(),
                    false => Vec::new(),
                },
                ..Display::default()
            };
            let bytes = alone.to_container_bytes();
            let c = Container::parse(&bytes).unwrap();
            assert_eq!(
                alone.largest_payload_bytes(),
                c.section(kind).unwrap().len(),
                "{}",
                kind::describe(kind)
            );
        }
        d.sky_transfer = Some(vec![0.5; 9 * 6 * 50]);
        let bytes = d.to_container_bytes();
        let c = Container::parse(&bytes).unwrap();
        assert_eq!(
            d.largest_payload_bytes(),
            c.section(kind::SKY_TRANSFER).unwrap().len()
        );
    }

    #[test]
    fn geometry_padding() {
        let file = sample(Precision::F32, 3);
        let payload = encode_geometry(&file.geometry);
        // n = 6 counts padded to 8, then 72 + 18 f32.
        assert_eq!(payload.len(), 8 + 4 * 72 + 4 * 18);
        assert_eq!(&payload[6..8], &[0, 0]);
    }

    #[test]
    fn length_mismatch_names_section_and_lengths() {
        let file = sample(Precision::F32, 3);
        let c_bytes = encode(&file);
        let c = Container::parse(&c_bytes).unwrap();
        let mut w = ContainerWriter::new();
        for kind in c.kinds() {
            let mut payload = c.section(kind).unwrap().to_vec();
            if kind == kind::WEIGHTS {
                payload.truncate(20);
            }
            w.add(kind, true, payload);
        }
        let bytes = w.to_bytes();
        let err = decode(&Container::parse(&bytes).unwrap()).unwrap_err();
        assert_eq!(err.kind, ErrorKind::Corrupt);
        assert_eq!(
            err.message,
            "section WEIGHTS (kind 5): expected 24 bytes (n = 6 values of 4 bytes), found 20"
        );
    }
}
