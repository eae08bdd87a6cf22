//! Section FACES (kind 19, format 1.4, written as required): the display faces, their byte
//! encoding (tabled in the crate docs), decoding and invariants; and the checks of a polygon
//! list that GEOMETRY and FACES share.
//!
//! The payload: a head of the face count `F` and a reserved word, then `F` × u32 file positions,
//! `F` × u8 vertex counts zero-padded to a multiple of 4 bytes, `F * 12` × f32 vertices and
//! `F * 3` × f32 normals. Its length follows from `F`, checked before anything is copied out.

use crate::bytes::{self, u32_at};
use crate::error::FormatError;
use crate::file::OperatorFile;
use crate::geometry::{Faces, Geometry};

/// How far a stored normal's length may be from 1.
pub(crate) const NORMAL_TOLERANCE: f64 = 1e-3;

/// Encodes `faces` (validated).
pub(crate) fn encode(faces: &Faces) -> Vec<u8> {
    let count = faces.element.len();
    let mut out = Vec::with_capacity(8 + 64 * count);
    bytes::put_u32s(&mut out, &[count as u32, 0]);
    bytes::put_u32s(&mut out, &faces.element);
    out.extend_from_slice(&faces.geometry.vertex_count);
    out.resize(8 + 4 * count + count.next_multiple_of(4), 0);
    bytes::put_f32s(&mut out, &faces.geometry.vertices);
    bytes::put_f32s(&mut out, &faces.geometry.normals);
    out
}

/// Decodes the payload; lengths are checked, values are not.
pub(crate) fn decode(payload: &[u8]) -> Result<Faces, FormatError> {
    let corrupt = |m: String| FormatError::corrupt(format!("section FACES (kind 19): {m}"));
    let Some(count) = u32_at(payload, 0).filter(|_| payload.len() >= 8) else {
        return Err(corrupt(format!(
            "{} bytes, too short for the face count and the reserved word",
            payload.len()
        )));
    };
    // 8 + 4 F + F padded to 4 + 48 F + 12 F: below 2^39, no overflow in u64.
    let f = u64::from(count);
    let padded = f.next_multiple_of(4);
    let expected = 8 + 4 * f + padded + 48 * f + 12 * f;
    if expected != payload.len() as u64 {
        return Err(corrupt(format!(
            "expected {expected} bytes (8 + {count} faces: u32 element, u8 vertex count padded \
             to 4 bytes, 12 + 3 f32), found {}",
            payload.len()
        )));
    }
    let count = count as usize;
    let elements_end = 8 + 4 * count;
    let counts_end = elements_end + padded as usize;
    let vertices_end = counts_end + 48 * count;
    Ok(Faces {
        element: bytes::u32s(&payload[8..elements_end]),
        geometry: Geometry {
            vertex_count: payload[elements_end..elements_end + count].to_vec(),
            vertices: bytes::f32s(&payload[counts_end..vertices_end]),
            normals: bytes::f32s(&payload[vertices_end..]),
        },
    })
}

/// The invariants of [`Faces`] against the file's elements: at least one face, consistent
/// lengths, every face showing a file position `< n` and every file position shown by at least
/// one face, and polygons as GEOMETRY's ([`check_polygons`]).
pub(crate) fn check(f: &OperatorFile, faces: &Faces) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section FACES: {m}")));
    let count = faces.element.len();
    if count == 0 {
        return fail("no faces: a file with FACES draws every element as at least one".into());
    }
    let g = &faces.geometry;
    let lengths = [
        ("vertex counts", count, g.vertex_count.len()),
        ("vertex coordinates", 12 * count, g.vertices.len()),
        ("normal coordinates", 3 * count, g.normals.len()),
    ];
    for (what, expected, found) in lengths {
        if expected != found {
            return fail(format!(
                "{count} faces need {expected} {what}, found {found}"
            ));
        }
    }
    let n = f.n as usize;
    let mut shown = vec![false; n];
    for (face, &e) in faces.element.iter().enumerate() {
        match shown.get_mut(e as usize) {
            Some(slot) => *slot = true,
            None => {
                return fail(format!(
                    "face {face}: element {e} is not below n = {n} (a file position)"
                ));
            }
        }
    }
    if let Some(e) = shown.iter().position(|&s| !s) {
        return fail(format!(
            "element {e} (file position) has no face: every element is drawn by at least one"
        ));
    }
    check_polygons("FACES", "face", g)
}

/// The polygons of GEOMETRY or FACES (lengths checked before): 3 or 4 finite vertices, a
/// triangle's 4th zero, unit normals within [`NORMAL_TOLERANCE`]. Messages read
/// `section {section}: {item} {i}: {problem}`.
pub(crate) fn check_polygons(section: &str, item: &str, g: &Geometry) -> Result<(), FormatError> {
    let polygons = g.vertices.chunks_exact(12).zip(g.normals.chunks_exact(3));
    for (e, (&count, (vertices, normal))) in g.vertex_count.iter().zip(polygons).enumerate() {
        let fail = |problem: String| {
            Err(FormatError::invalid(format!(
                "section {section}: {item} {e}: {problem}"
            )))
        };
        if count != 3 && count != 4 {
            return fail(format!("{count} vertices, must be 3 or 4"));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            let value = vertices[i];
            return fail(format!(
                "vertex {}: coordinate {value} is not finite",
                i / 3
            ));
        }
        if count == 3 && vertices[9..].iter().any(|&v| v != 0.0) {
            return fail("a triangle whose unused 4th vertex is not (0, 0, 0)".into());
        }
        let length = normal
            .iter()
            .map(|&v| f64::from(v) * f64::from(v))
            .sum::<f64>()
            .sqrt();
        if length.is_nan() || (length - 1.0).abs() > NORMAL_TOLERANCE {
            return fail(format!(
                "normal {normal:?} has length {length}, must be unit (within {NORMAL_TOLERANCE})"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata::{display_sample, faces_sample};

    fn faces() -> Faces {
        faces_sample().display.faces.unwrap()
    }

    #[test]
    fn encoding_is_as_documented() {
        let f = faces();
        let bytes = encode(&f);
        // 9 faces: head, 9 elements, 9 counts padded to 12, 9 * 12 + 9 * 3 f32.
        assert_eq!(bytes.len(), 8 + 36 + 12 + 4 * 9 * 15);
        assert_eq!(u32_at(&bytes, 0), Some(9));
        assert_eq!(u32_at(&bytes, 4), Some(0));
        assert_eq!(u32_at(&bytes, 8), Some(0));
        assert_eq!(u32_at(&bytes, 8 + 4 * 2), Some(1));
        assert_eq!(&bytes[44..56], &[3, 3, 3, 3, 3, 3, 3, 3, 3, 0, 0, 0]);
        assert_eq!(decode(&bytes).unwrap(), f);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let good = encode(&faces());
        for len in 0..good.len() {
            assert!(decode(&good[..len]).is_err(), "prefix {len}");
        }
        let mut longer = good.clone();
        longer.extend([0; 4]);
        assert!(decode(&longer).is_err());
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode(&huge).unwrap_err();
        assert!(
            e.message.starts_with("section FACES (kind 19): expected"),
            "{e}"
        );
        // The reserved word is skipped.
        let mut reserved = good.clone();
        reserved[4] = 7;
        assert_eq!(decode(&reserved).unwrap(), faces());
    }

    #[test]
    fn invariants_name_the_face_and_the_problem() {
        type Edit = fn(&mut Faces);
        let cases: [(Edit, &str); 11] = [
            (|f| *f = Faces::default(), "section FACES: no faces"),
            (
                |f| f.element[4] = 6,
                "section FACES: face 4: element 6 is not below n = 6",
            ),
            (
                |f| f.element[2] = 0,
                "section FACES: element 1 (file position) has no face",
            ),
            (
                |f| {
                    f.geometry.vertex_count.pop();
                },
                "section FACES: 9 faces need 9 vertex counts, found 8",
            ),
            (
                |f| {
                    f.geometry.vertices.pop();
                },
                "section FACES: 9 faces need 108 vertex coordinates, found 107",
            ),
            (
                |f| f.geometry.normals.extend([0.0; 3]),
                "section FACES: 9 faces need 27 normal coordinates, found 30",
            ),
            (
                |f| f.geometry.vertex_count[3] = 2,
                "section FACES: face 3: 2 vertices, must be 3 or 4",
            ),
            (
                |f| f.geometry.vertex_count[3] = 5,
                "section FACES: face 3: 5 vertices, must be 3 or 4",
            ),
            (
                |f| f.geometry.vertices[12 * 5 + 4] = f32::INFINITY,
                "section FACES: face 5: vertex 1: coordinate inf is not finite",
            ),
            (
                |f| f.geometry.vertices[12 * 5 + 10] = 1.0,
                "section FACES: face 5: a triangle whose unused 4th vertex",
            ),
            (
                |f| f.geometry.normals[3 * 7 + 2] = 0.9,
                "section FACES: face 7: normal [0.0, 0.0, 0.9] has length 0.89",
            ),
        ];
        for (edit, expected) in cases {
            let mut f = faces_sample();
            f.validate().unwrap();
            edit(f.display.faces.as_mut().unwrap());
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with(expected),
                "{e} (expected {expected:?})"
            );
        }
    }

    #[test]
    fn the_display_sections_are_sized_by_the_faces() {
        let mut f = faces_sample();
        let faces = f.faces();
        assert!(faces.is_separate());
        assert_eq!((faces.len(), faces.triangle_count()), (9, 9));
        assert_eq!(faces.element(4), 2);
        assert_eq!(faces.triangles().nth(4).unwrap().0, 4);
        // SMOOTH of the elements' corners (n * 4) no longer fits.
        f.display.smooth = display_sample().display.smooth;
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .starts_with("section SMOOTH: expected F * 4 = 36 corners, found 24"),
            "{e}"
        );
        let mut f = faces_sample();
        f.display.smooth.as_mut().unwrap().corners[4 * 5 + 3] = 0;
        let e = f.validate().unwrap_err();
        assert!(
            e.message.starts_with(
                "section SMOOTH: face 5 corner 3: a triangle's unused 4th corner must be NONE"
            ),
            "{e}"
        );
        // LIGHTMAP: 4 corners per face.
        let mut f = faces_sample();
        f.display.lightmap = Some(crate::LightmapUv {
            uv: vec![0.0; 48],
            atlas: None,
        });
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .starts_with("section LIGHTMAP: expected F * 8 = 72"),
            "{e}"
        );
        let mut uv = vec![0.0; 72];
        uv[8 * 2 + 6] = 0.5;
        f.display.lightmap = Some(crate::LightmapUv { uv, atlas: None });
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .starts_with("section LIGHTMAP: face 2 is a triangle"),
            "{e}"
        );
        // BVH: T counts the faces' triangles; its boxes must hold the faces.
        let mut f = faces_sample();
        f.display.bvh.as_mut().unwrap().triangles.pop();
        let e = f.validate().unwrap_err();
        assert!(
            e.message
                .starts_with("section BVH: 8 triangle ids, but FACES has 9 display triangles"),
            "{e}"
        );
        let mut f = faces_sample();
        // Face 0 (element 0) moved out of its leaf's box.
        f.display.faces.as_mut().unwrap().geometry.vertices[2] = 0.5;
        let e = f.validate().unwrap_err();
        assert!(e.message.starts_with("section BVH: node 1: the box"), "{e}");
        // Without FACES, a face is its element.
        let plain = display_sample();
        let faces = plain.faces();
        assert!(!faces.is_separate());
        assert_eq!((faces.len(), faces.element(4)), (6, 4));
        assert_eq!(faces.elements(), None);
    }
}
