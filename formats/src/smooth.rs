//! Section SMOOTH: the smooth reconstruction weights (format 1.2), their byte encoding (tabled in
//! the crate docs), decoding and invariants.
//!
//! The payload's length follows from `n` (DIMS) and the two counts of its head, checked with
//! overflow-checked arithmetic before anything is copied out.

use crate::bytes::{self, checked_product, u32_at};
use crate::display::Smooth;
use crate::error::FormatError;
use crate::file::OperatorFile;

/// Largest weight magnitude (extrapolating boundary vertices have negative weights).
pub(crate) const MAX_WEIGHT: f32 = 8.0;
/// How far the weights of one smooth vertex may sum from 1.
pub(crate) const WEIGHT_SUM_TOLERANCE: f64 = 1e-5;

/// Encodes `s` (validated).
pub(crate) fn encode(s: &Smooth) -> Vec<u8> {
    let mut out = Vec::new();
    bytes::put_u32s(
        &mut out,
        &[s.vertex_count() as u32, s.positions.len() as u32],
    );
    bytes::put_u32s(&mut out, &s.corners);
    bytes::put_u32s(&mut out, &s.offsets);
    bytes::put_u32s(&mut out, &s.positions);
    bytes::put_f32s(&mut out, &s.weights);
    out
}

fn corrupt(message: String) -> FormatError {
    FormatError::corrupt(format!("section SMOOTH (kind 13): {message}"))
}

/// Decodes the payload of a file of `n` display faces (its elements, or the faces of FACES);
/// lengths are checked, values are not.
pub(crate) fn decode(payload: &[u8], n: usize) -> Result<Smooth, FormatError> {
    let (v, p) = match (u32_at(payload, 0), u32_at(payload, 4)) {
        (Some(v), Some(p)) => (u64::from(v), u64::from(p)),
        _ => {
            return Err(corrupt(format!(
                "{} bytes, too short for the two counts",
                payload.len()
            )));
        }
    };
    // 8 + 16 n + 4 (V + 1) + 8 P: at most 2^68, so the sum is done in u128.
    let expected = 8 + 16 * n as u128 + 4 * (u128::from(v) + 1) + 8 * u128::from(p);
    if expected != payload.len() as u128 {
        return Err(corrupt(format!(
            "expected {expected} bytes (8 + 4 corners of 4 bytes for each of {n} display faces, \
             {} offsets and {p} positions and weights), found {}",
            v + 1,
            payload.len()
        )));
    }
    let corners_end = checked_product("section SMOOTH (F * 16)", &[n as u64, 16])? + 8;
    let offsets_end = corners_end + 4 * (v as usize + 1);
    let positions_end = offsets_end + 4 * p as usize;
    Ok(Smooth {
        corners: bytes::u32s(&payload[8..corners_end]),
        offsets: bytes::u32s(&payload[corners_end..offsets_end]),
        positions: bytes::u32s(&payload[offsets_end..positions_end]),
        weights: bytes::f32s(&payload[positions_end..]),
    })
}

/// The invariants of [`Smooth`] against the file's elements; messages name the element and
/// corner or the smooth vertex.
pub(crate) fn check(f: &OperatorFile, s: &Smooth) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section SMOOTH: {m}")));
    let n = f.n as usize;
    let faces = f.faces();
    let (count, item) = match faces.is_separate() {
        true => ("F", "face"),
        false => ("n", "element"),
    };
    if s.corners.len() as u64 != 4 * faces.len() as u64 {
        return fail(format!(
            "expected {count} * 4 = {} corners, found {}",
            4 * faces.len() as u64,
            s.corners.len()
        ));
    }
    if s.positions.len() != s.weights.len() {
        return fail(format!(
            "{} positions but {} weights: one weight per position",
            s.positions.len(),
            s.weights.len()
        ));
    }
    match s.offsets.first() {
        None => return fail("no offsets: V + 1 >= 1 are needed".into()),
        Some(&first) if first != 0 => return fail(format!("offsets[0] = {first}, must be 0")),
        _ => {}
    }
    for (v, pair) in s.offsets.windows(2).enumerate() {
        if pair[1] <= pair[0] {
            return fail(format!(
                "offsets[{v}] = {} and offsets[{}] = {}: offsets must increase strictly (smooth \
                 vertex {v} needs at least one position)",
                pair[0],
                v + 1,
                pair[1]
            ));
        }
    }
    let last = s.offsets[s.offsets.len() - 1] as usize;
    if last != s.positions.len() {
        return fail(format!(
            "the last offset is {last}, must be the number of positions {}",
            s.positions.len()
        ));
    }
    let vertices = s.vertex_count();
    for (e, (corners, &count)) in s
        .corners
        .chunks_exact(4)
        .zip(&faces.geometry.vertex_count)
        .enumerate()
    {
        for (j, &v) in corners.iter().enumerate() {
            if j < usize::from(count) {
                if v as usize >= vertices {
                    let what = if v == Smooth::NONE {
                        "NONE (only a triangle's unused 4th corner may be NONE)".to_string()
                    } else {
                        format!("{v}, not below the {vertices} smooth vertices")
                    };
                    return fail(format!("{item} {e} corner {j}: smooth vertex {what}"));
                }
            } else if v != Smooth::NONE {
                return fail(format!(
                    "{item} {e} corner {j}: a triangle's unused 4th corner must be NONE \
                     ({}), found {v}",
                    Smooth::NONE
                ));
            }
        }
    }
    for v in 0..vertices {
        let range = s.offsets[v] as usize..s.offsets[v + 1] as usize;
        let mut sum = 0.0f64;
        for (&p, &w) in s.positions[range.clone()].iter().zip(&s.weights[range]) {
            if p as usize >= n {
                return fail(format!(
                    "smooth vertex {v}: position {p} is not below n = {n}"
                ));
            }
            if !(w != 0.0 && w.abs() <= MAX_WEIGHT) {
                return fail(format!(
                    "smooth vertex {v}: the weight of position {p} is {w}, must be finite, \
                     non-zero and within ±{MAX_WEIGHT}"
                ));
            }
            sum += f64::from(w);
        }
        if (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE {
            return fail(format!(
                "smooth vertex {v}: the weights sum to {sum}, must sum to 1 (within \
                 {WEIGHT_SUM_TOLERANCE})"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testdata::display_sample;

    #[test]
    fn encoding_is_as_documented() {
        let f = display_sample();
        let s = f.display.smooth.as_ref().unwrap();
        let bytes = encode(s);
        let (v, p) = (s.vertex_count(), s.positions.len());
        assert_eq!(bytes.len(), 8 + 16 * 6 + 4 * (v + 1) + 8 * p);
        assert_eq!(u32_at(&bytes, 0), Some(v as u32));
        assert_eq!(u32_at(&bytes, 4), Some(p as u32));
        // Element 1 is a triangle: its 4th corner is NONE.
        assert_eq!(u32_at(&bytes, 8 + 16 + 12), Some(u32::MAX));
        assert_eq!(&decode(&bytes, 6).unwrap(), s);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let f = display_sample();
        let good = encode(f.display.smooth.as_ref().unwrap());
        for len in 0..good.len() {
            assert!(decode(&good[..len], 6).is_err(), "prefix {len}");
        }
        assert!(decode(&good, 7).is_err());
        for at in [0, 4] {
            let mut huge = good.clone();
            huge[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
            let e = decode(&huge, 6).unwrap_err();
            assert!(e.message.contains("expected"), "{e}");
        }
        let e = decode(&good, usize::MAX / 2).unwrap_err();
        assert!(e.message.contains("expected"), "{e}");
    }

    #[test]
    fn invariants_name_element_corner_and_vertex() {
        type Edit = fn(&mut Smooth);
        let cases: [(Edit, &str); 12] = [
            (|s| s.corners.truncate(20), "expected n * 4 = 24 corners"),
            (
                |s| s.corners[5] = 99,
                "element 1 corner 1: smooth vertex 99",
            ),
            (
                |s| s.corners[4] = Smooth::NONE,
                "element 1 corner 0: smooth vertex NONE",
            ),
            (
                |s| s.corners[7] = 0,
                "element 1 corner 3: a triangle's unused 4th corner must be NONE",
            ),
            (|s| s.offsets[0] = 1, "offsets[0] = 1, must be 0"),
            (
                |s| s.offsets[2] = s.offsets[1],
                "offsets must increase strictly",
            ),
            (|s| s.offsets.clear(), "no offsets"),
            (
                |s| {
                    s.offsets.pop();
                },
                "the last offset is",
            ),
            (
                |s| s.positions[0] = 6,
                "smooth vertex 0: position 6 is not below n = 6",
            ),
            (
                |s| s.weights[0] = f32::NAN,
                "smooth vertex 0: the weight of position 0 is NaN",
            ),
            (
                |s| s.weights[0] *= 0.999,
                "smooth vertex 0: the weights sum to",
            ),
            (|s| s.weights.push(0.5), "positions but"),
        ];
        for (edit, expected) in cases {
            let mut f = display_sample();
            f.validate().unwrap();
            edit(f.display.smooth.as_mut().unwrap());
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with("section SMOOTH: "),
                "{e} (expected {expected:?})"
            );
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
        }
    }
}
