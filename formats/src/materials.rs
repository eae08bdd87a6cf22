//! Section MATERIALS (format 1.2): the materials a ray tracer shades with and the material of
//! every element; byte encoding (tabled in the crate docs), decoding and invariants.

use crate::bytes::{self, checked_product, f32_at, vec3_at};
use crate::display::{Material, Materials};
use crate::error::FormatError;
use crate::file::OperatorFile;
use crate::kind;
use crate::records::{self, Shape};

/// The records' shape: 4 rows of 16 bytes (diffuse, shininess; specular, ior; mirror, name
/// length; transmission, reserved).
const SHAPE: Shape = Shape {
    kind: kind::MATERIALS,
    what: "material",
    record_len: 64,
    name_at: 44,
};

/// Encodes `m` (validated).
pub(crate) fn encode(m: &Materials) -> Vec<u8> {
    let mut out = Vec::new();
    records::put_head(&mut out, m.materials.len());
    for material in &m.materials {
        records::put_row_f(&mut out, material.diffuse, material.shininess);
        records::put_row_f(&mut out, material.specular, material.ior);
        records::put_row(&mut out, material.mirror, material.name.len() as u32);
        records::put_row(&mut out, material.transmission, 0);
    }
    bytes::put_u32s(&mut out, &m.element_material);
    records::put_names(&mut out, m.materials.iter().map(|m| m.name.as_str()));
    out
}

/// Decodes the payload of a file of `n` elements; lengths and UTF-8 are checked, values are not.
pub(crate) fn decode(payload: &[u8], n: usize) -> Result<Materials, FormatError> {
    let block = checked_product("section MATERIALS (n * 4)", &[n as u64, 4]).ok();
    let table = SHAPE.decode(payload, block)?;
    let materials = table
        .records
        .iter()
        .zip(table.names)
        .map(|(r, name)| Material {
            name,
            diffuse: vec3_at(r, 0),
            shininess: f32_at(r, 12).unwrap_or_default(),
            specular: vec3_at(r, 16),
            ior: f32_at(r, 28).unwrap_or_default(),
            mirror: vec3_at(r, 32),
            transmission: vec3_at(r, 48),
        })
        .collect();
    Ok(Materials {
        materials,
        element_material: bytes::u32s(table.block),
    })
}

/// The invariants of [`Materials`]; messages name the material (index and name) or the element.
pub(crate) fn check(f: &OperatorFile, m: &Materials) -> Result<(), FormatError> {
    let fail = |m: String| Err(FormatError::invalid(format!("section MATERIALS: {m}")));
    let count = m.materials.len();
    if count == 0 {
        return fail("no materials: at least one is needed".into());
    }
    if m.element_material.len() != f.n as usize {
        return fail(format!(
            "expected n = {} element materials, found {}",
            f.n,
            m.element_material.len()
        ));
    }
    if let Some(e) = m.element_material.iter().position(|&i| i as usize >= count) {
        return fail(format!(
            "element {e} (file position): material {} is not below the {count} materials",
            m.element_material[e]
        ));
    }
    for (i, material) in m.materials.iter().enumerate() {
        check_material(material)
            .or_else(|problem| fail(format!("material {i} {:?}: {problem}", material.name)))?;
    }
    Ok(())
}

impl Material {
    /// Checks this material's invariants: an `Invalid` error naming the material and the field.
    /// For writers that want to refuse a bad material before they build a file.
    pub fn check(&self) -> Result<(), FormatError> {
        check_material(self)
            .map_err(|problem| FormatError::invalid(format!("material {:?}: {problem}", self.name)))
    }
}

fn check_material(m: &Material) -> Result<(), String> {
    let unit = |v: f32| (0.0..=1.0).contains(&v);
    let colours = [
        ("diffuse", m.diffuse),
        ("specular", m.specular),
        ("mirror", m.mirror),
        ("transmission", m.transmission),
    ];
    for (field, colour) in colours {
        if let Some(c) = colour.iter().position(|&v| !unit(v)) {
            return Err(format!(
                "{field} channel {}: value {} must be finite and in [0, 1]",
                ["r", "g", "b"][c],
                colour[c]
            ));
        }
    }
    if !(m.shininess.is_finite() && m.shininess >= 0.0) {
        return Err(format!("shininess {} must be finite and >= 0", m.shininess));
    }
    if !(m.ior.is_finite() && m.ior >= 1.0) {
        return Err(format!("ior {} must be finite and >= 1", m.ior));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bytes::u32_at;
    use crate::testdata::display_sample;

    #[test]
    fn encoding_is_as_documented() {
        let f = display_sample();
        let m = f.display.materials.as_ref().unwrap();
        let bytes = encode(m);
        let names: usize = m.materials.iter().map(|m| m.name.len()).sum();
        assert_eq!(bytes.len(), 8 + 64 * 2 + 4 * 6 + names);
        assert_eq!(u32_at(&bytes, 0), Some(2));
        // Material 1 ("glass"): ior at 28, name length at 44, transmission at 48.
        assert_eq!(f32_at(&bytes, 8 + 64 + 28), Some(1.5));
        assert_eq!(u32_at(&bytes, 8 + 64 + 44), Some(5));
        assert_eq!(vec3_at(&bytes, 8 + 64 + 48), m.materials[1].transmission);
        assert_eq!(u32_at(&bytes, 8 + 128 + 8), Some(m.element_material[2]));
        assert!(bytes.ends_with(b"whiteglass"));
        assert_eq!(&decode(&bytes, 6).unwrap(), m);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let f = display_sample();
        let good = encode(f.display.materials.as_ref().unwrap());
        for len in 0..good.len() {
            assert!(decode(&good[..len], 6).is_err(), "prefix {len}");
        }
        assert!(decode(&good, 7).is_err());
        assert!(decode(&good, usize::MAX).is_err());
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge, 6).is_err());
    }

    #[test]
    fn invariants_name_material_and_field() {
        type Edit = fn(&mut Materials);
        let cases: [(Edit, &str); 9] = [
            (|m| m.materials.clear(), "no materials"),
            (
                |m| m.element_material.pop().map(drop).unwrap(),
                "expected n = 6 element materials",
            ),
            (
                |m| m.element_material[3] = 2,
                "element 3 (file position): material 2 is not below the 2 materials",
            ),
            (
                |m| m.materials[1].diffuse[1] = 1.5,
                "material 1 \"glass\": diffuse channel g: value 1.5",
            ),
            (
                |m| m.materials[0].specular[0] = -0.1,
                "material 0 \"white\": specular channel r: value -0.1",
            ),
            (
                |m| m.materials[1].mirror[2] = f32::NAN,
                "material 1 \"glass\": mirror channel b: value NaN",
            ),
            (
                |m| m.materials[1].transmission[0] = 2.0,
                "material 1 \"glass\": transmission channel r: value 2",
            ),
            (
                |m| m.materials[0].shininess = -1.0,
                "material 0 \"white\": shininess -1 must be finite and >= 0",
            ),
            (
                |m| m.materials[1].ior = 0.9,
                "material 1 \"glass\": ior 0.9 must be finite and >= 1",
            ),
        ];
        for (edit, expected) in cases {
            let mut f = display_sample();
            edit(f.display.materials.as_mut().unwrap());
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with("section MATERIALS: "),
                "{e} (expected {expected:?})"
            );
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
        }
    }
}
