//! The pinhole camera: eye, target, up and the vertical field of view in degrees (the file's
//! [`Camera`] or the caller's), one ray through the centre of each pixel.

use lrr_formats::Camera;

use super::math::{V3, cross, dot, length, mad, normalize, scale, sub};
use crate::error::{RuntimeError, input};

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

    /// Whether a camera ray may hit the triangle `t` (v0, v1, v2): false only when all three
    /// corners lie outside one side of the view's pyramid (its four sides through the eye and
    /// the plane of the eye itself), with a margin of 1e-4 of their distance for rounding, so
    /// a triangle any camera ray hits is never called unseen.
    pub(crate) fn may_see(&self, t: &[f32; 9]) -> bool {
        let (f, r, u) = (self.forward, self.right, self.up);
        // The pyramid's edges through the image plane's corners, in turn around it.
        let corners = [
            sub(sub(f, r), u),
            sub(mad(f, r, 1.0), u),
            mad(mad(f, r, 1.0), u, 1.0),
            mad(sub(f, r), u, 1.0),
        ];
        let mut planes = [f; 5];
        for i in 0..4 {
            let n = cross(corners[i], corners[(i + 1) % 4]);
            planes[i] = if dot(n, f) < 0.0 { scale(n, -1.0) } else { n };
        }
        let rel = |k: usize| sub([t[3 * k], t[3 * k + 1], t[3 * k + 2]], self.eye);
        let points = [rel(0), rel(1), rel(2)];
        !planes.iter().any(|n| {
            let margin = 1e-4 * length(*n);
            points.iter().all(|p| dot(*n, *p) < -margin * length(*p))
        })
    }

    /// The unit direction through pixel `(x, y)`'s centre (`y = 0` the top row).
    #[inline]
    pub(crate) fn direction(&self, x: u32, y: u32, width: u32, height: u32) -> V3 {
        let u = 2.0 * (x as f32 + 0.5) / width as f32 - 1.0;
        let v = 1.0 - 2.0 * (y as f32 + 0.5) / height as f32;
        normalize(mad(mad(self.forward, self.right, u), self.up, v))
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
