//! Section LIGHTMAP (kind 18, format 1.3, optional): lightmap texture coordinates of every
//! display face's corner, from the scene's own second UV set (glTF `TEXCOORD_1`), so that
//! exports rasterise into the atlas the user's engine already has.
//!
//! The payload is `F * 4 * 2` × f32 and nothing else: `u, v` of each corner of each display
//! face in order (`F = n`, the elements in file order with their corners as GEOMETRY stores
//! them, without FACES); a triangle's unused fourth corner is zero. Its length follows from
//! `F` (FACES' count, else `n` of DIMS).
//!
//! Since format 1.6 the coordinates may also be the bake's own charts, and section ATLAS
//! (kind 22, optional, only beside LIGHTMAP) names the atlas they address: 24 bytes, `width`,
//! `height`, `padding` and `source` (u32: 0 the scene's coordinates, 1 generated charts), then
//! `density` (f64, texels per scene unit, 0 for the scene's coordinates).

use crate::bytes::{self, checked_product};
use crate::display::{
    LightmapAtlas, LightmapSource, LightmapUv, MAX_ATLAS_PADDING, MAX_ATLAS_SIDE,
};
use crate::error::FormatError;
use crate::file::OperatorFile;

/// Encodes section ATLAS (validated).
pub(crate) fn encode_atlas(a: &LightmapAtlas) -> Vec<u8> {
    let source = match a.source {
        LightmapSource::Scene => 0,
        LightmapSource::Generated => 1,
    };
    let mut out = Vec::with_capacity(24);
    bytes::put_u32s(&mut out, &[a.width, a.height, a.padding, source]);
    bytes::put_f64s(&mut out, &[a.density]);
    out
}

/// Decodes section ATLAS; the length and the source code are checked, the values by [`check`].
pub(crate) fn decode_atlas(payload: &[u8]) -> Result<LightmapAtlas, FormatError> {
    if payload.len() != 24 {
        return Err(FormatError::corrupt(format!(
            "section ATLAS (kind 22): expected 24 bytes (width, height, padding, source, \
             density), found {}",
            payload.len()
        )));
    }
    let w = bytes::u32s(&payload[..16]);
    let source = match w[3] {
        0 => LightmapSource::Scene,
        1 => LightmapSource::Generated,
        other => {
            return Err(FormatError::corrupt(format!(
                "section ATLAS: source {other} is unknown (0 the scene's coordinates, 1 \
                 generated charts)"
            )));
        }
    };
    Ok(LightmapAtlas {
        width: w[0],
        height: w[1],
        padding: w[2],
        source,
        density: bytes::f64s(&payload[16..])[0],
    })
}

/// The invariants of [`LightmapAtlas`]: sides 1 to [`MAX_ATLAS_SIDE`], padding at most
/// [`MAX_ATLAS_PADDING`], a generated atlas's density finite and > 0, the scene's 0.
fn check_atlas(a: &LightmapAtlas) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section ATLAS: {m}")));
    for (name, side) in [("width", a.width), ("height", a.height)] {
        if !(1..=MAX_ATLAS_SIDE).contains(&side) {
            return fail(format!(
                "{name} {side} texels; must be 1 to {MAX_ATLAS_SIDE}"
            ));
        }
    }
    if a.padding > MAX_ATLAS_PADDING {
        return fail(format!(
            "padding {} texels; at most {MAX_ATLAS_PADDING}",
            a.padding
        ));
    }
    match a.source {
        LightmapSource::Generated if !(a.density.is_finite() && a.density > 0.0) => fail(format!(
            "generated charts at density {}; must be finite and > 0 texels per unit",
            a.density
        )),
        LightmapSource::Scene if a.density != 0.0 => fail(format!(
            "the scene's coordinates with density {}; must be 0",
            a.density
        )),
        _ => Ok(()),
    }
}

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
        atlas: None,
    })
}

/// The invariants of [`LightmapUv`] against the file's display faces: `F * 8` finite values,
/// the unused fourth corner of a triangle zero.
pub(crate) fn check(f: &OperatorFile, uv: &LightmapUv) -> Result<(), FormatError> {
    if let Some(a) = &uv.atlas {
        check_atlas(a)?;
    }
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
