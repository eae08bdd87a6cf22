//! The window of `lrr view`: winit for the window and input, a wgpu surface on the device the
//! evaluator runs on (the adapter chosen among those that present to it), egui for the panel.
//! The scene is relit and drawn every frame (vsync: the display's refresh rate); once a second
//! one frame is measured stage by stage (evaluation, lightmap fill, draw, each waited for).

use std::collections::VecDeque;
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use lrr_runtime::Operator;
use lrr_runtime::gpu::{Gpu, GpuOptions, wgpu};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use super::scene::{Eye, cross, dot, normalize, sub};
use super::viewer::{StageTimes, ViewArgs, Viewer, no_gpu};

/// Runs the window until it is closed (or `--frames` are drawn).
pub fn run(a: &ViewArgs, op: Operator, out: &mut dyn Write) -> Result<()> {
    if cfg!(target_os = "linux")
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        bail!(
            "lrr view needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set: run it \
             in a desktop session, under a virtual X server (`xvfb-run -a lrr view …`; Debian: \
             apt-get install xvfb), or with --headless --screenshot FILE"
        );
    }
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow::anyhow!(
            "lrr view: cannot connect to the display ({e}); run it in a desktop session, under \
             `xvfb-run -a`, or with --headless --screenshot FILE"
        )
    })?;
    let mut app = App {
        args: a,
        op: Some(op),
        state: None,
        error: None,
        said: Vec::new(),
    };
    event_loop.run_app(&mut app)?;
    for line in &app.said {
        writeln!(out, "{line}")?;
    }
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App<'a> {
    args: &'a ViewArgs,
    op: Option<Operator>,
    state: Option<State>,
    error: Option<anyhow::Error>,
    /// Lines to print when the window closes.
    said: Vec<String>,
}

/// Mouse and keys held.
#[derive(Default)]
struct Input {
    left: bool,
    right: bool,
    cursor: Option<(f64, f64)>,
    keys: Vec<KeyCode>,
}

struct State {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    viewer: Viewer,
    egui: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    input: Input,
    last: Instant,
    frame_times: VecDeque<f32>,
    stages: StageTimes,
    last_timed: Instant,
    frames: u64,
    screenshots: u32,
    want_screenshot: bool,
    camera: usize,
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        let Some(op) = self.op.take() else {
            return;
        };
        match start(self.args, op, event_loop) {
            Ok(state) => self.state = Some(state),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(state) = self.state.as_mut() else {
            return;
        };
        let response = state.egui_state.on_window_event(&state.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) if size.width > 0 && size.height > 0 => {
                state.config.width = size.width;
                state.config.height = size.height;
                state
                    .surface
                    .configure(state.viewer.gpu.device(), &state.config);
            }
            WindowEvent::RedrawRequested => match state.redraw(self.args) {
                Ok(done) => {
                    if done {
                        self.said.push(state.summary());
                        event_loop.exit();
                    }
                }
                Err(e) => {
                    self.error = Some(e);
                    event_loop.exit();
                }
            },
            _ if response.consumed => {}
            WindowEvent::MouseInput {
                state: s, button, ..
            } => {
                let down = s == ElementState::Pressed;
                match button {
                    MouseButton::Left => state.input.left = down,
                    MouseButton::Right => state.input.right = down,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let now = (position.x, position.y);
                if let Some(before) = state.input.cursor {
                    let (dx, dy) = ((now.0 - before.0) as f32, (now.1 - before.1) as f32);
                    if state.input.left {
                        orbit(&mut state.viewer.eye, dx, dy);
                    } else if state.input.right {
                        let scale = state.viewer.scene_diagonal() / state.config.height as f32;
                        pan(&mut state.viewer.eye, dx * scale, dy * scale);
                    }
                }
                state.input.cursor = Some(now);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                dolly(&mut state.viewer.eye, 0.9f32.powf(lines));
            }
            WindowEvent::KeyboardInput { event, .. } => {
                if let PhysicalKey::Code(code) = event.physical_key {
                    let down = event.state == ElementState::Pressed;
                    state.input.keys.retain(|k| *k != code);
                    if down {
                        state.input.keys.push(code);
                        if code == KeyCode::F12 {
                            state.want_screenshot = true;
                        }
                        if code == KeyCode::Escape {
                            event_loop.exit();
                        }
                    }
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(state) = &self.state {
            state.window.request_redraw();
        }
    }
}

fn start(a: &ViewArgs, op: Operator, event_loop: &ActiveEventLoop) -> Result<State> {
    let title = format!(
        "lrr view — {}",
        a.file.file_name().map_or_else(
            || a.file.display().to_string(),
            |n| n.to_string_lossy().into_owned()
        )
    );
    let window = Arc::new(
        event_loop.create_window(
            Window::default_attributes()
                .with_title(title)
                .with_inner_size(PhysicalSize::new(a.size.0, a.size.1)),
        )?,
    );
    let instance = lrr_runtime::gpu::instance();
    let surface = instance.create_surface(window.clone())?;
    let gpu = Gpu::with_surface(&GpuOptions::default(), &instance, &surface).map_err(no_gpu)?;
    let caps = surface.get_capabilities(gpu.adapter());
    let Some(&format) = caps
        .formats
        .iter()
        .find(|f| f.is_srgb())
        .or(caps.formats.first())
    else {
        bail!(
            "the window's surface offers no format on {}",
            gpu.adapter_name()
        );
    };
    let size = window.inner_size();
    let config = wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        width: size.width.max(1),
        height: size.height.max(1),
        present_mode: wgpu::PresentMode::Fifo,
        desired_maximum_frame_latency: 2,
        alpha_mode: caps.alpha_modes[0],
        view_formats: vec![],
        color_space: Default::default(),
    };
    surface.configure(gpu.device(), &config);
    let egui_renderer =
        egui_wgpu::Renderer::new(gpu.device(), format, egui_wgpu::RendererOptions::default());
    let viewer = Viewer::new(gpu, op, a)?;
    let egui = egui::Context::default();
    let egui_state = egui_winit::State::new(
        egui.clone(),
        egui::ViewportId::ROOT,
        &window,
        Some(window.scale_factor() as f32),
        None,
        None,
    );
    let camera = a
        .camera
        .as_ref()
        .and_then(|c| viewer.cameras.iter().position(|(n, _)| n == c))
        .unwrap_or(0);
    Ok(State {
        window,
        surface,
        config,
        viewer,
        egui,
        egui_state,
        egui_renderer,
        input: Input::default(),
        last: Instant::now(),
        frame_times: VecDeque::new(),
        stages: StageTimes::default(),
        last_timed: Instant::now() - Duration::from_secs(2),
        frames: 0,
        screenshots: 0,
        want_screenshot: false,
        camera,
    })
}

impl State {
    /// Draws one frame; true when `--frames` are drawn (the screenshot written).
    fn redraw(&mut self, a: &ViewArgs) -> Result<bool> {
        let now = Instant::now();
        let dt = (now - self.last).as_secs_f32();
        self.last = now;
        self.frame_times.push_back(dt);
        if self.frame_times.len() > 60 {
            self.frame_times.pop_front();
        }
        self.fly(dt);
        if a.animate {
            self.viewer.animate(self.frames);
        }
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface
                    .configure(self.viewer.gpu.device(), &self.config);
                return Ok(false);
            }
            _ => return Ok(false),
        };
        let view = frame.texture.create_view(&Default::default());
        let size = (self.config.width, self.config.height);
        let format = self.config.format;
        if self.last_timed.elapsed() >= Duration::from_secs(1) {
            self.stages = self.viewer.timed_frame(&view, format, size)?;
            self.last_timed = Instant::now();
        } else {
            self.viewer.relight()?;
            let mut encoder = self
                .viewer
                .gpu
                .device()
                .create_command_encoder(&Default::default());
            let exposure = self.viewer.exposure();
            self.viewer
                .draw(&mut encoder, &view, format, size, exposure);
            self.viewer.gpu.queue().submit([encoder.finish()]);
        }
        self.panel(&view, size)?;
        self.viewer.gpu.queue().present(frame);
        self.frames += 1;
        let last = a.frames.is_some_and(|n| self.frames >= n);
        if self.want_screenshot || (last && a.screenshot.is_some()) {
            self.want_screenshot = false;
            let path = match &a.screenshot {
                Some(p) => p.clone(),
                None => {
                    self.screenshots += 1;
                    PathBuf::from(format!("lrr-view-{}.png", self.screenshots))
                }
            };
            self.viewer.screenshot(&path, size)?;
            eprintln!("lrr view: wrote {}", path.display());
        }
        Ok(last)
    }

    /// WASD/QE move the eye and the target together.
    fn fly(&mut self, dt: f32) {
        let speed = 0.25 * self.viewer.scene_diagonal() * dt;
        let e = &mut self.viewer.eye;
        let f = normalize(sub(e.target, e.eye));
        let r = normalize(cross(f, e.up));
        let u = normalize(e.up);
        let mut step = [0.0f32; 3];
        for key in &self.input.keys {
            let (dir, sign) = match key {
                KeyCode::KeyW => (f, 1.0),
                KeyCode::KeyS => (f, -1.0),
                KeyCode::KeyD => (r, 1.0),
                KeyCode::KeyA => (r, -1.0),
                KeyCode::KeyE => (u, 1.0),
                KeyCode::KeyQ => (u, -1.0),
                _ => continue,
            };
            for k in 0..3 {
                step[k] += sign * speed * dir[k];
            }
        }
        for k in 0..3 {
            e.eye[k] += step[k];
            e.target[k] += step[k];
        }
    }

    /// The egui panel drawn over the scene.
    fn panel(&mut self, view: &wgpu::TextureView, size: (u32, u32)) -> Result<()> {
        let input = self.egui_state.take_egui_input(&self.window);
        let mean = self.frame_times.iter().sum::<f32>() / self.frame_times.len().max(1) as f32;
        let (n, k) = self.viewer.sizes();
        let adapter = self.viewer.adapter();
        let stages = self.stages;
        let viewer = &mut self.viewer;
        let camera = &mut self.camera;
        let want_screenshot = &mut self.want_screenshot;
        let output = self.egui.run_ui(input, |ui| {
            egui::Panel::left("lrr").show(ui, |ui| {
                ui.heading("lrr view");
                ui.label(format!("n = {n} elements, k = {k} patches"));
                ui.label(adapter.as_str());
                ui.separator();
                ui.label(format!(
                    "{:.0} frames/s, {:.2} ms a frame",
                    1.0 / mean.max(1e-6),
                    1e3 * mean
                ));
                ui.label(format!(
                    "evaluation {:.2} ms · fill {:.2} ms · draw {:.2} ms",
                    1e3 * stages.evaluate.as_secs_f64(),
                    1e3 * stages.fill.as_secs_f64(),
                    1e3 * stages.draw.as_secs_f64()
                ));
                ui.small("(one frame a second, each stage waited for)");
                ui.separator();
                ui.add(egui::Slider::new(&mut viewer.ev, -8.0..=8.0).text("exposure (EV)"));
                if !viewer.cameras.is_empty() {
                    let names: Vec<String> =
                        viewer.cameras.iter().map(|(n, _)| n.clone()).collect();
                    let before = *camera;
                    egui::ComboBox::from_label("camera")
                        .selected_text(names[*camera].clone())
                        .show_ui(ui, |ui| {
                            for (i, name) in names.iter().enumerate() {
                                ui.selectable_value(camera, i, name.as_str());
                            }
                        });
                    if *camera != before || ui.button("back to the camera").clicked() {
                        viewer.eye = viewer.cameras[*camera].1;
                    }
                }
                ui.separator();
                if viewer.groups.is_empty() {
                    ui.add(egui::Slider::new(&mut viewer.intensity, 0.0..=4.0).text("emission"));
                } else {
                    ui.label("light groups");
                    for (name, a) in viewer.groups.iter().zip(viewer.intensities.iter_mut()) {
                        ui.add(egui::Slider::new(a, 0.0..=4.0).text(name.as_str()));
                    }
                }
                if !viewer.lights.is_empty() {
                    ui.separator();
                    ui.label("lights (drag the numbers)");
                    let speed = f64::from(viewer.scene_diagonal()) / 400.0;
                    for (i, light) in viewer.lights.iter_mut().enumerate() {
                        let (label, place) = match light {
                            lrr_runtime::lights::Light::Point { position, .. } => {
                                ("point", position)
                            }
                            lrr_runtime::lights::Light::Spot { position, .. } => ("spot", position),
                            lrr_runtime::lights::Light::Directional { direction, .. } => {
                                ("sun direction", direction)
                            }
                        };
                        ui.horizontal(|ui| {
                            ui.label(format!("{i}: {label}"));
                            for v in place.iter_mut() {
                                ui.add(egui::DragValue::new(v).speed(speed));
                            }
                        });
                    }
                }
                ui.separator();
                if ui.button("screenshot (F12)").clicked() {
                    *want_screenshot = true;
                }
                ui.small("left drag: orbit · right drag: pan · wheel: zoom · WASD QE: fly");
            });
        });
        self.egui_state
            .handle_platform_output(&self.window, output.platform_output);
        let jobs = self.egui.tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: output.pixels_per_point,
        };
        let gpu = &self.viewer.gpu;
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.egui_renderer
                    .update_texture(gpu.device(), gpu.queue(), *id, delta);
            }
        }
        let mut encoder = gpu.device().create_command_encoder(&Default::default());
        let extra = self.egui_renderer.update_buffers(
            gpu.device(),
            gpu.queue(),
            &mut encoder,
            &jobs,
            &screen,
        );
        {
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("egui"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Load,
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.egui_renderer.render(&mut pass, &jobs, &screen);
        }
        gpu.queue()
            .submit(extra.into_iter().chain([encoder.finish()]));
        for id in &output.textures_delta.free {
            self.egui_renderer.free_texture(id);
        }
        Ok(())
    }

    fn summary(&self) -> String {
        let mean = self.frame_times.iter().sum::<f32>() / self.frame_times.len().max(1) as f32;
        format!(
            "{} frames in the window on {}: {:.1} frames/s over the last {}; a frame stage by \
             stage: evaluation {:.3} ms, lightmap fill {:.3} ms, draw {:.3} ms",
            self.frames,
            self.viewer.adapter(),
            1.0 / mean.max(1e-6),
            self.frame_times.len(),
            1e3 * self.stages.evaluate.as_secs_f64(),
            1e3 * self.stages.fill.as_secs_f64(),
            1e3 * self.stages.draw.as_secs_f64()
        )
    }
}

/// Turns the eye around the target: `dx` pixels about the up axis, `dy` about the right axis
/// (kept off the poles).
fn orbit(e: &mut Eye, dx: f32, dy: f32) {
    let (yaw, pitch) = (-0.005 * dx, -0.005 * dy);
    let up = normalize(e.up);
    let mut d = sub(e.eye, e.target);
    d = rotate(d, up, yaw);
    let right = normalize(cross(up, d));
    let turned = rotate(d, right, pitch);
    let dist = dot(turned, turned).sqrt();
    if dot(turned, up).abs() < 0.98 * dist {
        d = turned;
    }
    e.eye = [e.target[0] + d[0], e.target[1] + d[1], e.target[2] + d[2]];
}

/// Moves the eye and the target across the view.
fn pan(e: &mut Eye, dx: f32, dy: f32) {
    let f = normalize(sub(e.target, e.eye));
    let r = normalize(cross(f, e.up));
    let u = cross(r, f);
    for k in 0..3 {
        let step = -dx * r[k] + dy * u[k];
        e.eye[k] += step;
        e.target[k] += step;
    }
}

/// Scales the eye's distance to the target.
fn dolly(e: &mut Eye, factor: f32) {
    for k in 0..3 {
        e.eye[k] = e.target[k] + (e.eye[k] - e.target[k]) * factor;
    }
}

/// `v` turned by `angle` about the unit `axis` (Rodrigues).
fn rotate(v: [f32; 3], axis: [f32; 3], angle: f32) -> [f32; 3] {
    let (s, c) = angle.sin_cos();
    let kxv = cross(axis, v);
    let kdv = dot(axis, v);
    [0, 1, 2].map(|i| v[i] * c + kxv[i] * s + axis[i] * kdv * (1.0 - c))
}
