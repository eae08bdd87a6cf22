//! Drawing the relit scene the way an engine does: the file's display triangles rasterised with
//! their lightmap coordinates, each pixel the lightmap texture (`GpuLightmap`, filled every frame)
//! sampled bilinearly, times the exposure. Back faces are culled (display faces wind
//! counter-clockwise around their normal), so the two sides of a thin wall never fight.

use std::collections::HashMap;

use anyhow::{Result, bail};
use lrr_formats::OperatorFile;
use lrr_runtime::gpu::{Gpu, wgpu};
use wgpu::util::DeviceExt;

/// The depth buffer's format.
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

const SHADER: &str = r#"
struct Frame {
    view_proj: mat4x4<f32>,
    // x: the factor on the lightmap's B/pi; yzw: unused.
    exposure: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var lightmap: texture_2d<f32>;
@group(0) @binding(2) var linear: sampler;

struct Out {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) uv: vec2<f32>) -> Out {
    var out: Out;
    out.clip = frame.view_proj * vec4<f32>(position, 1.0);
    out.uv = uv;
    return out;
}

@fragment
fn fs(in: Out) -> @location(0) vec4<f32> {
    let radiance = textureSample(lightmap, linear, in.uv).rgb;
    return vec4<f32>(radiance * frame.exposure.x, 1.0);
}
"#;

/// A pinhole camera, as the file's cameras and `lrr render` take it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eye {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
    pub fov_y_deg: f32,
}

impl Eye {
    /// The view-projection matrix (column-major, wgpu's clip space: depth 0 to 1) for an image
    /// of `aspect` = width / height, between `near` and `far`: the rays of `lrr render`'s
    /// pinhole camera through pixel centres are the pixel centres here.
    pub fn view_proj(&self, aspect: f32, near: f32, far: f32) -> [[f32; 4]; 4] {
        let f = normalize(sub(self.target, self.eye));
        let r = normalize(cross(f, self.up));
        let u = cross(r, f);
        let e = self.eye;
        // Rows of the view matrix: right, up, -forward; translation by -eye.
        let view = [
            [r[0], u[0], -f[0], 0.0],
            [r[1], u[1], -f[1], 0.0],
            [r[2], u[2], -f[2], 0.0],
            [-dot(r, e), -dot(u, e), dot(f, e), 1.0],
        ];
        let t = 1.0 / (0.5 * self.fov_y_deg.to_radians()).tan();
        let proj = [
            [t / aspect, 0.0, 0.0, 0.0],
            [0.0, t, 0.0, 0.0],
            [0.0, 0.0, far / (near - far), -1.0],
            [0.0, 0.0, near * far / (near - far), 0.0],
        ];
        mul(proj, view)
    }
}

pub(super) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(super) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(super) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = dot(a, a).sqrt().max(f32::MIN_POSITIVE);
    [a[0] / l, a[1] / l, a[2] / l]
}

/// `a · b` of column-major 4×4 matrices.
fn mul(a: [[f32; 4]; 4], b: [[f32; 4]; 4]) -> [[f32; 4]; 4] {
    let mut out = [[0.0; 4]; 4];
    for (c, column) in out.iter_mut().enumerate() {
        for (r, v) in column.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[k][r] * b[c][k]).sum();
        }
    }
    out
}

/// A 2D texture of one mip level and one sample.
pub(super) fn texture(
    gpu: &Gpu,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    gpu.device().create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// The display triangles with their lightmap coordinates, uploaded once, and a pipeline per
/// target format.
pub struct Scene {
    vertices: wgpu::Buffer,
    count: u32,
    /// The scene's bounding box, for the camera's near and far planes and a default camera.
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    pipelines: HashMap<wgpu::TextureFormat, wgpu::RenderPipeline>,
    uniform: wgpu::Buffer,
    group: wgpu::BindGroup,
    depth: Option<(u32, u32, wgpu::TextureView)>,
}

impl Scene {
    /// The fan triangles of `file`'s display faces with their lightmap coordinates (section
    /// LIGHTMAP), drawn with `lightmap` (the `GpuLightmap`'s texture).
    pub fn new(gpu: &Gpu, file: &OperatorFile, lightmap: &wgpu::Texture) -> Result<Self> {
        let Some(uv) = file.display.lightmap.as_ref() else {
            bail!(
                "the file has no lightmap coordinates (section LIGHTMAP): re-bake it with this lrr"
            );
        };
        let g = file.faces().geometry;
        let mut data: Vec<f32> = Vec::new();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for f in 0..g.len() {
            let count = usize::from(g.vertex_count[f]);
            let corner = |c: usize| {
                let p = g.vertex(f, c);
                [
                    p[0],
                    p[1],
                    p[2],
                    uv.uv[8 * f + 2 * c],
                    uv.uv[8 * f + 2 * c + 1],
                ]
            };
            for c in 0..count {
                let p = g.vertex(f, c);
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            for c in 1..count.saturating_sub(1) {
                for k in [0, c, c + 1] {
                    data.extend(corner(k));
                }
            }
        }
        if data.is_empty() {
            bail!("the file has no display faces to draw");
        }
        let device = gpu.device();
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("view vertices"),
            contents: &data
                .iter()
                .flat_map(|x| x.to_le_bytes())
                .collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view frame"),
            size: 80,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("lightmap"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            ..Default::default()
        });
        let view = lightmap.create_view(&wgpu::TextureViewDescriptor::default());
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("view"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("view"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("view"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        Ok(Self {
            vertices,
            count: (data.len() / 5) as u32,
            lo,
            hi,
            pipeline_layout,
            module,
            pipelines: HashMap::new(),
            uniform,
            group,
            depth: None,
        })
    }

    /// The diagonal of the scene's bounding box.
    pub fn diagonal(&self) -> f32 {
        dot(sub(self.hi, self.lo), sub(self.hi, self.lo)).sqrt()
    }

    /// A camera that frames the whole scene, for files without cameras.
    pub fn framing(&self) -> Eye {
        let c = [0, 1, 2].map(|k| 0.5 * (self.lo[k] + self.hi[k]));
        let d = self.diagonal().max(f32::MIN_POSITIVE);
        Eye {
            eye: [c[0] + 0.3 * d, c[1] + 0.4 * d, c[2] + 1.1 * d],
            target: c,
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 45.0,
        }
    }

    fn pipeline(&mut self, gpu: &Gpu, format: wgpu::TextureFormat) -> &wgpu::RenderPipeline {
        let (layout, module) = (&self.pipeline_layout, &self.module);
        self.pipelines.entry(format).or_insert_with(|| {
            gpu.device()
                .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("view"),
                    layout: Some(layout),
                    vertex: wgpu::VertexState {
                        module,
                        entry_point: Some("vs"),
                        compilation_options: Default::default(),
                        buffers: &[Some(wgpu::VertexBufferLayout {
                            array_stride: 20,
                            step_mode: wgpu::VertexStepMode::Vertex,
                            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2],
                        })],
                    },
                    primitive: wgpu::PrimitiveState {
                        topology: wgpu::PrimitiveTopology::TriangleList,
                        front_face: wgpu::FrontFace::Ccw,
                        cull_mode: Some(wgpu::Face::Back),
                        ..Default::default()
                    },
                    depth_stencil: Some(wgpu::DepthStencilState {
                        format: DEPTH,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(wgpu::CompareFunction::Less),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState {
                        module,
                        entry_point: Some("fs"),
                        compilation_options: Default::default(),
                        targets: &[Some(wgpu::ColorTargetState {
                            format,
                            blend: None,
                            write_mask: wgpu::ColorWrites::ALL,
                        })],
                    }),
                    multiview_mask: None,
                    cache: None,
                })
        })
    }

    /// Records the scene drawn from `eye` at `exposure` into `target` (`width × height`, of
    /// `format`), cleared to black first.
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        (width, height): (u32, u32),
        eye: &Eye,
        exposure: f32,
    ) {
        let d = self.diagonal().max(f32::MIN_POSITIVE);
        let dist = dot(sub(eye.eye, eye.target), sub(eye.eye, eye.target)).sqrt();
        let m = eye.view_proj(width as f32 / height as f32, 1e-3 * d, 4.0 * d + 2.0 * dist);
        let mut bytes: Vec<u8> = m.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        for x in [exposure, 0.0, 0.0, 0.0] {
            bytes.extend(x.to_le_bytes());
        }
        gpu.queue().write_buffer(&self.uniform, 0, &bytes);
        if self
            .depth
            .as_ref()
            .is_none_or(|(w, h, _)| (*w, *h) != (width, height))
        {
            let texture = texture(
                gpu,
                "view depth",
                (width, height),
                DEPTH,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            );
            let view = texture.create_view(&Default::default());
            self.depth = Some((width, height, view));
        }
        self.pipeline(gpu, format);
        let pipeline = &self.pipelines[&format];
        let depth = &self.depth.as_ref().expect("made above").2;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.draw(0..self.count, 0..1);
    }
}
