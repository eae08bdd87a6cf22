//! `Operator.render`: a frame ray traced by the runtime's CPU tracer into a numpy image.

use lrr_formats::Camera;
use lrr_runtime::trace::{Lighting, Tracer, View};
use lrr_runtime::{Operator, RuntimeError};

/// The camera: the file's camera `name` (default: its first), each field overridden by the
/// arguments given; with no camera in the file, `eye` and `target` are needed.
pub struct CameraArgs {
    pub name: Option<String>,
    pub eye: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    pub fov_y: Option<f32>,
}

impl CameraArgs {
    fn camera(&self, tracer: &Tracer) -> Result<Camera, RuntimeError> {
        let cameras = tracer.cameras();
        let base = match &self.name {
            Some(name) => Some(cameras.iter().find(|c| &c.name == name).ok_or_else(|| {
                let names: Vec<String> = cameras.iter().map(|c| format!("'{}'", c.name)).collect();
                RuntimeError::Input(format!(
                    "camera '{name}': the file has no such camera (it has: {})",
                    if names.is_empty() {
                        "none".into()
                    } else {
                        names.join(", ")
                    }
                ))
            })?),
            None => cameras.first(),
        };
        let eye = self.eye.or(base.map(|c| c.eye));
        let target = self.target.or(base.map(|c| c.target));
        let (Some(eye), Some(target)) = (eye, target) else {
            return Err(RuntimeError::Input(
                "the file has no camera: give eye=(x, y, z) and target=(x, y, z) (and up, fov_y)"
                    .into(),
            ));
        };
        Ok(Camera {
            name: base.map_or(String::new(), |c| c.name.clone()),
            eye,
            target,
            up: self.up.or(base.map(|c| c.up)).unwrap_or([0.0, 1.0, 0.0]),
            fov_y_deg: self.fov_y.or(base.map(|c| c.fov_y_deg)).unwrap_or(60.0),
        })
    }
}

/// What a render is asked for.
pub struct RenderArgs {
    pub width: u32,
    pub height: u32,
    pub camera: CameraArgs,
    pub smooth: bool,
    pub max_depth: u32,
    pub threads: usize,
}

/// Renders `radiosity` (n values) with point lights scaled by `groups`: `width * height`
/// pixels of linear radiance, rows from the top.
pub fn render(
    op: &Operator,
    radiosity: &[[f32; 3]],
    groups: &[f32],
    a: &RenderArgs,
) -> Result<Vec<[f32; 3]>, RuntimeError> {
    if a.width == 0 || a.height == 0 || u64::from(a.width) * u64::from(a.height) > 1 << 28 {
        return Err(RuntimeError::Input(format!(
            "image size {}x{}: need 1 to 2^28 pixels",
            a.width, a.height
        )));
    }
    let mut tracer = Tracer::new(op.file())?;
    tracer.set_max_depth(a.max_depth)?;
    tracer.set_smooth(a.smooth)?;
    let cam = a.camera.camera(&tracer)?;
    let view = View::new(&cam, a.width, a.height)?;
    let lighting = Lighting {
        radiosity,
        group_intensities: groups,
    };
    let (image, _) = tracer.render(&view, &lighting, a.width, a.height, a.threads)?;
    Ok(image.pixels)
}
