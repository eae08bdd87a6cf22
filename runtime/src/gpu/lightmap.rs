//! The lightmap fill on the GPU (`lightmap.wgsl` of `lrr-shaders`): the runtime's [`Lightmap`]
//! (built once on the CPU: the samples, their weights and the dilation rings) uploaded, then
//! filled every frame from a radiosity storage buffer (the evaluator's
//! [`radiosity_buffer`](super::GpuEvaluator::radiosity_buffer)) into an `rgba16float` storage
//! texture that an application binds for sampling: no readback.
//!
//! A frame is one compute pass: smooth lightmaps first compute the smooth-vertex values
//! (`smooth.wgsl`, as the tracer does), then one dispatch writes every sample, then one per
//! dilation ring (their bindings made with the first fill from a radiosity buffer and kept
//! while fills read that buffer); each texel written holds `B/π` and alpha 1, every other texel stays zero
//! (the texture is zeroed once, when made), so alpha is the lightmap's coverage. Values are
//! those of [`Lightmap::fill`] up to f32 sums (the GPU's smooth-vertex values and samples sum
//! in f32, the CPU's in f64) and binary16 storage (2⁻¹¹ relative; up to 65504).

use lrr_formats::OperatorFile;
use lrr_shaders::{
    LIGHTMAP_ENTRY, LIGHTMAP_FILL, LIGHTMAP_FLAT, LIGHTMAP_LANES, LIGHTMAP_RING, LIGHTMAP_SMOOTH,
    LightmapParams, workgroups,
};
use std::sync::Mutex;

use wgpu::util::DeviceExt;

use super::buffers::storage;
use super::common::{GpuError, bytes_of_mut};
use super::device::Gpu;
use super::smooth::SmoothPass;
use crate::{Lightmap, LightmapValues};

/// The texture's format: half floats, filterable, a storage format of core WebGPU.
pub const LIGHTMAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// A lightmap filled on the GPU. See the module docs.
pub struct GpuLightmap {
    gpu: Gpu,
    n: usize,
    width: u32,
    height: u32,
    samples: u32,
    smooth: Option<SmoothPass>,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    texel: wgpu::Buffer,
    index: wgpu::Buffer,
    weight: wgpu::Buffer,
    values: wgpu::Buffer,
    neighbour_ends: wgpu::Buffer,
    neighbours: wgpu::Buffer,
    /// One uniform per step: the samples, then each ring.
    steps: Vec<(u32, wgpu::Buffer)>,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// The bindings of the last radiosity buffer filled from: the smooth pass's, and one per
    /// step (what [`encode`](Self::encode) would otherwise make every frame).
    bindings: Mutex<Option<Bindings>>,
}

/// [`GpuLightmap`]'s bindings for one radiosity buffer.
struct Bindings {
    radiosity: wgpu::Buffer,
    smooth: Option<wgpu::BindGroup>,
    steps: Vec<wgpu::BindGroup>,
}

impl GpuLightmap {
    /// Uploads `map`, a lightmap of `file` (made by [`Lightmap::new`] or its kin from the same
    /// file), and makes its texture. Errors when a table is over the adapter's binding limit or
    /// the atlas over its texture limit.
    pub fn new(gpu: &Gpu, file: &OperatorFile, map: &Lightmap) -> Result<Self, GpuError> {
        let (width, height) = (map.width as u32, map.height as u32);
        let side = gpu.limits.max_texture_dimension_2d;
        if width > side || height > side {
            return Err(GpuError::Device(format!(
                "GPU: a {width}×{height} lightmap is over the {side}-texel texture limit of {}",
                gpu.adapter_name()
            )));
        }
        let (mut texel, index, weight) = map.sample_table();
        let samples = texel.len();
        let compact = samples + map.dilated.len();
        let limit = gpu.max_binding_bytes();
        for (name, bytes) in [
            ("texel", 4 * compact),
            ("index", 4 * index.len()),
            ("weight", 4 * weight.len()),
            ("values", 12 * compact),
            ("neighbours", 4 * map.neighbours.len()),
        ] {
            if bytes as u64 > limit {
                return Err(GpuError::Device(format!(
                    "GPU: the lightmap's {name} table needs {bytes} bytes, over the {limit}-byte \
                     limit of one storage binding on {}; fill it on the CPU (Lightmap::fill)",
                    gpu.adapter_name()
                )));
            }
        }
        // Compact ids: samples, then the dilated texels; the neighbours named by compact id.
        let mut compact_of = std::collections::HashMap::with_capacity(compact);
        texel.extend(&map.dilated);
        for (i, &t) in texel.iter().enumerate() {
            compact_of.insert(t, i as u32);
        }
        let neighbours: Vec<u32> = map.neighbours.iter().map(|t| compact_of[t]).collect();
        let smooth = match map.values {
            LightmapValues::Smooth => {
                let s = file.display.smooth.as_ref().ok_or_else(|| {
                    GpuError::Runtime(crate::error::input(
                        "a smooth lightmap of a file without SMOOTH: make both from one file",
                    ))
                })?;
                // The same checks as the CPU's, so that the pass indexes nothing out of range.
                crate::Reconstruction::new(file)?;
                Some(SmoothPass::new(gpu, s, &file.order))
            }
            LightmapValues::Flat => None,
        };
        let none = wgpu::BufferUsages::empty();
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(LIGHTMAP_ENTRY),
            source: wgpu::ShaderSource::Wgsl(LIGHTMAP_FILL.into()),
        });
        let layout = super::common::bind_group_layout(
            device,
            LIGHTMAP_ENTRY,
            lrr_shaders::LIGHTMAP_BINDINGS,
        );
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(LIGHTMAP_ENTRY),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(LIGHTMAP_ENTRY),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some(LIGHTMAP_ENTRY),
            compilation_options: wgpu::PipelineCompilationOptions::default(),
            cache: None,
        });
        let uniform = |p: LightmapParams| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("lightmap params"),
                contents: &p.to_bytes(),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        let mode = match map.values {
            LightmapValues::Smooth => LIGHTMAP_SMOOTH,
            LightmapValues::Flat => LIGHTMAP_FLAT,
        };
        let mut steps = vec![(
            samples as u32,
            uniform(LightmapParams {
                count: samples as u32,
                first: 0,
                width,
                mode,
                samples: samples as u32,
                ..LightmapParams::default()
            }),
        )];
        let mut begin = 0usize;
        for &end in &map.ring_ends {
            let count = (end as usize - begin) as u32;
            steps.push((
                count,
                uniform(LightmapParams {
                    count,
                    first: (samples + begin) as u32,
                    width,
                    mode: LIGHTMAP_RING,
                    samples: samples as u32,
                    ..LightmapParams::default()
                }),
            ));
            begin = end as usize;
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("lightmap"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: LIGHTMAP_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        Ok(Self {
            gpu: gpu.clone(),
            n: file.n as usize,
            width,
            height,
            samples: samples as u32,
            smooth,
            pipeline,
            layout,
            texel: storage(gpu, "lightmap texels", &texel, none),
            index: storage(gpu, "lightmap indices", &index, none),
            weight: storage(gpu, "lightmap weights", &weight, none),
            values: storage(gpu, "lightmap values", &vec![0.0f32; 3 * compact], none),
            neighbour_ends: storage(gpu, "lightmap rings", &map.neighbour_ends, none),
            neighbours: storage(gpu, "lightmap neighbours", &neighbours, none),
            steps,
            texture,
            view,
            bindings: Mutex::new(None),
        })
    }

    /// The texture the fill writes: `rgba16float`, usage `STORAGE_BINDING | TEXTURE_BINDING |
    /// COPY_SRC`; bind it for sampling on the same device ([`Gpu::device`]). Work submitted
    /// after a fill sees its texels.
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Width and height in texels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Records a fill from `radiosity` (3 f32 per element, original ids: the evaluator's
    /// radiosity buffer) into `encoder`. An error when the buffer is too small.
    pub fn encode(
        &self,
        radiosity: &wgpu::Buffer,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<(), GpuError> {
        self.encode_timed(radiosity, encoder, None)
    }

    /// GPU times of `fills` fills (1 to 128) from `radiosity` recorded back to back, each
    /// timed by its own timestamp queries around its compute pass, after 0.3 s of untimed fills
    /// (a GPU idling at low clocks raises them under load); `None` without `TIMESTAMP_QUERY`.
    /// For benchmarks: what the fill adds to a frame on the GPU itself, without the host's
    /// submission.
    pub fn burst(
        &self,
        radiosity: &wgpu::Buffer,
        fills: usize,
    ) -> Result<Option<Vec<std::time::Duration>>, GpuError> {
        use super::evaluator::{BURST_PAIRS, WARM_UP, timestamps};
        if !self.gpu.has(wgpu::Features::TIMESTAMP_QUERY) {
            return Ok(None);
        }
        let fills = fills.clamp(1, BURST_PAIRS as usize) as u32;
        let t = timestamps(&self.gpu);
        let warm = std::time::Instant::now();
        while warm.elapsed() < WARM_UP {
            for _ in 0..32 {
                self.fill(radiosity)?;
            }
            self.gpu.wait()?;
        }
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        for i in 0..fills {
            self.encode_timed(radiosity, &mut encoder, Some(t.writes(i)))?;
        }
        t.resolve(&mut encoder, fills);
        self.gpu.queue.submit([encoder.finish()]);
        Ok(Some(t.read_pairs(&self.gpu, fills as usize)?))
    }

    /// [`encode`](Self::encode), its compute pass timed by `timestamps` when given.
    fn encode_timed(
        &self,
        radiosity: &wgpu::Buffer,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) -> Result<(), GpuError> {
        let need = 12 * self.n as u64;
        if radiosity.size() < need {
            return Err(GpuError::Runtime(crate::error::input(format!(
                "the lightmap's radiosity buffer holds {} bytes, not the 12 × {} elements = \
                 {need} it needs",
                radiosity.size(),
                self.n
            ))));
        }
        let mut bindings = self.bindings.lock().unwrap_or_else(|e| e.into_inner());
        if bindings.as_ref().is_none_or(|b| b.radiosity != *radiosity) {
            *bindings = Some(self.bindings(radiosity));
        }
        let b = bindings.as_ref().expect("made above");
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(LIGHTMAP_ENTRY),
            timestamp_writes: timestamps,
        });
        if let (Some(smooth), Some(group)) = (&self.smooth, &b.smooth) {
            smooth.dispatch(&mut pass, group);
        }
        pass.set_pipeline(&self.pipeline);
        for ((count, _), group) in self.steps.iter().zip(&b.steps) {
            if *count == 0 {
                continue;
            }
            pass.set_bind_group(0, group, &[]);
            let [x, y, z] = workgroups(count.div_ceil(LIGHTMAP_LANES));
            pass.dispatch_workgroups(x, y, z);
        }
        Ok(())
    }

    /// The bindings of the smooth pass and of every step, reading `radiosity`.
    fn bindings(&self, radiosity: &wgpu::Buffer) -> Bindings {
        let smooth = (self.smooth.as_ref()).map(|pass| pass.bind_group(&self.gpu, radiosity));
        let table = match &self.smooth {
            Some(pass) => &pass.values,
            None => radiosity,
        };
        let steps = (self.steps.iter())
            .map(|(_, params)| {
                let buffers = [
                    params,
                    &self.texel,
                    &self.index,
                    &self.weight,
                    table,
                    &self.values,
                    &self.neighbour_ends,
                    &self.neighbours,
                ];
                let mut entries = super::common::buffer_entries(&buffers);
                entries.push(wgpu::BindGroupEntry {
                    binding: 8,
                    resource: wgpu::BindingResource::TextureView(&self.view),
                });
                self.gpu
                    .device
                    .create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some(LIGHTMAP_ENTRY),
                        layout: &self.layout,
                        entries: &entries,
                    })
            })
            .collect();
        Bindings {
            radiosity: radiosity.clone(),
            smooth,
            steps,
        }
    }

    /// Submits a fill from `radiosity` (see [`encode`](Self::encode)); returns once submitted.
    pub fn fill(&self, radiosity: &wgpu::Buffer) -> Result<(), GpuError> {
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("lightmap fill"),
            });
        self.encode(radiosity, &mut encoder)?;
        self.gpu.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Waits for the submitted work and reads the texture back as RGBA f32, rows top to bottom
    /// (for tests and tools; an engine samples the texture instead).
    pub fn read_texels(&self) -> Result<Vec<[f32; 4]>, GpuError> {
        let row = (8 * self.width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let staging = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("lightmap readback"),
            size: u64::from(row) * u64::from(self.height),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            self.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
        self.gpu.queue.submit([encoder.finish()]);
        super::evaluator::map(&self.gpu, &staging)?;
        let mut words = vec![0.0f32; (row / 4 * self.height) as usize];
        {
            let view = staging
                .get_mapped_range(..)
                .map_err(|e| GpuError::Device(format!("GPU: reading the lightmap back: {e}")))?;
            bytes_of_mut(&mut words).copy_from_slice(&view);
        }
        staging.unmap();
        let mut out = Vec::with_capacity((self.width * self.height) as usize);
        for y in 0..self.height as usize {
            let line = &words[y * (row / 4) as usize..];
            for x in 0..self.width as usize {
                let bits = |c: usize| {
                    let word = line[2 * x + c / 2].to_bits();
                    let half = if c.is_multiple_of(2) {
                        word & 0xffff
                    } else {
                        word >> 16
                    };
                    lrr_formats::f16_to_f32(half as u16)
                };
                out.push([bits(0), bits(1), bits(2), bits(3)]);
            }
        }
        Ok(out)
    }

    /// Samples the fill writes (texels a face covers).
    pub fn sample_count(&self) -> u32 {
        self.samples
    }
}
