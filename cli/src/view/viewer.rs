//! What the window and `--headless` share: the device, the evaluator, the GPU lightmap fill, the
//! drawn scene, the light groups, the exposure and the camera ([`Viewer`]), and the arguments.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuDirect, GpuEvaluator, GpuLightmap, wgpu};
use lrr_runtime::lights::{DirectLighting, Light};
use lrr_runtime::trace::{CameraFields, Image};
use lrr_runtime::{Lightmap, Operator, Rgb, RgbMut};

use super::scene::{Eye, Scene};
use crate::exr_image::ExrSamples;
use crate::picture::{self, parse_size};

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// Operator file (baked by this version: lightmap coordinates and their atlas).
    pub file: PathBuf,
    /// Start from the file's camera of this name [default: its first, else one framing the
    /// scene].
    #[arg(long, value_name = "NAME")]
    pub camera: Option<String>,
    /// Light group intensities at the start, `NAME=A` (repeatable; the rest at 1).
    #[arg(long = "group", value_name = "NAME=A")]
    pub groups: Vec<String>,
    /// Exposure in stops [default: the one mapping the 99th percentile of the surfaces' B/π
    /// to white].
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Window (or headless image) size.
    #[arg(long, value_name = "WxH", value_parser = parse_size, default_value = "1280x720")]
    pub size: (u32, u32),
    /// Draw offscreen, with no window: `--frames` frames, the last written to `--screenshot`.
    #[arg(long, requires = "screenshot")]
    pub headless: bool,
    /// Frames to draw before closing [default: 60 with --headless; the window stays open].
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,
    /// Where the screenshot goes (`.png`: sRGB at the exposure; `.exr`: linear B/π): the last
    /// frame with --headless or --frames, else what F12 writes.
    #[arg(long, value_name = "FILE")]
    pub screenshot: Option<PathBuf>,
    /// Animate the lights: each light group (or the whole emission) pulses between 0 and 2 in
    /// turn, one cycle every 60 frames, as a hand on the sliders would (a demo, and what the
    /// tests use to see the scene relit every frame).
    #[arg(long)]
    pub animate: bool,
    /// Lights that are not surfaces (the file's, and these flags'): moved in the panel; each
    /// frame the GPU direct pass lights the elements with them before the operator bounces it.
    #[command(flatten)]
    pub lights: crate::emission::LightArgs,
}

/// The one-line error of a machine without a usable GPU adapter.
pub(super) fn no_gpu(e: lrr_runtime::gpu::GpuError) -> anyhow::Error {
    let why = e
        .to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    anyhow::anyhow!(
        "lrr view needs a GPU adapter, and none is usable: {why} (without a GPU: \
         scripts/setup-gpu.sh installs lavapipe, Mesa's Vulkan on the CPU; run with \
         WGPU_BACKEND=vulkan)"
    )
}

pub(super) fn screenshot_format(path: &Path) -> Result<bool> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => Ok(false),
        Some("exr") => Ok(true),
        _ => bail!(
            "--screenshot {}: the extension chooses the format: .png (sRGB at the exposure) or \
             .exr (linear B/π)",
            path.display()
        ),
    }
}

/// Per-stage times of a frame measured with waits between the stages (once a second in the
/// window; the other frames run back to back).
#[derive(Debug, Clone, Copy, Default)]
pub struct StageTimes {
    pub evaluate: Duration,
    pub fill: Duration,
    pub draw: Duration,
}

/// What the window and the headless path share: the device, the evaluator, the lightmap fill,
/// the drawn scene, the lights and the camera.
pub struct Viewer {
    pub(super) gpu: Gpu,
    op: Operator,
    eval: GpuEvaluator,
    fill: GpuLightmap,
    scene: Scene,
    /// Light group names and their intensities (none: the baked emission times `intensity`).
    pub groups: Vec<String>,
    pub intensities: Vec<f32>,
    /// With no light groups: the factor on the baked emission.
    pub intensity: f32,
    /// Exposure in stops over `base_exposure`.
    pub ev: f32,
    base_exposure: f32,
    pub eye: Eye,
    /// The file's cameras (name, camera).
    pub cameras: Vec<(String, Eye)>,
    emission: Vec<[f32; 3]>,
    scaled: Vec<[f32; 3]>,
    /// Lights that are not surfaces, as the panel moves them, and the GPU direct pass.
    pub lights: Vec<Light>,
    direct: Option<GpuDirect>,
}

impl Viewer {
    pub(super) fn new(gpu: Gpu, op: Operator, a: &ViewArgs) -> Result<Self> {
        let lightmap = Lightmap::new(op.file(), None)
            .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
        let mut eval = GpuEvaluator::new(&gpu, &op)?;
        let fill = GpuLightmap::new(&gpu, op.file(), &lightmap)?;
        let scene = Scene::new(&gpu, op.file(), fill.texture())?;
        let groups: Vec<String> = op.light_groups().map(str::to_string).collect();
        let mut intensities = vec![1.0f32; groups.len()];
        for g in &a.groups {
            let Some((name, value)) = g.split_once('=') else {
                bail!("--group {g}: give NAME=A");
            };
            let Some(i) = groups.iter().position(|n| n == name) else {
                bail!(
                    "--group {name}: the file has no such light group (it has: {})",
                    groups.join(", ")
                );
            };
            intensities[i] = value
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .with_context(|| format!("--group {g}: the intensity must be a number >= 0"))?;
        }
        let cameras: Vec<(String, Eye)> = op
            .file()
            .display
            .cameras
            .iter()
            .map(|c| {
                (
                    c.name.clone(),
                    Eye {
                        eye: c.eye,
                        target: c.target,
                        up: c.up,
                        fov_y_deg: c.fov_y_deg,
                    },
                )
            })
            .collect();
        let eye = match (&a.camera, cameras.first()) {
            (Some(_), _) => {
                let fields = CameraFields {
                    name: a.camera.clone(),
                    ..CameraFields::default()
                };
                let c = fields.choose(&op.file().display.cameras).map_err(|_| {
                    let names: Vec<&str> = cameras.iter().map(|(n, _)| n.as_str()).collect();
                    anyhow::anyhow!(
                        "--camera {}: the file has no such camera (it has: {})",
                        a.camera.as_deref().unwrap_or(""),
                        names.join(", ")
                    )
                })?;
                Eye {
                    eye: c.eye,
                    target: c.target,
                    up: c.up,
                    fov_y_deg: c.fov_y_deg,
                }
            }
            (None, Some((_, eye))) => *eye,
            (None, None) => scene.framing(),
        };
        let frame_lights = a.lights.lights(&op)?;
        let lights = frame_lights.lights;
        // The GPU direct pass when something is not a surface: the lights (shadow rays) and the
        // sky (its transfer, the bake's or projected here once on the CPU).
        let mut direct = match lights.is_empty() && frame_lights.sky.is_none() {
            true => None,
            false => {
                let mut pass = DirectLighting::new(op.file(), frame_lights.samples, 0)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", a.file.display()))?;
                let mut d = GpuDirect::new(&gpu, &pass, &op.reflectance())?;
                d.set_sky(&mut pass, frame_lights.sky.as_ref())?;
                Some(d)
            }
        };
        let emission = op.baked_emission();
        // The automatic exposure: the 99th percentile of B/π over surfaces that do not emit,
        // of the first frame.
        let mut b = vec![[0.0f32; 3]; op.n()];
        match (&mut direct, groups.is_empty()) {
            (None, true) => eval.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut b))?,
            (None, false) => eval.evaluate_groups(&intensities, RgbMut::triples(&mut b))?,
            (Some(d), true) => {
                d.evaluate(
                    &mut eval,
                    &lights,
                    Rgb::triples(&emission),
                    RgbMut::triples(&mut b),
                )?;
            }
            (Some(d), false) => {
                d.evaluate_groups(&mut eval, &lights, &intensities, RgbMut::triples(&mut b))?;
            }
        }
        let mut lum: Vec<f32> = b
            .iter()
            .zip(&emission)
            .filter(|(_, e)| e.iter().all(|&v| v == 0.0))
            .map(|(v, _)| (0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]) / std::f32::consts::PI)
            .filter(|l| *l > 0.0)
            .collect();
        let base_exposure = if lum.is_empty() {
            1.0
        } else {
            let at = (lum.len() - 1) * 99 / 100;
            1.0 / *lum.select_nth_unstable_by(at, f32::total_cmp).1
        };
        Ok(Self {
            gpu,
            eval,
            fill,
            scene,
            groups,
            intensities,
            intensity: 1.0,
            ev: a.exposure.map_or(0.0, |ev| ev - base_exposure.log2()),
            base_exposure,
            eye,
            cameras,
            scaled: emission.clone(),
            emission,
            lights,
            direct,
            op,
        })
    }

    /// With `--animate`: the lights at frame `frame` (see [`ViewArgs::animate`]).
    pub(super) fn animate(&mut self, frame: u64) {
        let phase = |g: usize, count: usize| {
            let t = frame as f32 / 60.0 + g as f32 / count.max(1) as f32;
            1.0 + (std::f32::consts::TAU * t).sin()
        };
        let count = self.intensities.len();
        for (g, a) in self.intensities.iter_mut().enumerate() {
            *a = phase(g, count);
        }
        self.intensity = phase(0, 1);
    }

    /// The factor on `B/π` before display.
    pub fn exposure(&self) -> f32 {
        self.base_exposure * 2f32.powf(self.ev)
    }

    /// The exposure in stops (absolute: `log2` of [`exposure`](Self::exposure)).
    pub fn exposure_ev(&self) -> f32 {
        self.exposure().log2()
    }

    /// Submits a frame's evaluation and lightmap fill.
    pub(super) fn relight(&mut self) -> Result<()> {
        self.evaluate()?;
        self.fill.fill(self.eval.radiosity_buffer())?;
        Ok(())
    }

    /// Submits a frame's evaluation: the direct pass of the lights first, when there are any.
    fn evaluate(&mut self) -> Result<()> {
        if self.groups.is_empty() {
            let k = self.intensity;
            for (s, e) in self.scaled.iter_mut().zip(&self.emission) {
                *s = e.map(|v| v * k);
            }
        }
        // A light the panel moved to a value the pass refuses (a zero direction) sits out.
        let shining: Vec<Light> = self
            .lights
            .iter()
            .filter(|l| l.check().is_ok())
            .cloned()
            .collect();
        match (&mut self.direct, self.groups.is_empty()) {
            (None, true) => self.eval.submit(Rgb::triples(&self.scaled))?,
            (None, false) => self.eval.submit_groups(&self.intensities)?,
            (Some(d), true) => {
                d.submit(&mut self.eval, &shining, Rgb::triples(&self.scaled))?;
            }
            (Some(d), false) => {
                d.submit_groups(&mut self.eval, &shining, &self.intensities)?;
            }
        }
        Ok(())
    }

    /// Records the scene into `target`.
    pub(super) fn draw(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        size: (u32, u32),
        exposure: f32,
    ) {
        let eye = self.eye;
        self.scene
            .draw(&self.gpu, encoder, target, format, size, &eye, exposure);
    }

    /// A frame with waits between its stages, timed.
    pub(super) fn timed_frame(
        &mut self,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        size: (u32, u32),
    ) -> Result<StageTimes> {
        self.gpu.wait()?;
        let t = Instant::now();
        self.evaluate()?;
        self.gpu.wait()?;
        let evaluate = t.elapsed();
        let t = Instant::now();
        self.fill.fill(self.eval.radiosity_buffer())?;
        self.gpu.wait()?;
        let fill = t.elapsed();
        let t = Instant::now();
        let mut encoder = self
            .gpu
            .device()
            .create_command_encoder(&Default::default());
        let exposure = self.exposure();
        self.draw(&mut encoder, target, format, size, exposure);
        self.gpu.queue().submit([encoder.finish()]);
        self.gpu.wait()?;
        Ok(StageTimes {
            evaluate,
            fill,
            draw: t.elapsed(),
        })
    }

    /// The current frame drawn offscreen at `size` as linear `B/π` (exposure 1).
    pub(super) fn capture(&mut self, size: (u32, u32)) -> Result<Image> {
        let (width, height) = size;
        let format = wgpu::TextureFormat::Rgba32Float;
        let texture = super::scene::texture(
            &self.gpu,
            "view capture",
            size,
            format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let view = texture.create_view(&Default::default());
        let row = (16 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let staging = self.gpu.device().create_buffer(&wgpu::BufferDescriptor {
            label: Some("view capture readback"),
            size: u64::from(row) * u64::from(height),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self
            .gpu
            .device()
            .create_command_encoder(&Default::default());
        self.draw(&mut encoder, &view, format, size, 1.0);
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(height),
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        self.gpu.queue().submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.gpu.wait()?;
        rx.recv()
            .context("the screenshot's readback never completed")?
            .context("reading the screenshot back")?;
        let bytes = staging
            .get_mapped_range(..)
            .context("reading the screenshot back")?;
        let mut pixels = Vec::with_capacity((width * height) as usize);
        for y in 0..height as usize {
            let line = &bytes[y * row as usize..];
            for x in 0..width as usize {
                let f = |c: usize| {
                    let at = 16 * x + 4 * c;
                    f32::from_le_bytes([line[at], line[at + 1], line[at + 2], line[at + 3]])
                };
                pixels.push([f(0), f(1), f(2)]);
            }
        }
        drop(bytes);
        staging.unmap();
        Ok(Image {
            width,
            height,
            pixels,
        })
    }

    /// Writes the current frame to `path` (PNG at the exposure, or EXR of linear `B/π`).
    pub(super) fn screenshot(&mut self, path: &Path, size: (u32, u32)) -> Result<()> {
        let image = self.capture(size)?;
        let bytes = if screenshot_format(path)? {
            picture::encode_exr(
                &image,
                ExrSamples::Float,
                "lrr view: the lightmap sampled bilinearly at each pixel (B/pi)",
            )?
        } else {
            picture::encode_png(&image, self.exposure())?
        };
        lrr_formats::write_atomic(path, &bytes)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(())
    }

    /// The diagonal of the scene's bounding box.
    pub fn scene_diagonal(&self) -> f32 {
        self.scene.diagonal()
    }

    /// The adapter's description.
    pub fn adapter(&self) -> String {
        self.gpu.describe()
    }

    /// Elements and patches of the operator.
    pub fn sizes(&self) -> (usize, usize) {
        (self.op.n(), self.op.k())
    }
}
