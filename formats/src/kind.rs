//! Section kinds: the `u32` codes in the section table.
//!
//! Every kind listed here is known to this reader. The writer marks all of them *required* except
//! [`LIGHTS`] (optional, so that readers of format 1.0 skip it) and the display sections of format
//! 1.2 and 1.3, [`SMOOTH`] to [`LIGHTMAP`] (optional: a reader that only evaluates skips them);
//! [`FACES`] (1.4) is required although it is for display: it changes what SMOOTH, LIGHTMAP and
//! the BVH are defined on, so an older reader must refuse the file rather than misread them;
//! [`DIRECT_LIGHTS`] and [`SKY_TRANSFER`] (1.5) are optional (a reader that does not know them
//! loses those lights only), and so is [`ATLAS`] (1.6: a reader that does not know it keeps the
//! lightmap coordinates without their atlas size). A
//! reader that meets a required kind it does not know refuses the file, and skips unknown
//! optional ones. New kinds take new codes; a code is never reused for another meaning.

/// UTF-8 JSON text from the precompute (scene name, bake parameters, timings, error estimates).
pub const METADATA: u32 = 1;
/// `n, k, channels, precision, layout` and three reserved words, all `u32`.
pub const DIMS: u32 = 2;
/// `n` × `u32`: file position -> original element id.
pub const ORDER: u32 = 3;
/// `k + 1` × `u32`: patch `p` holds file positions `index[p]..index[p + 1]`.
pub const INDEX: u32 = 4;
/// `n` × `f32`: `w_e = A_e / A_P(e)`.
pub const WEIGHTS: u32 = 5;
/// `n * k` element-to-patch form factors `F_k`, row-major, `f32` or binary16 per DIMS.
pub const FK: u32 = 6;
/// `channels * k * k` × `f64`: the cores `M_c = (I - Vᵀ diag(rho_c) F_k)⁻¹`, row-major.
pub const CORES: u32 = 7;
/// `n * 3` × `f32`: RGB reflectance per element.
pub const REFLECTANCE: u32 = 8;
/// `n * 3` × `f32`: RGB emitted exitance per element.
pub const EMISSION: u32 = 9;
/// Display geometry: vertex counts, vertices, normals.
pub const GEOMETRY: u32 = 10;
/// `channels * n * k` plain `Y_c = -diag(rho_c) F_k M_c`, `f32` or binary16 per DIMS (format 1.1,
/// plain layout only).
pub const YK: u32 = 11;
/// Light groups: names, positions, emission and `Vᵀ E_g` (format 1.1, optional).
pub const LIGHTS: u32 = 12;
/// Smooth reconstruction weights: corners -> smooth vertices -> weighted elements (format 1.2,
/// optional).
pub const SMOOTH: u32 = 13;
/// Materials for display and the material of every element (format 1.2, optional).
pub const MATERIALS: u32 = 14;
/// Point lights: position, intensity, light group (format 1.2, optional).
pub const POINT_LIGHTS: u32 = 15;
/// Pinhole cameras (format 1.2, optional).
pub const CAMERAS: u32 = 16;
/// The flattened binary BVH over the display triangles (format 1.2, optional).
pub const BVH: u32 = 17;
/// Lightmap texture coordinates of every display face corner (format 1.3, optional).
pub const LIGHTMAP: u32 = 18;
/// The display faces: per face its element, vertex counts, vertices, normals (format 1.4,
/// written as required when present).
pub const FACES: u32 = 19;

/// Spot and directional lights and the sky (format 1.5, optional).
pub const DIRECT_LIGHTS: u32 = 20;

/// The sky's order-2 spherical harmonic transfer per element (format 1.5, optional).
pub const SKY_TRANSFER: u32 = 21;

/// The lightmap atlas that LIGHTMAP's coordinates address: its size in texels, padding and
/// where the coordinates came from (format 1.6, optional).
pub const ATLAS: u32 = 22;

/// Every kind this reader knows, by code. The writer stores them in this order, leaving out the
/// operator sections of the other layout (FK and CORES, or YK), an empty LIGHTS and the display
/// sections the file lacks.
pub const KNOWN: [u32; 22] = [
    METADATA,
    DIMS,
    ORDER,
    INDEX,
    WEIGHTS,
    FK,
    CORES,
    REFLECTANCE,
    EMISSION,
    GEOMETRY,
    YK,
    LIGHTS,
    SMOOTH,
    MATERIALS,
    POINT_LIGHTS,
    CAMERAS,
    BVH,
    LIGHTMAP,
    FACES,
    DIRECT_LIGHTS,
    SKY_TRANSFER,
    ATLAS,
];

/// The name of a known kind (`"FK"`), `None` for unknown codes.
pub fn name(kind: u32) -> Option<&'static str> {
    Some(match kind {
        METADATA => "METADATA",
        DIMS => "DIMS",
        ORDER => "ORDER",
        INDEX => "INDEX",
        WEIGHTS => "WEIGHTS",
        FK => "FK",
        CORES => "CORES",
        REFLECTANCE => "REFLECTANCE",
        EMISSION => "EMISSION",
        GEOMETRY => "GEOMETRY",
        YK => "YK",
        LIGHTS => "LIGHTS",
        SMOOTH => "SMOOTH",
        MATERIALS => "MATERIALS",
        POINT_LIGHTS => "POINT_LIGHTS",
        DIRECT_LIGHTS => "DIRECT_LIGHTS",
        SKY_TRANSFER => "SKY_TRANSFER",
        ATLAS => "ATLAS",
        CAMERAS => "CAMERAS",
        BVH => "BVH",
        LIGHTMAP => "LIGHTMAP",
        FACES => "FACES",
        _ => return None,
    })
}

/// Whether this reader knows `kind`.
pub fn is_known(kind: u32) -> bool {
    name(kind).is_some()
}

/// `"FK (kind 6)"` or `"kind 99"`, for messages.
pub(crate) fn describe(kind: u32) -> String {
    match name(kind) {
        Some(name) => format!("{name} (kind {kind})"),
        None => format!("kind {kind}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_distinct_and_complete() {
        for (i, &k) in KNOWN.iter().enumerate() {
            assert!(is_known(k));
            assert!(!KNOWN[..i].contains(&k));
        }
        assert_eq!(name(FK), Some("FK"));
        assert_eq!(name(0), None);
        assert_eq!(describe(99), "kind 99");
        assert_eq!(describe(CORES), "CORES (kind 7)");
        assert_eq!(describe(BVH), "BVH (kind 17)");
        assert_eq!(describe(LIGHTMAP), "LIGHTMAP (kind 18)");
        assert_eq!(describe(FACES), "FACES (kind 19)");
        assert_eq!(describe(DIRECT_LIGHTS), "DIRECT_LIGHTS (kind 20)");
        assert_eq!(describe(SKY_TRANSFER), "SKY_TRANSFER (kind 21)");
        assert_eq!(describe(ATLAS), "ATLAS (kind 22)");
        assert_eq!(KNOWN.last(), Some(&ATLAS));
    }
}
