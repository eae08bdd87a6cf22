//! Section POINT_LIGHTS (format 1.2): point lights for highlights and shadow rays; byte encoding
//! (tabled in the crate docs), decoding and invariants.

use crate::bytes::{u32_at, vec3_at};
use crate::display::PointLight;
use crate::error::FormatError;
use crate::file::OperatorFile;
use crate::kind;
use crate::records::{self, Shape};

/// The records' shape: position, group; intensity, name length.
const SHAPE: Shape = Shape {
    kind: kind::POINT_LIGHTS,
    what: "point light",
    record_len: 32,
    name_at: 28,
};

/// Encodes `lights` (validated); the caller leaves the section out when there are none.
pub(crate) fn encode(lights: &[PointLight]) -> Vec<u8> {
    let mut out = Vec::new();
    records::put_head(&mut out, lights.len());
    for light in lights {
        records::put_row(&mut out, light.position, light.group);
        records::put_row(&mut out, light.intensity, light.name.len() as u32);
    }
    records::put_names(&mut out, lights.iter().map(|l| l.name.as_str()));
    out
}

/// Decodes the payload; lengths and UTF-8 are checked, values are not.
pub(crate) fn decode(payload: &[u8]) -> Result<Vec<PointLight>, FormatError> {
    let table = SHAPE.decode(payload, Some(0))?;
    Ok(table
        .records
        .iter()
        .zip(table.names)
        .map(|(r, name)| PointLight {
            name,
            position: vec3_at(r, 0),
            group: u32_at(r, 12).unwrap_or_default(),
            intensity: vec3_at(r, 16),
        })
        .collect())
}

/// The invariants of [`PointLight`]; messages name the light (index and name).
pub(crate) fn check(f: &OperatorFile, lights: &[PointLight]) -> Result<(), FormatError> {
    for (i, light) in lights.iter().enumerate() {
        check_light(f, light).map_err(|problem| {
            FormatError::invalid(format!(
                "section POINT_LIGHTS: point light {i} {:?}: {problem}",
                light.name
            ))
        })?;
    }
    Ok(())
}

impl PointLight {
    /// Checks this light's position and intensity (its group needs the file): an `Invalid`
    /// error naming the light and the field. For writers that want to refuse a bad light before
    /// they build a file.
    pub fn check_values(&self) -> Result<(), FormatError> {
        check_values(self).map_err(|problem| {
            FormatError::invalid(format!("point light {:?}: {problem}", self.name))
        })
    }
}

fn check_light(f: &OperatorFile, light: &PointLight) -> Result<(), String> {
    check_values(light)?;
    if light.group != PointLight::FIXED && light.group as usize >= f.lights.len() {
        return Err(format!(
            "group {} names no light group (the file has {}; {} for a light that follows none)",
            light.group,
            f.lights.len(),
            PointLight::FIXED
        ));
    }
    Ok(())
}

fn check_values(light: &PointLight) -> Result<(), String> {
    if let Some(c) = light.position.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "position coordinate {c}: value {} must be finite",
            light.position[c]
        ));
    }
    if let Some(c) = light
        .intensity
        .iter()
        .position(|&v| !(v.is_finite() && v >= 0.0))
    {
        return Err(format!(
            "intensity channel {}: value {} must be finite and >= 0",
            ["r", "g", "b"][c],
            light.intensity[c]
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bytes::f32_at;
    use crate::testdata::display_sample;

    #[test]
    fn encoding_is_as_documented() {
        let f = display_sample();
        let lights = &f.display.point_lights;
        let bytes = encode(lights);
        assert_eq!(bytes.len(), 8 + 32 * 2 + "keyfill".len());
        assert_eq!(u32_at(&bytes, 8 + 12), Some(0));
        assert_eq!(u32_at(&bytes, 8 + 32 + 12), Some(PointLight::FIXED));
        assert_eq!(f32_at(&bytes, 8 + 16), Some(lights[0].intensity[0]));
        assert_eq!(u32_at(&bytes, 8 + 28), Some(3));
        assert!(bytes.ends_with(b"keyfill"));
        assert_eq!(&decode(&bytes).unwrap(), lights);
        assert_eq!(decode(&encode(&[])).unwrap(), vec![]);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let f = display_sample();
        let good = encode(&f.display.point_lights);
        for len in 0..good.len() {
            assert!(decode(&good[..len]).is_err(), "prefix {len}");
        }
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge).is_err());
    }

    #[test]
    fn invariants_name_light_and_field() {
        type Edit = fn(&mut Vec<PointLight>);
        let cases: [(Edit, &str); 4] = [
            (
                |l| l[1].position[2] = f32::INFINITY,
                "point light 1 \"fill\": position coordinate 2: value inf must be finite",
            ),
            (
                |l| l[0].intensity[1] = -1.0,
                "point light 0 \"key\": intensity channel g: value -1",
            ),
            (
                |l| l[0].group = 1,
                "point light 0 \"key\": group 1 names no light group (the file has 1;",
            ),
            (|l| l[1].group = 7, "point light 1 \"fill\": group 7"),
        ];
        for (edit, expected) in cases {
            let mut f = display_sample();
            edit(&mut f.display.point_lights);
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with("section POINT_LIGHTS: "),
                "{e} (expected {expected:?})"
            );
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
        }
    }
}
