//! [`GpuTracer`]: the CPU ray tracer's twin on the GPU (`trace.wgsl` of `lrr-shaders`), shading
//! with the radiosity the relighting left in [`GpuEvaluator::radiosity_buffer`] (no readback
//! between the two).
//!
//! [`GpuTracer::new`] takes a checked CPU [`Tracer`] (so both read the same display data, and
//! every index the shader follows was checked there) and uploads its scene once: BVH nodes,
//! leaf-order triangles, per-element ids, normals and materials, optics, and with SMOOTH
//! weights the smooth reconstruction (`super::smooth`, and per display face its corners' smooth
//! vertices, `lrr_shaders::smooth_element`). A frame writes the point lights'
//! intensities (their group's factor applied) and, when it has lights that are not surfaces
//! ([`DirectShading`]), their records and the reflectance per element (uploaded again only when
//! it changed), decides the effects exactly as the CPU twin does and builds (once per
//! combination, the lights' `DIRECT` variant included) the pipeline specialised by them; shading
//! smooth, it first
//! runs `smooth.wgsl` over the radiosity buffer (the smooth-vertex values, once per frame, left
//! on the GPU), then renders the image in tiles of at most [`GpuTracer::tile_pixels`] pixels,
//! one dispatch and one submission each, so that no dispatch runs long enough for a driver's
//! watchdog, and reads the image back as RGBA f32.
//!
//! ```no_run
//! use lrr_runtime::gpu::{Gpu, GpuEvaluator, GpuOptions, GpuTracer};
//! use lrr_runtime::trace::{Tracer, View};
//! use lrr_runtime::{Operator, Rgb};
//!
//! let op = Operator::load("cornell.lrr".as_ref())?;
//! let gpu = Gpu::new(&GpuOptions::default())?;
//! let mut eval = GpuEvaluator::new(&gpu, &op)?;
//! let mut tracer = GpuTracer::new(&gpu, &Tracer::new(op.file())?)?;
//! let view = View::new(&op.file().display.cameras[0], 640, 480)?;
//! eval.submit(Rgb::triples(&op.baked_emission()))?; // B stays on the GPU
//! let groups = vec![1.0; op.light_groups().len()];
//! let (image, report) = tracer.render(&view, eval.radiosity_buffer(), &groups, 640, 480)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::HashMap;
use std::time::{Duration, Instant};

use lrr_shaders::{
    DIRECT_LIGHT_BYTES, LIGHT_BYTES, NODE_BYTES, OPTICS_BYTES, SMOOTH_ELEMENT_BYTES, TRACE,
    TRACE_ENTRY, TRACE_LANES, TraceConstants, TraceParams, smooth_element,
};

use super::buffers::storage;
use super::common::{GpuError, bytes_of};
use super::device::Gpu;
use super::smooth::SmoothPass;
use crate::error::input;
use crate::rays::V3;
use crate::trace::{Decision, DirectShading, Effects, Image, Lighting, RayCounts, Tracer, View};

/// Default pixels per dispatch: 2¹⁸ (a 1920 × 1080 frame in 8 tiles). A diffuse tile is
/// 2¹⁸ closest hits, well under a millisecond on a datacenter GPU; a deep ray tree on a
/// CPU adapter stays far below any watchdog too.
pub const DEFAULT_TILE_PIXELS: u32 = 1 << 18;

/// What a GPU frame produced besides the image.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuRenderReport {
    /// The effects simulated and why (the CPU twin's decision).
    pub decision: Decision,
    /// Rays cast, by kind (`None` when not counted: timed frames).
    pub rays: Option<RayCounts>,
    /// Tiles (dispatches) of the frame.
    pub tiles: u32,
    /// Wall time from the first upload to the image read back.
    pub wall: Duration,
    /// GPU time of the trace dispatches alone (the sum over tiles, by timestamp queries around
    /// each tile's pass; not the smooth-vertex pass nor the copies); `None` when the adapter
    /// has no `TIMESTAMP_QUERY` or the frame has more than 2048 tiles.
    pub gpu: Option<Duration>,
}

/// The ray tracer on the GPU. See the [module docs](self).
pub struct GpuTracer {
    gpu: Gpu,
    tracer: Tracer,
    n: u32,
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<TraceConstants, wgpu::ComputePipeline>,
    params: wgpu::Buffer,
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
    /// Per leaf-order triangle: its display face.
    tri_face: wgpu::Buffer,
    /// Per display face: the original id of its element; its normal; its element's material.
    face_id: wgpu::Buffer,
    normals: wgpu::Buffer,
    face_material: wgpu::Buffer,
    optics: wgpu::Buffer,
    lights: wgpu::Buffer,
    /// Radiosity uploaded from the host ([`render_lighting`](Self::render_lighting)).
    host_radiosity: Option<wgpu::Buffer>,
    /// The smooth reconstruction (files with SMOOTH weights), and per display face its
    /// `lrr_shaders::smooth_element` record (binding `smooth_faces`).
    smooth: Option<(SmoothPass, wgpu::Buffer)>,
    /// Bound as `smooth_faces` and `vertex_values` when the file has no SMOOTH, and as
    /// `reflectance` in a frame without lights that are not surfaces (unread).
    no_smooth: wgpu::Buffer,
    /// The frame's lights that are not surfaces (`DirectLight` records), and how many it holds
    /// (made again, larger, when a frame has more; one zero record until then).
    direct_lights: wgpu::Buffer,
    direct_capacity: usize,
    /// The reflectance per element the last frame with such lights shaded with, on the GPU and
    /// on the host (uploaded again only when a frame's differs).
    reflectance: Option<(wgpu::Buffer, Vec<[f32; 3]>)>,
    tile_pixels: u32,
}

impl std::fmt::Debug for GpuTracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuTracer({} triangles, {} elements, tiles of {} pixels, {})",
            self.tracer.triangle_count(),
            self.n,
            self.tile_pixels,
            self.gpu.adapter_name()
        )
    }
}

impl GpuTracer {
    /// Uploads the display data of `tracer` (a checked CPU tracer of the file; its depth limit
    /// is this tracer's) to `gpu`. Errors when a buffer exceeds the adapter's binding limit.
    pub fn new(gpu: &Gpu, tracer: &Tracer) -> Result<Self, GpuError> {
        let scene = tracer.scene();
        let n = scene.n();
        let none = wgpu::BufferUsages::empty();
        let nodes: Vec<u32> = scene
            .rays
            .nodes
            .iter()
            .flat_map(|node| {
                let [a, b, c] = node.min.map(f32::to_bits);
                let [d, e, f] = node.max.map(f32::to_bits);
                [a, b, c, node.count, d, e, f, node.first]
            })
            .collect();
        let tris: Vec<f32> = scene.rays.tris.iter().flatten().copied().collect();
        let normals: Vec<f32> = scene.rays.normals.iter().flatten().copied().collect();
        let optics: Vec<f32> = scene
            .optics
            .iter()
            .flat_map(|o| {
                let [s0, s1, s2] = o.specular;
                let [m0, m1, m2] = o.mirror;
                let [t0, t1, t2] = o.transmission;
                [s0, s1, s2, o.shininess, m0, m1, m2, o.ior, t0, t1, t2, 0.0]
            })
            .collect();
        debug_assert_eq!(nodes.len() * 4, scene.rays.nodes.len() * NODE_BYTES);
        debug_assert_eq!(optics.len() * 4, scene.optics.len() * OPTICS_BYTES);
        let lights = scene.lights.len();
        let bindings = lrr_shaders::TRACE_BINDINGS.len() - 1;
        let limit = gpu.limits.max_storage_buffers_per_shader_stage;
        if (limit as usize) < bindings {
            return Err(GpuError::Device(format!(
                "GPU: the tracer binds {bindings} storage buffers, {} allows {limit} per shader \
                 stage; render on the CPU (--device cpu)",
                gpu.adapter_name()
            )));
        }
        let mut sizes = vec![
            ("BVH nodes", 4 * nodes.len() as u64),
            ("triangles", 4 * tris.len() as u64),
            ("radiosity", 12 * n as u64),
            ("point lights", (lights * LIGHT_BYTES) as u64),
            ("tile image", 16 * u64::from(DEFAULT_TILE_PIXELS)),
        ];
        if let Some((geometry, smooth)) = &scene.smooth {
            let faces = geometry.vertex_count.len() as u64;
            sizes.extend([
                ("smooth vertex values", 12 * smooth.vertex_count() as u64),
                ("smooth faces", SMOOTH_ELEMENT_BYTES as u64 * faces),
                ("smooth offsets", 4 * smooth.offsets.len() as u64),
                ("smooth weights", 4 * smooth.positions.len() as u64),
            ]);
        }
        check_fits(gpu, &sizes)?;
        let smooth = scene.smooth.as_ref().map(|(geometry, smooth)| {
            let faces: Vec<u32> = (0..geometry.vertex_count.len())
                .flat_map(|f| {
                    let corners = std::array::from_fn(|i| geometry.vertex(f, i));
                    let vertices = std::array::from_fn(|i| smooth.corners[4 * f + i]);
                    smooth_element(corners, vertices, geometry.vertex_count[f])
                })
                .collect();
            (
                SmoothPass::new(gpu, smooth, &scene.element_id),
                storage(gpu, "smooth faces", &faces, none),
            )
        });
        let layout = bind_group_layout(gpu);
        let pipeline_layout = gpu
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("trace"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
        Ok(GpuTracer {
            module: shader_module(gpu),
            pipelines: HashMap::new(),
            params: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("trace params"),
                size: TraceParams::SIZE as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            nodes: storage(gpu, "bvh nodes", &nodes, none),
            tris: storage(gpu, "triangles", &tris, none),
            tri_face: storage(gpu, "triangle faces", &scene.rays.tri_face, none),
            face_id: storage(gpu, "face element ids", &scene.rays.face_id, none),
            normals: storage(gpu, "face normals", &normals, none),
            face_material: storage(gpu, "face materials", &scene.face_material, none),
            optics: storage(gpu, "optics", &optics, none),
            lights: storage(
                gpu,
                "point lights",
                // At least one (zero) light: a binding holds at least one element.
                &vec![0.0f32; lights.max(1) * LIGHT_BYTES / 4],
                wgpu::BufferUsages::COPY_DST,
            ),
            host_radiosity: None,
            direct_lights: storage(
                gpu,
                "direct lights",
                &[0u32; DIRECT_LIGHT_BYTES / 4],
                wgpu::BufferUsages::COPY_DST,
            ),
            direct_capacity: 1,
            reflectance: None,
            smooth,
            no_smooth: storage(gpu, "no smooth", &[0u32; 16], none),
            tile_pixels: DEFAULT_TILE_PIXELS,
            n: n as u32,
            layout,
            pipeline_layout,
            gpu: gpu.clone(),
            tracer: tracer.clone(),
        })
    }

    /// Pixels per dispatch.
    pub fn tile_pixels(&self) -> u32 {
        self.tile_pixels
    }

    /// Sets the pixels per dispatch: from [`TRACE_LANES`] to [`DEFAULT_TILE_PIXELS`] (a smaller
    /// tile for a slow adapter or a deep ray tree under a short watchdog; tests use small tiles
    /// to cross tile boundaries).
    pub fn set_tile_pixels(&mut self, pixels: u32) -> Result<(), GpuError> {
        if !(TRACE_LANES..=DEFAULT_TILE_PIXELS).contains(&pixels) {
            return Err(input(format!(
                "tile of {pixels} pixels: give {TRACE_LANES} to {DEFAULT_TILE_PIXELS}"
            ))
            .into());
        }
        self.tile_pixels = pixels;
        Ok(())
    }

    /// Sets the depth limit of the ray tree (as [`Tracer::set_max_depth`]).
    pub fn set_max_depth(&mut self, depth: u32) -> Result<(), GpuError> {
        Ok(self.tracer.set_max_depth(depth)?)
    }

    /// Renders `view` at `width × height`, shading with `radiosity` (3 f32 per element, original
    /// ids, a storage buffer of this tracer's device: [`GpuEvaluator::radiosity_buffer`]) and
    /// the light groups' intensities, simulating what the scene needs (the CPU twin's
    /// decision). Rays are counted (atomics); [`render_with`](Self::render_with) can skip that.
    /// No lights that are not surfaces: [`render_direct`](Self::render_direct) adds them.
    ///
    /// [`GpuEvaluator::radiosity_buffer`]: super::GpuEvaluator::radiosity_buffer
    pub fn render(
        &mut self,
        view: &View,
        radiosity: &wgpu::Buffer,
        group_intensities: &[f32],
        width: u32,
        height: u32,
    ) -> Result<(Image, GpuRenderReport), GpuError> {
        self.render_direct(view, radiosity, group_intensities, None, width, height)
    }

    /// [`render`](Self::render) with lights that are not surfaces shaded at every hit, as the
    /// CPU twin's [`Lighting::direct`]: `ρ H(x) / π` added to the radiosity's radiance, each
    /// light behind its own shadow ray (counted with the shadow rays). `radiosity` is then the
    /// bounced light, `B − ρ ⊙ H` per element with `H` the lights' direct irradiance per element
    /// ([`DirectLighting::irradiance`](crate::lights::DirectLighting::irradiance)), as
    /// [`Lighting::radiosity`] says. `None`, or no lights: [`render`](Self::render), the
    /// pipeline without the lights' code. Errors name a light whose values are bad, or a
    /// reflectance of the wrong length (the CPU twin's messages).
    pub fn render_direct(
        &mut self,
        view: &View,
        radiosity: &wgpu::Buffer,
        group_intensities: &[f32],
        direct: Option<DirectShading<'_>>,
        width: u32,
        height: u32,
    ) -> Result<(Image, GpuRenderReport), GpuError> {
        let (intensities, decision) = self.tracer.frame_lights(view, group_intensities)?;
        let effects = decision.effects;
        self.frame(
            view,
            radiosity,
            &intensities,
            direct,
            decision,
            effects,
            true,
            (width, height),
        )
    }

    /// [`render_direct`](Self::render_direct) with the radiosity on the host (uploaded first;
    /// the CPU twin's [`Lighting`], its lights that are not surfaces included).
    pub fn render_lighting(
        &mut self,
        view: &View,
        lighting: &Lighting,
        width: u32,
        height: u32,
    ) -> Result<(Image, GpuRenderReport), GpuError> {
        let buffer = self.upload_radiosity(lighting.radiosity)?;
        self.render_direct(
            view,
            &buffer,
            lighting.group_intensities,
            lighting.direct,
            width,
            height,
        )
    }

    /// [`render`](Self::render) with the effects forced (as [`Tracer::render_with`]) and ray
    /// counting on or off (off: the frame a benchmark times); no lights that are not surfaces.
    #[allow(clippy::too_many_arguments)]
    pub fn render_with(
        &mut self,
        view: &View,
        radiosity: &wgpu::Buffer,
        group_intensities: &[f32],
        effects: Effects,
        count_rays: bool,
        width: u32,
        height: u32,
    ) -> Result<(Image, GpuRenderReport), GpuError> {
        let (intensities, decision) = self.tracer.frame_lights(view, group_intensities)?;
        if effects.max_depth > crate::trace::MAX_DEPTH_LIMIT {
            return Err(input(format!(
                "the ray depth limit is at most {}, got {}",
                crate::trace::MAX_DEPTH_LIMIT,
                effects.max_depth
            ))
            .into());
        }
        self.frame(
            view,
            radiosity,
            &intensities,
            None,
            decision,
            effects,
            count_rays,
            (width, height),
        )
    }

    /// A buffer holding `radiosity` (checked as the CPU twin checks it), reused across frames.
    pub fn upload_radiosity(&mut self, radiosity: &[[f32; 3]]) -> Result<wgpu::Buffer, GpuError> {
        let n = self.n as usize;
        if radiosity.len() != n {
            return Err(input(format!(
                "radiosity: {} values for {n} elements",
                radiosity.len()
            ))
            .into());
        }
        if let Some(i) = radiosity
            .iter()
            .position(|b| b.iter().any(|c| !c.is_finite()))
        {
            return Err(input(format!("radiosity of element {i} is not finite")).into());
        }
        let flat: Vec<f32> = radiosity.iter().flatten().copied().collect();
        let buffer = match &self.host_radiosity {
            Some(b) => b.clone(),
            None => {
                let b = storage(
                    &self.gpu,
                    "host radiosity",
                    &flat,
                    wgpu::BufferUsages::COPY_DST,
                );
                self.host_radiosity = Some(b.clone());
                return Ok(b);
            }
        };
        if !flat.is_empty() {
            self.gpu.queue.write_buffer(&buffer, 0, bytes_of(&flat));
        }
        Ok(buffer)
    }

    fn pipeline(&mut self, constants: TraceConstants) -> wgpu::ComputePipeline {
        let (gpu, module, layout) = (&self.gpu, &self.module, &self.pipeline_layout);
        self.pipelines
            .entry(constants)
            .or_insert_with(|| {
                let values = constants.constants();
                gpu.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(TRACE_ENTRY),
                        layout: Some(layout),
                        module,
                        entry_point: Some(TRACE_ENTRY),
                        compilation_options: wgpu::PipelineCompilationOptions {
                            constants: &values,
                            zero_initialize_workgroup_memory: false,
                        },
                        cache: None,
                    })
            })
            .clone()
    }

    /// Checks a frame's lights that are not surfaces as the CPU twin does and uploads them
    /// (their records, and the reflectance where it changed); the number of lights the shader
    /// loops over, 0 when the frame has none that shines (no `DIRECT` variant then). Dark lights
    /// are left out: the CPU's `at_point` skips them before any ray.
    fn upload_direct(&mut self, direct: Option<DirectShading<'_>>) -> Result<u32, GpuError> {
        let Some(direct) = direct else {
            return Ok(0);
        };
        let n = self.n as usize;
        if direct.reflectance.len() != n {
            return Err(input(format!(
                "direct shading: {} reflectances for {n} elements",
                direct.reflectance.len()
            ))
            .into());
        }
        for (i, light) in direct.lights.iter().enumerate() {
            light
                .check()
                .map_err(|p| input(format!("light {i} ({light:?}): {p}")))?;
        }
        let records: Vec<u32> = direct
            .lights
            .iter()
            .filter(|l| l.strength() != [0.0; 3])
            .flat_map(|l| l.gpu_record())
            .collect();
        let count = records.len() / (DIRECT_LIGHT_BYTES / 4);
        if count == 0 {
            return Ok(0);
        }
        check_fits(
            &self.gpu,
            &[("direct lights", (count * DIRECT_LIGHT_BYTES) as u64)],
        )?;
        if count > self.direct_capacity {
            self.direct_lights = storage(
                &self.gpu,
                "direct lights",
                &records,
                wgpu::BufferUsages::COPY_DST,
            );
            self.direct_capacity = count;
        } else {
            self.gpu
                .queue
                .write_buffer(&self.direct_lights, 0, bytes_of(&records));
        }
        // Compared bit for bit, so that a zero's new sign or a NaN reaches the GPU too.
        let same = |held: &[[f32; 3]]| {
            held.len() == direct.reflectance.len()
                && held
                    .iter()
                    .flatten()
                    .zip(direct.reflectance.iter().flatten())
                    .all(|(a, b)| a.to_bits() == b.to_bits())
        };
        match &mut self.reflectance {
            Some((_, held)) if same(held) => {}
            Some((buffer, held)) => {
                let flat: Vec<f32> = direct.reflectance.iter().flatten().copied().collect();
                self.gpu.queue.write_buffer(buffer, 0, bytes_of(&flat));
                held.copy_from_slice(direct.reflectance);
            }
            None => {
                let flat: Vec<f32> = direct.reflectance.iter().flatten().copied().collect();
                let buffer = storage(
                    &self.gpu,
                    "reflectance",
                    &flat,
                    wgpu::BufferUsages::COPY_DST,
                );
                self.reflectance = Some((buffer, direct.reflectance.to_vec()));
            }
        }
        Ok(count as u32)
    }

    #[allow(clippy::too_many_arguments)]
    fn frame(
        &mut self,
        view: &View,
        radiosity: &wgpu::Buffer,
        intensities: &[V3],
        direct: Option<DirectShading<'_>>,
        decision: Decision,
        effects: Effects,
        count_rays: bool,
        (width, height): (u32, u32),
    ) -> Result<(Image, GpuRenderReport), GpuError> {
        let start = Instant::now();
        let pixels = u64::from(width) * u64::from(height);
        if pixels == 0 || pixels > 1 << 28 {
            return Err(input(format!(
                "image size {width}x{height}: need at least 1 and at most 2^28 pixels"
            ))
            .into());
        }
        let image_bytes = 16 * pixels;
        if image_bytes > self.gpu.limits.max_buffer_size {
            return Err(GpuError::Device(format!(
                "GPU: a {width}x{height} RGBA f32 image needs {image_bytes} bytes, over the \
                 {}-byte buffer limit of {}; render fewer pixels",
                self.gpu.limits.max_buffer_size,
                self.gpu.adapter_name()
            )));
        }
        let direct_count = self.upload_direct(direct)?;
        if self.tracer.scene().rays.nodes.is_empty() {
            // No triangles: every ray misses (a binding cannot be empty; nothing to trace).
            let image = Image {
                width,
                height,
                pixels: vec![[0.0; 3]; pixels as usize],
            };
            let rays = count_rays.then(|| RayCounts {
                primary: pixels,
                ..RayCounts::default()
            });
            let report = GpuRenderReport {
                decision,
                rays,
                tiles: 0,
                wall: start.elapsed(),
                gpu: None,
            };
            return Ok((image, report));
        }
        let need = 12 * u64::from(self.n);
        if radiosity.size() < need || !radiosity.usage().contains(wgpu::BufferUsages::STORAGE) {
            return Err(input(format!(
                "the radiosity buffer holds {} bytes (usage {:?}); the tracer reads {need} \
                 bytes of storage (3 f32 per element), e.g. GpuEvaluator::radiosity_buffer",
                radiosity.size(),
                radiosity.usage()
            ))
            .into());
        }
        let light_words: Vec<f32> = self
            .tracer
            .scene()
            .lights
            .iter()
            .zip(intensities)
            .flat_map(|(l, i)| {
                let [p0, p1, p2] = l.position;
                [p0, p1, p2, 0.0, i[0], i[1], i[2], 0.0]
            })
            .collect();
        if !light_words.is_empty() {
            self.gpu
                .queue
                .write_buffer(&self.lights, 0, bytes_of(&light_words));
        }
        // Smooth forced on a file without SMOOTH shades flat, as the CPU twin does.
        let smooth = effects.smooth && self.smooth.is_some();
        let pipeline = self.pipeline(TraceConstants {
            highlights: effects.highlights,
            secondary: effects.secondary,
            smooth,
            count_rays,
            direct: direct_count > 0,
        });
        let tile = u64::from(self.tile_pixels);
        let tiles = pixels.div_ceil(tile) as u32;
        let device = &self.gpu.device;
        let tile_image = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace tile"),
            size: 16 * tile,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let counts_bytes = (12 * u64::from(tiles)).max(16);
        let counts = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ray counts"),
            size: counts_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        // Two timestamps per tile (its pass's start and end), resolved after the last tile
        // and read back behind the image and the counters.
        // A query set holds at most QUERY_SET_MAX_QUERIES (4096): a frame of more than 2048
        // tiles (only with small tiles, `set_tile_pixels`) is not timed.
        let queries = (self.gpu.has(wgpu::Features::TIMESTAMP_QUERY)
            && 2 * tiles <= wgpu::QUERY_SET_MAX_QUERIES)
            .then(|| TileTimestamps::new(&self.gpu, tiles));
        let query_bytes = queries.as_ref().map_or(0, |q| q.bytes);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace readback"),
            size: image_bytes + counts_bytes + query_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = self.bind_group(radiosity, &tile_image, &counts);
        let [eye, forward, right, up] = view.frame();
        let scene = self.tracer.scene();
        let mut params = TraceParams {
            eye,
            epsilon: scene.rays.epsilon,
            forward,
            max_depth: effects.max_depth,
            right,
            light_count: scene.lights.len() as u32,
            up,
            width,
            height,
            direct_count,
            ..TraceParams::default()
        };
        if smooth && let Some((pass, _)) = &self.smooth {
            // The smooth-vertex values from this frame's radiosity, before every tile.
            let mut encoder =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            pass.encode(&self.gpu, radiosity, &mut encoder);
            self.gpu.queue.submit([encoder.finish()]);
        }
        for t in 0..tiles {
            let first = u64::from(t) * tile;
            let count = tile.min(pixels - first);
            params.first_pixel = first as u32;
            params.pixel_count = count as u32;
            params.tile = t;
            self.gpu
                .queue
                .write_buffer(&self.params, 0, &params.to_bytes());
            let mut encoder =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("trace"),
                    timestamp_writes: queries.as_ref().map(|q| q.writes(t)),
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.dispatch_workgroups((count as u32).div_ceil(TRACE_LANES), 1, 1);
            }
            encoder.copy_buffer_to_buffer(&tile_image, 0, &readback, 16 * first, 16 * count);
            if t + 1 == tiles {
                encoder.copy_buffer_to_buffer(&counts, 0, &readback, image_bytes, counts_bytes);
                if let Some(q) = &queries {
                    encoder.resolve_query_set(&q.set, 0..2 * tiles, &q.resolve, 0);
                    encoder.copy_buffer_to_buffer(
                        &q.resolve,
                        0,
                        &readback,
                        image_bytes + counts_bytes,
                        q.bytes,
                    );
                }
            }
            self.gpu.queue.submit([encoder.finish()]);
        }
        let words = read(&self.gpu, &readback)?;
        let (rgba, rest) = words.split_at(4 * pixels as usize);
        let (counted, ticks) = rest.split_at((counts_bytes / 4) as usize);
        let gpu = queries.as_ref().map(|q| q.elapsed(ticks));
        let image = Image {
            width,
            height,
            pixels: rgba.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect(),
        };
        let rays = count_rays.then(|| {
            let mut sum = RayCounts::default();
            for c in counted.chunks_exact(3).take(tiles as usize) {
                sum.primary += u64::from(c[0].to_bits());
                sum.shadow += u64::from(c[1].to_bits());
                sum.secondary += u64::from(c[2].to_bits());
            }
            sum
        });
        Ok((
            image,
            GpuRenderReport {
                decision,
                rays,
                tiles,
                wall: start.elapsed(),
                gpu,
            },
        ))
    }

    fn bind_group(
        &self,
        radiosity: &wgpu::Buffer,
        image: &wgpu::Buffer,
        counts: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let (elements, values) = match &self.smooth {
            Some((pass, faces)) => (faces, &pass.values),
            None => (&self.no_smooth, &self.no_smooth),
        };
        let reflectance = self
            .reflectance
            .as_ref()
            .map_or(&self.no_smooth, |(b, _)| b);
        let buffers: [&wgpu::Buffer; 16] = [
            &self.params,
            &self.nodes,
            &self.tris,
            &self.tri_face,
            &self.face_id,
            &self.normals,
            &self.face_material,
            &self.optics,
            &self.lights,
            radiosity,
            image,
            counts,
            elements,
            values,
            &self.direct_lights,
            reflectance,
        ];
        let entries = super::common::buffer_entries(&buffers);
        self.gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("trace"),
                layout: &self.layout,
                entries: &entries,
            })
    }
}

/// The sixteen bindings of `trace.wgsl` (`lrr_shaders::TRACE_BINDINGS`), explicit so that
/// every specialisation (whatever its overrides leave unused) shares one layout.
fn bind_group_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    super::common::bind_group_layout(&gpu.device, "trace", lrr_shaders::TRACE_BINDINGS)
}

fn shader_module(gpu: &Gpu) -> wgpu::ShaderModule {
    #[allow(unsafe_code)]
    // SAFETY: every index trace.wgsl follows was checked by `TraceScene::new` (through
    // `RayScene::new`: the BVH's children and leaf ranges, its depth against the fixed stacks,
    // the display faces' element ids; itself: the materials, light groups, the SMOOTH corners
    // of the display faces through `Reconstruction::from_parts`) and by `GpuTracer::frame`
    // (the radiosity buffer's size, the tile against the tile buffer, the counters per tile),
    // `GpuTracer::upload_direct` (the direct lights' count against their buffer, 3 f32 of
    // reflectance per element), `SmoothPass::new` (3 f32 per smooth vertex) and `GpuTracer::new`
    // (one smooth face record per display face); the argument is in the header of trace.wgsl.
    // Its loops end: the traversal visits each node at most once (children after parents) and
    // the ray tree's depth grows by one per push up to a limit of at most 16.
    unsafe {
        super::common::shader_module(&gpu.device, "trace", TRACE, gpu.options.bounds_checks)
    }
}

/// The timestamp queries of one frame: tile `t`'s pass writes entries `2 t` (start) and
/// `2 t + 1` (end).
struct TileTimestamps {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// 8 bytes per query.
    bytes: u64,
    period_ns: f32,
}

impl TileTimestamps {
    fn new(gpu: &Gpu, tiles: u32) -> Self {
        let bytes = 16 * u64::from(tiles);
        TileTimestamps {
            set: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("trace timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * tiles,
            }),
            resolve: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("trace timestamps"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            bytes,
            period_ns: gpu.queue.get_timestamp_period(),
        }
    }

    fn writes(&self, tile: u32) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(2 * tile),
            end_of_pass_write_index: Some(2 * tile + 1),
        }
    }

    /// The sum over tiles of end − start, from the resolved ticks (little-endian u64) read
    /// back among the frame's f32 words: each tick is the bits of two words.
    fn elapsed(&self, words: &[f32]) -> Duration {
        let ticks: Vec<u64> = words
            .chunks_exact(2)
            .map(|w| u64::from(w[0].to_bits()) | (u64::from(w[1].to_bits()) << 32))
            .collect();
        let sum: u64 = ticks
            .chunks_exact(2)
            .map(|t| t[1].saturating_sub(t[0]))
            .sum();
        Duration::from_nanos((sum as f64 * f64::from(self.period_ns)) as u64)
    }
}

/// Refuses a scene whose buffers do not fit one storage binding (wgpu would abort).
fn check_fits(gpu: &Gpu, buffers: &[(&str, u64)]) -> Result<(), GpuError> {
    let limit = gpu.max_binding_bytes();
    match buffers.iter().find(|(_, bytes)| *bytes > limit) {
        None => Ok(()),
        Some((name, bytes)) => Err(GpuError::Device(format!(
            "GPU: the tracer's {name} buffer needs {bytes} bytes, over the {limit}-byte limit \
             of one storage binding on {}; render this scene on the CPU (--device cpu)",
            gpu.adapter_name()
        ))),
    }
}

/// Waits for the submitted work and copies `buffer` out as f32 words.
fn read(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<Vec<f32>, GpuError> {
    super::evaluator::map(gpu, buffer)?;
    let mut out = vec![0.0f32; (buffer.size() / 4) as usize];
    {
        let view = buffer
            .get_mapped_range(..)
            .map_err(|e| GpuError::Device(format!("GPU: reading the image back: {e}")))?;
        super::common::bytes_of_mut(&mut out).copy_from_slice(&view);
    }
    buffer.unmap();
    Ok(out)
}
