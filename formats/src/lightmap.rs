//! Section LIGHTMAP (kind 18, format 1.3, optional): lightmap texture coordinates of every
//! display face's corner, from the scene's own second UV set (glTF `TEXCOORD_1`), so that
//! exports rasterise into the atlas the user's engine already has.
//!
//! The payload is `F * 4 * 2` × f32 and nothing else: `u, v` of each corner of each display
//! face in order (`F = n`, the elements in file order with their corners as GEOMETRY stores
//! them, without FACES); a triangle's unused fourth corner is zero. Its length follows from
//! `F` (FACES' count, else `n` of DIMS).

use crate::bytes::{self, checked_product};
use crate::display::LightmapUv;
use crate::error::FormatError;
use crate::file::OperatorFile;

/// Encodes `uv` (validated).
pub(crate) fn encode(uv: &LightmapUv) -> Vec<u8> {
    let mut out = Vec::with_capacity(4 * uv.uv.len());
    bytes::put_f32s(&mut out, &uv.uv);
    out
}

/// Decodes the payload of a file of `n` display faces; the length is checked, values are not.
pub(crate) fn decode(payload: &[u8], n: usize) -> Result<LightmapUv, FormatError> {
    let expected = checked_product("section LIGHTMAP (F * 32)", &[n as u64, 32])?;
    if payload.len() != expected {
        return Err(FormatError::corrupt(format!(
            "section LIGHTMAP (kind 18): expected {expected} bytes (4 corners * 2 f32 for each \
             of {n} display faces), found {}",
            payload.len()
        )));
    }
    Ok(LightmapUv {
        uv: bytes::f32s(payload),
    })
}

/// The invariants of [`LightmapUv`] against the file's display faces: `F * 8` finite values,
/// the unused fourth corner of a triangle zero.
pub(crate) fn check(f: &OperatorFile, uv: &LightmapUv) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section LIGHTMAP: {m}")));
    let faces = f.faces();
    let n = faces.len();
    let (count, item) = match faces.is_separate() {
        true => ("F", "face"),
        false => ("n", "element"),
    };
    if uv.uv.len() as u64 != 8 * n as u64 {
        return fail(format!(
            "expected {count} * 8 = {} values, found {}",
            8 * n as u64,
            uv.uv.len()
        ));
    }
    for e in 0..n {
        let used = usize::from(faces.geometry.vertex_count[e]);
        for corner in 0..4 {
            let at = 8 * e + 2 * corner;
            let (u, v) = (uv.uv[at], uv.uv[at + 1]);
            if corner < used && !(u.is_finite() && v.is_finite()) {
                return fail(format!(
                    "{item} {e} corner {corner}: ({u}, {v}) is not finite"
                ));
            }
            if corner >= used && (u != 0.0 || v != 0.0) {
                return fail(format!(
                    "{item} {e} is a triangle but its unused fourth corner holds ({u}, {v}), \
                     not zeros"
                ));
            }
        }
    }
    Ok(())
}
