//! Section CAMERAS (format 1.2): pinhole cameras; byte encoding (tabled in the crate docs),
//! decoding and invariants.

use crate::bytes::{f32_at, vec3_at};
use crate::display::Camera;
use crate::error::FormatError;
use crate::kind;
use crate::records::{self, Shape};

/// The records' shape: eye, fov_y_deg; target, name length; up, reserved.
const SHAPE: Shape = Shape {
    kind: kind::CAMERAS,
    what: "camera",
    record_len: 48,
    name_at: 28,
};

/// How close to parallel `up` and the view direction may be: the sine of the angle between
/// them must exceed this.
pub(crate) const MIN_UP_SINE: f64 = 1e-6;

/// Encodes `cameras` (validated); the caller leaves the section out when there are none.
pub(crate) fn encode(cameras: &[Camera]) -> Vec<u8> {
    let mut out = Vec::new();
    records::put_head(&mut out, cameras.len());
    for c in cameras {
        records::put_row_f(&mut out, c.eye, c.fov_y_deg);
        records::put_row(&mut out, c.target, c.name.len() as u32);
        records::put_row(&mut out, c.up, 0);
    }
    records::put_names(&mut out, cameras.iter().map(|c| c.name.as_str()));
    out
}

/// Decodes the payload; lengths and UTF-8 are checked, values are not.
pub(crate) fn decode(payload: &[u8]) -> Result<Vec<Camera>, FormatError> {
    let table = SHAPE.decode(payload, Some(0))?;
    Ok(table
        .records
        .iter()
        .zip(table.names)
        .map(|(r, name)| Camera {
            name,
            eye: vec3_at(r, 0),
            fov_y_deg: f32_at(r, 12).unwrap_or_default(),
            target: vec3_at(r, 16),
            up: vec3_at(r, 32),
        })
        .collect())
}

/// The invariants of [`Camera`]; messages name the camera (index and name).
pub(crate) fn check(cameras: &[Camera]) -> Result<(), FormatError> {
    let mut names: Vec<(&str, usize)> = cameras
        .iter()
        .enumerate()
        .map(|(i, c)| (c.name.as_str(), i))
        .collect();
    names.sort_unstable();
    if let Some(w) = names.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(FormatError::invalid(format!(
            "section CAMERAS: cameras {} and {} are both named {:?}: names must be unique",
            w[0].1, w[1].1, w[0].0
        )));
    }
    for (i, camera) in cameras.iter().enumerate() {
        check_camera(camera).map_err(|problem| {
            FormatError::invalid(format!(
                "section CAMERAS: camera {i} {:?}: {problem}",
                camera.name
            ))
        })?;
    }
    Ok(())
}

impl Camera {
    /// Checks this camera's invariants alone (all but the unique name): an `Invalid` error
    /// naming the camera and the field. For writers that want to refuse a bad camera before
    /// they build a file.
    pub fn check(&self) -> Result<(), FormatError> {
        check_camera(self)
            .map_err(|problem| FormatError::invalid(format!("camera {:?}: {problem}", self.name)))
    }
}

fn check_camera(c: &Camera) -> Result<(), String> {
    for (field, v) in [("eye", c.eye), ("target", c.target), ("up", c.up)] {
        if let Some(j) = v.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "{field} coordinate {j}: value {} must be finite",
                v[j]
            ));
        }
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(format!(
            "fov_y_deg {} must be in (0, 180) degrees",
            c.fov_y_deg
        ));
    }
    let d: [f64; 3] = std::array::from_fn(|j| f64::from(c.target[j]) - f64::from(c.eye[j]));
    let up = c.up.map(f64::from);
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if norm(d) == 0.0 {
        return Err(format!(
            "target {:?} is the eye: the camera looks nowhere",
            c.target
        ));
    }
    let cross = [
        d[1] * up[2] - d[2] * up[1],
        d[2] * up[0] - d[0] * up[2],
        d[0] * up[1] - d[1] * up[0],
    ];
    if norm(cross) <= MIN_UP_SINE * norm(d) * norm(up) {
        return Err(format!(
            "up {:?} is zero or parallel to the view direction target - eye = {d:?}",
            c.up
        ));
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
        let cameras = &f.display.cameras;
        let bytes = encode(cameras);
        assert_eq!(bytes.len(), 8 + 48 * 2 + "fronttop".len());
        assert_eq!(f32_at(&bytes, 8 + 12), Some(cameras[0].fov_y_deg));
        assert_eq!(u32_at(&bytes, 8 + 28), Some(5));
        assert_eq!(vec3_at(&bytes, 8 + 48 + 32), cameras[1].up);
        assert!(bytes.ends_with(b"fronttop"));
        assert_eq!(&decode(&bytes).unwrap(), cameras);
    }

    #[test]
    fn hostile_payloads_are_refused() {
        let f = display_sample();
        let good = encode(&f.display.cameras);
        for len in 0..good.len() {
            assert!(decode(&good[..len]).is_err(), "prefix {len}");
        }
        let mut long_name = good.clone();
        long_name[8 + 28..8 + 32].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&long_name).is_err());
    }

    #[test]
    fn invariants_name_camera_and_field() {
        type Edit = fn(&mut Vec<Camera>);
        let cases: [(Edit, &str); 7] = [
            (
                |c| c[1].name = "front".into(),
                "cameras 0 and 1 are both named \"front\"",
            ),
            (
                |c| c[0].eye[1] = f32::NAN,
                "camera 0 \"front\": eye coordinate 1: value NaN",
            ),
            (
                |c| c[1].fov_y_deg = 180.0,
                "camera 1 \"top\": fov_y_deg 180",
            ),
            (|c| c[1].fov_y_deg = 0.0, "camera 1 \"top\": fov_y_deg 0"),
            (|c| c[0].target = c[0].eye, "camera 0 \"front\": target"),
            (
                |c| c[0].up = [0.0, 0.0, -2.0],
                "camera 0 \"front\": up [0.0, 0.0, -2.0] is zero or parallel",
            ),
            (
                |c| c[1].up = [0.0; 3],
                "camera 1 \"top\": up [0.0, 0.0, 0.0]",
            ),
        ];
        for (edit, expected) in cases {
            let mut f = display_sample();
            edit(&mut f.display.cameras);
            let e = f.validate().unwrap_err();
            assert!(
                e.message.starts_with("section CAMERAS: "),
                "{e} (expected {expected:?})"
            );
            assert!(e.message.contains(expected), "{e} (expected {expected:?})");
        }
    }
}
