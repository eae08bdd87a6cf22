//! The lightmap fill on the GPU (`lightmap_tiles.wgsl` or `lightmap.wgsl` of `lrr-shaders`):
//! the runtime's [`Lightmap`]
//! (built once on the CPU: the samples, their weights and the dilation rings) uploaded, then
//! filled every frame from a radiosity storage buffer (the evaluator's
//! [`radiosity_buffer`](super::GpuEvaluator::radiosity_buffer)) into an `rgba16float` storage
//! texture that an application binds for sampling: no readback.
//!
//! A frame is one compute pass, its bindings made with the first fill from a radiosity buffer
//! and kept while fills read that buffer. Two ways to fill ([`GpuFill`]):
//! - **Tiles** (smooth lightmaps, the default where it applies): one dispatch,
//!   `lightmap_tiles.wgsl`. The texels are cut at upload into tiles, the texels of a 16 × 8
//!   block of the atlas that read at most 256 smooth vertices ([`Lightmap::gpu_tiles`]); each
//!   tile's workgroup computes its vertices in its own memory, then writes its texels.
//! - **Passes**: smooth lightmaps first compute every smooth-vertex value (`smooth.wgsl`, as
//!   the tracer does), then one dispatch of `lightmap.wgsl` writes every sample and every
//!   dilated texel (each ring texel expanded once, at upload, into the sources its neighbours
//!   read: [`Lightmap::gpu_table`]). Flat lightmaps take this dispatch alone, and smooth ones
//!   whose dilated texels read over 256 vertices (a padding far wider than the bake's) take
//!   both.
//!
//! Each texel written holds `B/π` and alpha 1, every other texel stays zero (the texture is
//! zeroed once, when made), so alpha is the lightmap's coverage. Values are those of
//! [`Lightmap::fill`] up to the texture's binary16 (2⁻¹⁰ relative: Vulkan lets an
//! implementation round toward zero, and lavapipe and the H200's driver do; up to 65504) and
//! f32 sums where the CPU sums in f64.

use lrr_formats::OperatorFile;
use lrr_shaders::{
    LIGHTMAP_ENTRY, LIGHTMAP_FILL, LIGHTMAP_FLAT, LIGHTMAP_LANES, LIGHTMAP_SMOOTH, LIGHTMAP_TILES,
    LightmapParams, TILES_ENTRY, TileParams, workgroups,
};
use std::sync::Mutex;

use wgpu::util::DeviceExt;

use super::buffers::storage;
use super::common::{GpuError, bytes_of_mut};
use super::device::Gpu;
use super::smooth::SmoothPass;
use crate::lightmap::TileTable;
use crate::{Lightmap, LightmapValues};

/// The texture's format: half floats, filterable, a storage format of core WebGPU.
pub const LIGHTMAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// How a [`GpuLightmap`] fills (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GpuFill {
    /// Tiles where the lightmap allows them, else passes.
    Auto,
    /// One dispatch, each tile's smooth vertices in its workgroup's memory (smooth lightmaps
    /// whose texels each read at most 256 smooth vertices).
    Tiles,
    /// The smooth-vertex pass (smooth lightmaps), then the texels' dispatch.
    Passes,
}

/// A lightmap filled on the GPU. See the module docs.
pub struct GpuLightmap {
    gpu: Gpu,
    n: usize,
    width: u32,
    height: u32,
    samples: u32,
    how: How,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    /// The bindings of the last radiosity buffer filled from (what
    /// [`encode`](Self::encode) would otherwise make every frame).
    bindings: Mutex<Option<Bindings>>,
}

/// A [`GpuLightmap`]'s pipelines and tables, by [`GpuFill`].
enum How {
    Passes {
        smooth: Option<SmoothPass>,
        pipeline: wgpu::ComputePipeline,
        layout: wgpu::BindGroupLayout,
        /// Invocations of the fill's dispatch: samples and dilated texels.
        count: u32,
        params: wgpu::Buffer,
        /// `lightmap.wgsl`'s tables ([`GpuTable`](crate::lightmap::GpuTable)): samples,
        /// run_base, run_index, rings, ring_source, ring_weight.
        tables: [wgpu::Buffer; 6],
    },
    Tiles {
        pipeline: wgpu::ComputePipeline,
        layout: wgpu::BindGroupLayout,
        tiles: u32,
        counts: TileCounts,
        params: wgpu::Buffer,
        /// `lightmap_tiles.wgsl`'s tables ([`TileTable`](crate::lightmap::TileTable)): tiles,
        /// tile_vertices, entries, items, slots, terms.
        tables: [wgpu::Buffer; 6],
    },
}

/// What a [`GpuLightmap`] that fills in tiles computes ([`GpuLightmap::tile_counts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileCounts {
    /// Tiles: workgroups of a fill.
    pub tiles: u32,
    /// Smooth vertices computed in a fill, over all tiles (a vertex read by several tiles is
    /// counted in each).
    pub vertices: u32,
    /// Smooth vertices in the file.
    pub smooth_vertices: u32,
    /// The most vertices one tile computes.
    pub largest: u32,
}

/// [`GpuLightmap`]'s bindings for one radiosity buffer.
struct Bindings {
    radiosity: wgpu::Buffer,
    /// The smooth pass's (passes, smooth).
    smooth: Option<wgpu::BindGroup>,
    fill: wgpu::BindGroup,
}

impl GpuLightmap {
    /// Uploads `map`, a lightmap of `file` (made by [`Lightmap::new`] or its kin from the same
    /// file), and makes its texture; fills in tiles where the lightmap allows them
    /// ([`GpuFill::Auto`]). Errors when a table is over the adapter's binding limit or the
    /// atlas over its texture limit.
    pub fn new(gpu: &Gpu, file: &OperatorFile, map: &Lightmap) -> Result<Self, GpuError> {
        Self::with_fill(gpu, file, map, GpuFill::Auto)
    }

    /// [`new`](Self::new) with the way to fill chosen: an error for [`GpuFill::Tiles`] when
    /// the lightmap is flat or a texel reads over 256 smooth vertices.
    pub fn with_fill(
        gpu: &Gpu,
        file: &OperatorFile,
        map: &Lightmap,
        fill: GpuFill,
    ) -> Result<Self, GpuError> {
        let (width, height) = (map.width as u32, map.height as u32);
        let side = gpu.limits.max_texture_dimension_2d;
        if width > side || height > side {
            return Err(GpuError::Device(format!(
                "GPU: a {width}×{height} lightmap is over the {side}-texel texture limit of {}",
                gpu.adapter_name()
            )));
        }
        if map.values == LightmapValues::Smooth {
            if file.display.smooth.is_none() {
                return Err(GpuError::Runtime(crate::error::input(
                    "a smooth lightmap of a file without SMOOTH: make both from one file",
                )));
            }
            // The same checks as the CPU's, so that no pass indexes out of range.
            crate::Reconstruction::new(file)?;
        }
        let tiles = match fill {
            GpuFill::Passes => None,
            GpuFill::Auto | GpuFill::Tiles => map.gpu_tiles(),
        };
        let how = match tiles {
            Some(t) if fill == GpuFill::Tiles => Self::tiles(gpu, map, &t)?,
            // A tile table over a binding can still fit as passes (its ring terms take 8
            // bytes where the passes' take 4 and 4 in two tables).
            Some(t) => match Self::tiles(gpu, map, &t) {
                Ok(how) => how,
                Err(_) => Self::passes(gpu, file, map)?,
            },
            None if fill == GpuFill::Tiles => {
                return Err(GpuError::Runtime(crate::error::input(
                    "the lightmap cannot be filled in tiles: it is flat, or one of its texels \
                     reads over 256 smooth vertices (a padding far wider than a bake's); fill \
                     it in passes (GpuFill::Passes or Auto)",
                )));
            }
            None => Self::passes(gpu, file, map)?,
        };
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
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
            samples: map.sample_count() as u32,
            how,
            texture,
            view,
            bindings: Mutex::new(None),
        })
    }

    /// How this lightmap fills: [`GpuFill::Tiles`] or [`GpuFill::Passes`].
    pub fn fill_kind(&self) -> GpuFill {
        match self.how {
            How::Passes { .. } => GpuFill::Passes,
            How::Tiles { .. } => GpuFill::Tiles,
        }
    }

    /// What a fill in tiles computes; `None` when filling in passes.
    pub fn tile_counts(&self) -> Option<TileCounts> {
        match self.how {
            How::Passes { .. } => None,
            How::Tiles { counts, .. } => Some(counts),
        }
    }

    /// The smooth pass and `lightmap.wgsl`'s tables.
    fn passes(gpu: &Gpu, file: &OperatorFile, map: &Lightmap) -> Result<How, GpuError> {
        let table = map.gpu_table();
        let samples = map.sample_count();
        let count = samples + map.dilated_count();
        let smooth = match (map.values, file.display.smooth.as_ref()) {
            (LightmapValues::Smooth, Some(s)) => Some(s),
            _ => None,
        };
        let rows = smooth.map_or([0; 3], |s| {
            [s.offsets.len(), s.positions.len(), 3 * s.vertex_count()]
        });
        check_sizes(
            gpu,
            "fill it on the CPU (Lightmap::fill)",
            &[
                ("sample", table.samples.len()),
                ("run base", table.run_base.len()),
                ("run source", table.run_index.len()),
                ("ring", table.rings.len()),
                ("ring source", table.ring_source.len()),
                ("ring weight", table.ring_weight.len()),
                ("smooth row", rows[0]),
                ("smooth weight", rows[1]),
                ("smooth vertex value", rows[2]),
            ],
        )?;
        let smooth = smooth.map(|s| SmoothPass::new(gpu, s, &file.order));
        let (pipeline, layout) = pipeline(
            gpu,
            LIGHTMAP_ENTRY,
            LIGHTMAP_FILL,
            lrr_shaders::LIGHTMAP_BINDINGS,
        );
        let mode = match map.values {
            LightmapValues::Smooth => LIGHTMAP_SMOOTH,
            LightmapValues::Flat => LIGHTMAP_FLAT,
        };
        let params = uniform(
            gpu,
            "lightmap params",
            &LightmapParams {
                samples: samples as u32,
                count: count as u32,
                width: map.width as u32,
                mode,
                ..LightmapParams::default()
            }
            .to_bytes(),
        );
        let none = wgpu::BufferUsages::empty();
        Ok(How::Passes {
            smooth,
            pipeline,
            layout,
            count: count as u32,
            params,
            tables: [
                storage(gpu, "lightmap samples", &table.samples, none),
                storage(gpu, "lightmap run bases", &table.run_base, none),
                storage(gpu, "lightmap run sources", &table.run_index, none),
                storage(gpu, "lightmap rings", &table.rings, none),
                storage(gpu, "lightmap ring sources", &table.ring_source, none),
                storage(gpu, "lightmap ring weights", &table.ring_weight, none),
            ],
        })
    }

    /// `lightmap_tiles.wgsl`'s pipeline and tables.
    fn tiles(gpu: &Gpu, map: &Lightmap, t: &TileTable) -> Result<How, GpuError> {
        check_sizes(
            gpu,
            "fill it in passes (GpuFill::Passes or Auto) or on the CPU (Lightmap::fill)",
            &[
                ("tile", t.tiles.len()),
                ("tile vertex", t.tile_vertices.len()),
                ("smooth weight", t.entries.len()),
                ("texel", t.items.len()),
                ("texel slot", t.slots.len()),
                ("ring term", t.terms.len()),
            ],
        )?;
        let (pipeline, layout) = pipeline(
            gpu,
            TILES_ENTRY,
            LIGHTMAP_TILES,
            lrr_shaders::TILES_BINDINGS,
        );
        let tiles = (t.tiles.len() / 2 - 1) as u32;
        let params = uniform(
            gpu,
            "lightmap tile params",
            &TileParams {
                width: map.width as u32,
                tiles,
                ..TileParams::default()
            }
            .to_bytes(),
        );
        let counts = TileCounts {
            tiles,
            vertices: (t.tile_vertices.len() / 2) as u32,
            smooth_vertices: map.smooth_vertex_count() as u32,
            largest: (t.tiles.windows(4).step_by(2))
                .map(|w| w[3] - w[1])
                .max()
                .unwrap_or(0),
        };
        let none = wgpu::BufferUsages::empty();
        Ok(How::Tiles {
            pipeline,
            layout,
            tiles,
            counts,
            params,
            tables: [
                storage(gpu, "lightmap tiles", &t.tiles, none),
                storage(gpu, "lightmap tile vertices", &t.tile_vertices, none),
                storage(gpu, "lightmap smooth weights", &t.entries, none),
                storage(gpu, "lightmap texels", &t.items, none),
                storage(gpu, "lightmap texel slots", &t.slots, none),
                storage(gpu, "lightmap ring terms", &t.terms, none),
            ],
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
        match &self.how {
            How::Passes {
                smooth,
                pipeline,
                count,
                ..
            } => {
                if let (Some(smooth), Some(group)) = (smooth, &b.smooth) {
                    smooth.dispatch(&mut pass, group);
                }
                if *count > 0 {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &b.fill, &[]);
                    let [x, y, z] = workgroups(count.div_ceil(LIGHTMAP_LANES));
                    pass.dispatch_workgroups(x, y, z);
                }
            }
            How::Tiles {
                pipeline, tiles, ..
            } => {
                if *tiles > 0 {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, &b.fill, &[]);
                    let [x, y, z] = workgroups(*tiles);
                    pass.dispatch_workgroups(x, y, z);
                }
            }
        }
        Ok(())
    }

    /// The bindings of the fill (and of the smooth pass), reading `radiosity`.
    fn bindings(&self, radiosity: &wgpu::Buffer) -> Bindings {
        let (layout, smooth, buffers) = match &self.how {
            How::Passes {
                smooth,
                layout,
                params,
                tables: t,
                ..
            } => {
                let group = smooth
                    .as_ref()
                    .map(|pass| pass.bind_group(&self.gpu, radiosity));
                let table = smooth.as_ref().map_or(radiosity, |pass| &pass.values);
                let buffers = vec![params, &t[0], &t[1], &t[2], &t[3], &t[4], &t[5], table];
                (layout, group, buffers)
            }
            How::Tiles {
                layout,
                params,
                tables: t,
                ..
            } => {
                let buffers = vec![params, &t[0], &t[1], &t[2], radiosity, &t[3], &t[4], &t[5]];
                (layout, None, buffers)
            }
        };
        let mut entries = super::common::buffer_entries(&buffers);
        entries.push(wgpu::BindGroupEntry {
            binding: buffers.len() as u32,
            resource: wgpu::BindingResource::TextureView(&self.view),
        });
        let fill = self
            .gpu
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(LIGHTMAP_ENTRY),
                layout,
                entries: &entries,
            });
        Bindings {
            radiosity: radiosity.clone(),
            smooth,
            fill,
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

/// An error, with `advice`, when a table of `words` u32 words is over one storage binding of
/// `gpu`.
fn check_sizes(gpu: &Gpu, advice: &str, tables: &[(&str, usize)]) -> Result<(), GpuError> {
    let limit = (gpu.options.max_table_bytes).map_or(gpu.max_binding_bytes(), |cap| {
        cap.min(gpu.max_binding_bytes())
    });
    for &(name, words) in tables {
        let bytes = 4 * words;
        if bytes as u64 > limit {
            return Err(GpuError::Device(format!(
                "GPU: the lightmap's {name} table needs {bytes} bytes, over the {limit}-byte \
                 limit of one storage binding on {}; {advice}",
                gpu.adapter_name()
            )));
        }
    }
    Ok(())
}

/// A compute pipeline of a self-contained WGSL pass (checked by naga) and its explicit
/// bindings.
fn pipeline(
    gpu: &Gpu,
    entry: &'static str,
    source: &'static str,
    bindings: &[lrr_shaders::Binding],
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let module = gpu
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(entry),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    super::common::compute_pipeline(&gpu.device, entry, &module, bindings)
}

/// A uniform buffer holding `bytes`.
fn uniform(gpu: &Gpu, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        })
}
