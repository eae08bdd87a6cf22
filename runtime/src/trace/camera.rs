//! The pinhole camera: eye, target, up and the vertical field of view in degrees (the file's
//! [`Camera`] or the caller's), one ray through the centre of each pixel.

use lrr_formats::Camera;

use crate::error::{RuntimeError, input};
use crate::rays::{V3, cross, dot, length, mad, normalize, scale, sub};

/// The fields of a camera to trace through, any of them given (`lrr render`'s flags, Python's
/// keyword arguments); [`CameraFields::choose`] fills the rest from a file's cameras.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CameraFields {
    /// The file's camera of this name (default: its first).
    pub name: Option<String>,
    /// Eye position (default: the camera's).
    pub eye: Option<[f32; 3]>,
    /// Point looked at (default: the camera's).
    pub target: Option<[f32; 3]>,
    /// Up direction (default: the camera's, else +y).
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees (default: the camera's, else 60).
    pub fov_y_deg: Option<f32>,
}

/// Why [`CameraFields::choose`] made no camera; each caller words it for its own arguments.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraChoiceError {
    /// The file has no camera of this name; `available` lists its names quoted, or "none".
    NoSuchCamera {
        /// The name asked for.
        name: String,
        /// The file's camera names, quoted, or "none".
        available: String,
    },
    /// The file has no camera, and the eye or the target was not given.
    NoCamera,
}

impl CameraFields {
    /// The camera of `cameras` named `name` (default: the first), each field replaced where
    /// given; without a camera in the file, `eye` and `target` are needed, `up` defaults to
    /// +y and the field of view to 60°.
    pub fn choose(&self, cameras: &[Camera]) -> Result<Camera, CameraChoiceError> {
        let base = match &self.name {
            Some(name) => Some(cameras.iter().find(|c| &c.name == name).ok_or_else(|| {
                let names: Vec<String> = cameras.iter().map(|c| format!("'{}'", c.name)).collect();
                CameraChoiceError::NoSuchCamera {
                    name: name.clone(),
                    available: if names.is_empty() {
                        "none".into()
                    } else {
                        names.join(", ")
                    },
                }
            })?),
            None => cameras.first(),
        };
        let eye = self.eye.or(base.map(|c| c.eye));
        let target = self.target.or(base.map(|c| c.target));
        let (Some(eye), Some(target)) = (eye, target) else {
            return Err(CameraChoiceError::NoCamera);
        };
        Ok(Camera {
            name: base.map_or(String::new(), |c| c.name.clone()),
            eye,
            target,
            up: self.up.or(base.map(|c| c.up)).unwrap_or([0.0, 1.0, 0.0]),
            fov_y_deg: self.fov_y_deg.or(base.map(|c| c.fov_y_deg)).unwrap_or(60.0),
        })
    }
}

/// A checked camera with its frame: `forward`, and `right` and `up` scaled by the half extents
/// of the image plane at distance 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    eye: V3,
    forward: V3,
    right: V3,
    up: V3,
}

impl View {
    /// The view of `camera` on an image of `width × height` pixels (square pixels); an error
    /// naming the fault when the camera is degenerate.
    pub fn new(camera: &Camera, width: u32, height: u32) -> Result<Self, RuntimeError> {
        let name = if camera.name.is_empty() {
            String::from("the camera")
        } else {
            format!("camera '{}'", camera.name)
        };
        let all = camera.eye.iter().chain(&camera.target).chain(&camera.up);
        if !all.clone().all(|c| c.is_finite()) {
            return Err(input(format!("{name}: eye, target and up must be finite")));
        }
        if !(camera.fov_y_deg > 0.0 && camera.fov_y_deg < 180.0) {
            return Err(input(format!(
                "{name}: the vertical field of view must lie in (0, 180) degrees, got {}",
                camera.fov_y_deg
            )));
        }
        if width == 0 || height == 0 {
            return Err(input(format!(
                "the image must have at least one pixel, got {width}x{height}"
            )));
        }
        let view = sub(camera.target, camera.eye);
        if length(view) == 0.0 {
            return Err(input(format!(
                "{name}: the target is the eye; look at another point"
            )));
        }
        let forward = normalize(view);
        let side = cross(forward, camera.up);
        if length(side) <= 1e-6 * length(camera.up) || length(camera.up) == 0.0 {
            return Err(input(format!(
                "{name}: the up direction {:?} is zero or parallel to the view direction; \
                 give one across it",
                camera.up
            )));
        }
        let right = normalize(side);
        let up = cross(right, forward);
        let half_h = (0.5 * camera.fov_y_deg.to_radians()).tan();
        let half_w = half_h * width as f32 / height as f32;
        debug_assert!(dot(up, forward).abs() < 1e-5);
        Ok(View {
            eye: camera.eye,
            forward,
            right: scale(right, half_w),
            up: scale(up, half_h),
        })
    }

    /// The eye.
    pub fn eye(&self) -> [f32; 3] {
        self.eye
    }

    /// The view's pyramid, to test triangles against ([`Pyramid::may_see`]); made once per
    /// frame, not per triangle.
    pub(crate) fn pyramid(&self) -> Pyramid {
        let (f, r, u) = (self.forward, self.right, self.up);
        // Inward normals of the sides from the orthogonal frame itself (`f` unit, `r` and `u`
        // the half extents): the side through `f ± r` (all `s`: `f ± r + s u`) has normal
        // `|r|² f ∓ r`, likewise for `u`; then the eye's plane. (Cross products of the corner
        // rays lose their precision at tiny fields of view.)
        let (rr, uu) = (dot(r, r), dot(u, u));
        let planes = [
            sub(scale(f, rr), r),
            mad(scale(f, rr), r, 1.0),
            sub(scale(f, uu), u),
            mad(scale(f, uu), u, 1.0),
            f,
        ];
        Pyramid {
            eye: self.eye,
            sides: planes.map(|n| (n, 1e-4 * length(n))),
        }
    }

    /// The unit direction through pixel `(x, y)`'s centre (`y = 0` the top row).
    #[inline]
    pub(crate) fn direction(&self, x: u32, y: u32, width: u32, height: u32) -> V3 {
        let u = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
        let v = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
        normalize(mad(mad(self.forward, self.right, u), self.up, v))
    }
}

/// A view's pyramid: its four sides through the eye and the plane of the eye itself, as inward
/// normals with a rounding margin (1e-4 of each normal's length).
pub(crate) struct Pyramid {
    eye: V3,
    sides: [(V3, f32); 5],
}

impl Pyramid {
    /// Whether a camera ray may hit the triangle `t` (v0, v1, v2): false only when all three
    /// corners lie outside one side of the pyramid, by the margin times their distance, so a
    /// triangle any camera ray hits is never called unseen.
    pub(crate) fn may_see(&self, t: &[f32; 9]) -> bool {
        let rel = |k: usize| sub([t[3 * k], t[3 * k + 1], t[3 * k + 2]], self.eye);
        let points = [rel(0), rel(1), rel(2)];
        !self
            .sides
            .iter()
            .any(|&(n, margin)| points.iter().all(|p| dot(n, *p) < -margin * length(*p)))
    }
}

// For the GPU twin (runtime/src/gpu/trace.rs): the frame its shader builds rays from.
#[cfg(feature = "gpu")]
impl View {
    /// `[eye, forward, right, up]` (right and up scaled by the image plane's half extents).
    pub(crate) fn frame(&self) -> [V3; 4] {
        [self.eye, self.forward, self.right, self.up]
    }
}

#[cfg(test)]
mod tests {
    use lrr_formats::Camera;

    use super::{CameraChoiceError, CameraFields, View};
    use crate::rays::{mad, scale, sub};

    /// A triangle a camera ray through a pixel centre hits is never called unseen, at fields
    /// of view from 1e-4° to 170°, near and far, whatever the scale; one wholly beside the
    /// view or behind the eye is.
    #[test]
    fn may_see_keeps_every_triangle_a_camera_ray_hits() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unit = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (w, h) = (1920, 1080);
        for fov in [
            1e-4f32, 1e-3, 0.007, 0.015, 0.1, 1.0, 20.0, 60.0, 120.0, 170.0,
        ] {
            for case in 0..300 {
                let s = 10f32.powf(6.0 * unit() - 3.0);
                let cam = Camera {
                    name: String::new(),
                    eye: [unit() * s, unit() * s, unit() * s],
                    target: [(unit() - 0.5) * s, (unit() - 0.5) * s, 2.0 * s],
                    up: [unit() - 0.5, 1.0, unit() - 0.5],
                    fov_y_deg: fov,
                };
                let view = View::new(&cam, w, h).unwrap();
                let (x, y) = ((unit() * w as f32) as u32, (unit() * h as f32) as u32);
                let d = view.direction(x.min(w - 1), y.min(h - 1), w, h);
                let dist = s * 10f32.powf(3.0 * unit() - 1.0);
                let p = mad(cam.eye, d, dist);
                // A small triangle around the hit point, across the ray.
                let e = 1e-3 * dist;
                let t = [
                    p[0] - e,
                    p[1],
                    p[2],
                    p[0] + e,
                    p[1] + e,
                    p[2],
                    p[0],
                    p[1] - e,
                    p[2] + e,
                ];
                assert!(
                    view.pyramid().may_see(&t),
                    "fov {fov} case {case}: a hit triangle culled"
                );
                // Behind the eye (the point mirrored through it) and far beside the view.
                let q = sub(cam.eye, sub(p, cam.eye));
                let t = [q[0], q[1], q[2], q[0] + e, q[1], q[2], q[0], q[1] + e, q[2]];
                assert!(
                    !view.pyramid().may_see(&t),
                    "fov {fov} case {case}: behind the eye kept"
                );
                if fov <= 60.0 {
                    let side = mad(p, scale(view.right, 1.0 / fov.to_radians()), 4.0 * dist);
                    let t = [
                        side[0],
                        side[1],
                        side[2],
                        side[0] + e,
                        side[1],
                        side[2],
                        side[0],
                        side[1] + e,
                        side[2],
                    ];
                    assert!(
                        !view.pyramid().may_see(&t),
                        "fov {fov} case {case}: beside the view kept"
                    );
                }
            }
        }
    }

    /// Fields given replace the named camera's; a missing name lists the file's; no camera
    /// at all needs an eye and a target, and then up and the field of view default.
    #[test]
    fn fields_choose_a_camera_from_the_file() {
        let cam = |name: &str, x: f32| Camera {
            name: name.into(),
            eye: [x, 0.0, 0.0],
            target: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            fov_y_deg: 40.0,
        };
        let cameras = [cam("a", 1.0), cam("b", 2.0)];
        let fields = CameraFields {
            name: Some("b".into()),
            fov_y_deg: Some(30.0),
            ..CameraFields::default()
        };
        let chosen = fields.choose(&cameras).unwrap();
        assert_eq!(
            (chosen.eye[0], chosen.fov_y_deg, chosen.up),
            (2.0, 30.0, [0.0, 0.0, 1.0])
        );
        assert_eq!(CameraFields::default().choose(&cameras).unwrap().name, "a");
        let missing = CameraFields {
            name: Some("c".into()),
            ..CameraFields::default()
        };
        assert_eq!(
            missing.choose(&cameras),
            Err(CameraChoiceError::NoSuchCamera {
                name: "c".into(),
                available: "'a', 'b'".into()
            })
        );
        assert_eq!(
            CameraFields::default().choose(&[]),
            Err(CameraChoiceError::NoCamera)
        );
        let given = CameraFields {
            eye: Some([0.0, 0.0, 5.0]),
            target: Some([0.0; 3]),
            ..CameraFields::default()
        };
        let c = given.choose(&[]).unwrap();
        assert_eq!(
            (c.up, c.fov_y_deg, c.name.as_str()),
            ([0.0, 1.0, 0.0], 60.0, "")
        );
    }
}
