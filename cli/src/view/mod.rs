//! `lrr view FILE.lrr`: the relit scene in a window, drawn the way an engine would use lrr. Every
//! frame the GPU evaluator relights the file from the light groups' intensities, the runtime's
//! GPU lightmap fill (`GpuLightmap`) writes the lightmap texture from that radiosity (no
//! readback), and the display triangles are rasterised sampling it ([`scene`]). A side panel
//! (egui) has a slider per light group, the exposure, the file's cameras and the frame's
//! timings; the mouse orbits (left drag), pans (right drag) and zooms (wheel), WASD/QE fly, F12
//! (or the button) writes a screenshot ([`window`]).
//!
//! `--headless` draws `--frames` frames offscreen (no window, no display) and writes the last to
//! `--screenshot`: what tests and CI run. A PNG is 8-bit sRGB at the exposure; an EXR holds the
//! linear radiance `B/π` the lightmap gives each pixel, comparable with `lrr render -o X.exr`.

mod scene;
mod viewer;
mod window;

use std::io::Write;
use std::time::Instant;

use anyhow::{Result, bail};
use lrr_runtime::Operator;
use lrr_runtime::gpu::{Gpu, GpuOptions, wgpu};

pub use viewer::ViewArgs;
use viewer::{Viewer, no_gpu, screenshot_format};

pub fn run(a: &ViewArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(path) = &a.screenshot {
        screenshot_format(path)?;
    }
    if a.size.0 == 0 || a.size.1 == 0 || a.size.0 > 16384 || a.size.1 > 16384 {
        bail!("--size {}x{}: 1 to 16384 pixels a side", a.size.0, a.size.1);
    }
    if a.frames == Some(0) {
        bail!("--frames 0: draw at least one frame");
    }
    let op = Operator::load(&a.file).map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
    if a.headless {
        let gpu = Gpu::new(&GpuOptions::default()).map_err(no_gpu)?;
        return headless(a, op, gpu, out);
    }
    window::run(a, op, out)
}

/// `--headless`: frames drawn offscreen, the last written to the screenshot.
fn headless(a: &ViewArgs, op: Operator, gpu: Gpu, out: &mut dyn Write) -> Result<()> {
    let path = a.screenshot.as_ref().expect("clap requires --screenshot");
    let frames = a.frames.unwrap_or(60);
    let mut viewer = Viewer::new(gpu, op, a)?;
    let (width, height) = a.size;
    let format = wgpu::TextureFormat::Rgba8UnormSrgb;
    let target = scene::texture(
        &viewer.gpu,
        "view headless",
        a.size,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    );
    let view = target.create_view(&Default::default());
    let start = Instant::now();
    for frame in 0..frames {
        if a.animate {
            viewer.animate(frame);
        }
        viewer.relight()?;
        let mut encoder = viewer
            .gpu
            .device()
            .create_command_encoder(&Default::default());
        let exposure = viewer.exposure();
        viewer.draw(&mut encoder, &view, format, a.size, exposure);
        viewer.gpu.queue().submit([encoder.finish()]);
    }
    viewer.gpu.wait()?;
    let seconds = start.elapsed().as_secs_f64();
    let stages = viewer.timed_frame(&view, format, a.size)?;
    viewer.screenshot(path, a.size)?;
    let (n, k) = viewer.sizes();
    writeln!(
        out,
        "{frames} frames of {width}x{height} on {} (n = {n}, k = {k}): {:.1} frames/s; a frame \
         waited for stage by stage: evaluation {:.3} ms, lightmap fill {:.3} ms, draw {:.3} ms; \
         exposure {:.2} EV",
        viewer.adapter(),
        frames as f64 / seconds,
        1e3 * stages.evaluate.as_secs_f64(),
        1e3 * stages.fill.as_secs_f64(),
        1e3 * stages.draw.as_secs_f64(),
        viewer.exposure_ev(),
    )?;
    writeln!(out, "wrote {}", path.display())?;
    Ok(())
}
