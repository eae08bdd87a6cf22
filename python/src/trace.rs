//! `Operator.render`: a frame ray traced by the runtime's CPU tracer into a numpy image.

use lrr_formats::Camera;
use lrr_runtime::trace::{CameraChoiceError, CameraFields, Lighting, Tracer, View};
use lrr_runtime::{Operator, RuntimeError};

/// The camera: the file's camera `fields.name` (default: its first), each field overridden by
/// the arguments given; with no camera in the file, `eye` and `target` are needed.
fn camera(fields: &CameraFields, tracer: &Tracer) -> Result<Camera, RuntimeError> {
    fields.choose(tracer.cameras()).map_err(|e| {
        RuntimeError::Input(match e {
            CameraChoiceError::NoSuchCamera { name, available } => {
                format!("camera '{name}': the file has no such camera (it has: {available})")
            }
            CameraChoiceError::NoCamera => "the file has no camera: give eye=(x, y, z) and \
                                            target=(x, y, z) (and up, fov_y)"
                .into(),
        })
    })
}

/// What a render is asked for.
pub struct RenderArgs {
    pub width: u32,
    pub height: u32,
    pub camera: CameraFields,
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
    let cam = camera(&a.camera, &tracer)?;
    let view = View::new(&cam, a.width, a.height)?;
    let lighting = Lighting {
        radiosity,
        group_intensities: groups,
        direct: None,
    };
    let (image, _) = tracer.render(&view, &lighting, a.width, a.height, a.threads)?;
    Ok(image.pixels)
}
