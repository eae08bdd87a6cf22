//! Section DIRECT_LIGHTS (format 1.5): spot and directional lights and the sky, the lights that
//! are not surfaces besides POINT_LIGHTS; byte encoding (tabled in the crate docs), decoding and
//! invariants.

use crate::bytes::{u32_at, vec3_at};
use crate::display::{DirectLight, DirectLightKind};
use crate::error::FormatError;
use crate::kind;
use crate::records::{self, Shape};

/// The records' shape: position, kind; direction, name length; strength, reserved; extra,
/// reserved.
const SHAPE: Shape = Shape {
    kind: kind::DIRECT_LIGHTS,
    what: "light",
    record_len: 64,
    name_at: 28,
};

/// Encodes `lights` (validated); the caller leaves the section out when there are none.
pub(crate) fn encode(lights: &[DirectLight]) -> Vec<u8> {
    let mut out = Vec::new();
    records::put_head(&mut out, lights.len());
    for light in lights {
        records::put_row(&mut out, light.position, light.kind.code());
        records::put_row(&mut out, light.direction, light.name.len() as u32);
        records::put_row(&mut out, light.strength, 0);
        records::put_row(&mut out, light.extra, 0);
    }
    records::put_names(&mut out, lights.iter().map(|l| l.name.as_str()));
    out
}

/// Decodes the payload; lengths, UTF-8 and kind codes are checked, values are not.
pub(crate) fn decode(payload: &[u8]) -> Result<Vec<DirectLight>, FormatError> {
    let table = SHAPE.decode(payload, Some(0))?;
    table
        .records
        .iter()
        .zip(table.names)
        .enumerate()
        .map(|(i, (r, name))| {
            if u32_at(r, 44) != Some(0) || u32_at(r, 60) != Some(0) {
                return Err(FormatError::corrupt(format!(
                    "section DIRECT_LIGHTS: light {i} {name:?}: its reserved words (bytes 44 and \
                     60 of the record) are not zero"
                )));
            }
            let code = u32_at(r, 12).unwrap_or_default();
            let kind = DirectLightKind::from_code(code).ok_or_else(|| {
                FormatError::corrupt(format!(
                    "section DIRECT_LIGHTS: light {i} {name:?}: kind code {code} is none of \
                     0 (spot), 1 (directional), 2 (uniform sky), 3 (gradient sky)"
                ))
            })?;
            Ok(DirectLight {
                name,
                kind,
                position: vec3_at(r, 0),
                direction: vec3_at(r, 16),
                strength: vec3_at(r, 32),
                extra: vec3_at(r, 48),
            })
        })
        .collect()
}

/// The invariants of [`DirectLight`]s; messages name the light (index and name).
pub(crate) fn check(lights: &[DirectLight]) -> Result<(), FormatError> {
    for (i, light) in lights.iter().enumerate() {
        light.check_values().map_err(|e| {
            FormatError::invalid(format!("section DIRECT_LIGHTS: light {i}: {}", e.message))
        })?;
    }
    let skies = lights.iter().filter(|l| l.kind.is_sky()).count();
    if skies > 1 {
        return Err(FormatError::invalid(format!(
            "section DIRECT_LIGHTS: {skies} skies; a scene has at most one"
        )));
    }
    Ok(())
}

impl DirectLight {
    /// Checks this light's values for its kind: an `Invalid` error naming the light and the
    /// field. For writers that want to refuse a bad light before they build a file.
    pub fn check_values(&self) -> Result<(), FormatError> {
        check_values(self)
            .map_err(|problem| FormatError::invalid(format!("{:?}: {problem}", self.name)))
    }
}

fn check_values(l: &DirectLight) -> Result<(), String> {
    let finite = |what: &str, v: [f32; 3]| match v.iter().position(|c| !c.is_finite()) {
        Some(c) => Err(format!(
            "{what} coordinate {c}: value {} must be finite",
            v[c]
        )),
        None => Ok(()),
    };
    let radiometric =
        |what: &str, v: [f32; 3]| match v.iter().position(|&c| !(c.is_finite() && c >= 0.0)) {
            Some(c) => Err(format!(
                "{what} channel {}: value {} must be finite and >= 0",
                ["r", "g", "b"][c],
                v[c]
            )),
            None => Ok(()),
        };
    // A direction is normalised by its readers: its f32 length must be finite and above zero
    // (`[1e-30, 0, 0]` underflows to length 0, `[3e38, 3e38, 0]` overflows).
    let direction = |what: &str, v: [f32; 3]| {
        finite(what, v)?;
        let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if !(l2.is_finite() && l2 > 0.0) {
            return Err(format!(
                "{what} {v:?} has no usable length in f32; it must point somewhere"
            ));
        }
        Ok(())
    };
    let zero = |what: &str, v: [f32; 3]| {
        if v != [0.0; 3] {
            return Err(format!("{what} {v:?} must be zero for this kind"));
        }
        Ok(())
    };
    match l.kind {
        DirectLightKind::Spot => {
            finite("position", l.position)?;
            direction("direction", l.direction)?;
            radiometric("intensity", l.strength)?;
            let [inner, outer, rest] = l.extra;
            let ok = inner.is_finite()
                && outer.is_finite()
                && inner >= 0.0
                && inner <= outer
                && outer <= std::f32::consts::FRAC_PI_2
                && rest == 0.0;
            if !ok {
                return Err(format!(
                    "cone angles [inner, outer, 0] = {:?} radians must satisfy \
                     0 <= inner <= outer <= pi/2",
                    l.extra
                ));
            }
            Ok(())
        }
        DirectLightKind::Directional => {
            zero("position", l.position)?;
            direction("direction", l.direction)?;
            radiometric("irradiance", l.strength)?;
            zero("extra", l.extra)
        }
        DirectLightKind::UniformSky => {
            zero("position", l.position)?;
            zero("direction", l.direction)?;
            radiometric("radiance", l.strength)?;
            zero("extra", l.extra)
        }
        DirectLightKind::GradientSky => {
            zero("position", l.position)?;
            direction("up direction", l.direction)?;
            radiometric("zenith radiance", l.strength)?;
            radiometric("horizon radiance", l.extra)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bytes::f32_at;

    fn sample() -> Vec<DirectLight> {
        vec![
            DirectLight {
                name: "spot".into(),
                kind: DirectLightKind::Spot,
                position: [1.0, 2.0, 3.0],
                direction: [0.0, -1.0, 0.0],
                strength: [5.0, 4.0, 3.0],
                extra: [0.2, 0.5, 0.0],
            },
            DirectLight {
                name: "sun".into(),
                kind: DirectLightKind::Directional,
                position: [0.0; 3],
                direction: [0.3, -1.0, 0.2],
                strength: [2.0; 3],
                extra: [0.0; 3],
            },
            DirectLight {
                name: String::new(),
                kind: DirectLightKind::GradientSky,
                position: [0.0; 3],
                direction: [0.0, 1.0, 0.0],
                strength: [1.0, 1.0, 2.0],
                extra: [0.2; 3],
            },
        ]
    }

    #[test]
    fn encoding_is_as_documented() {
        let lights = sample();
        let bytes = encode(&lights);
        assert_eq!(bytes.len(), 8 + 64 * 3 + "spotsun".len());
        assert_eq!(u32_at(&bytes, 8 + 12), Some(0));
        assert_eq!(u32_at(&bytes, 8 + 64 + 12), Some(1));
        assert_eq!(u32_at(&bytes, 8 + 128 + 12), Some(3));
        assert_eq!(u32_at(&bytes, 8 + 28), Some(4));
        assert_eq!(f32_at(&bytes, 8 + 32), Some(5.0));
        assert_eq!(f32_at(&bytes, 8 + 52), Some(0.5));
        assert!(bytes.ends_with(b"spotsun"));
        assert_eq!(decode(&bytes).unwrap(), lights);
        assert_eq!(decode(&encode(&[])).unwrap(), vec![]);
        check(&lights).unwrap();
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let good = encode(&sample());
        for len in 0..good.len() {
            assert!(decode(&good[..len]).is_err(), "prefix {len}");
        }
        let mut huge = good.clone();
        huge[..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&huge).is_err());
        let mut kind = good.clone();
        kind[8 + 12..8 + 16].copy_from_slice(&7u32.to_le_bytes());
        let e = decode(&kind).unwrap_err().to_string();
        assert!(e.contains("kind code 7"), "{e}");
    }

    #[test]
    fn invariants_name_light_and_field() {
        type Edit = fn(&mut Vec<DirectLight>);
        let cases: [(Edit, &str); 8] = [
            (
                |l| l[0].position[1] = f32::NAN,
                "light 0: \"spot\": position",
            ),
            (|l| l[0].direction = [0.0; 3], "no usable length"),
            (|l| l[1].direction = [1e-30, 0.0, 0.0], "no usable length"),
            (|l| l[0].extra = [0.6, 0.5, 0.0], "cone angles"),
            (|l| l[0].strength[2] = -1.0, "intensity channel b"),
            (|l| l[1].position = [1.0; 3], "light 1: \"sun\": position"),
            (
                |l| l[2].extra[0] = f32::INFINITY,
                "horizon radiance channel r",
            ),
            (
                |l| {
                    let sky = l[2].clone();
                    l.push(sky);
                },
                "2 skies",
            ),
        ];
        for (edit, needle) in cases {
            let mut lights = sample();
            edit(&mut lights);
            let e = check(&lights).unwrap_err().to_string();
            assert!(e.contains(needle), "{needle}: {e}");
        }
    }
}
