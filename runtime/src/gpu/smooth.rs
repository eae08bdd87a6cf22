//! The smooth reconstruction's per-frame step on the GPU (`smooth.wgsl` of `lrr-shaders`): each
//! smooth vertex's value from a radiosity storage buffer, left in [`SmoothPass::values`] for the
//! lightmap fill's smooth samples and the tracer's `SMOOTH` variant, with no readback. The twin
//! of [`Reconstruction::vertex_values`](crate::Reconstruction::vertex_values) (f64 sums; this
//! pass and its mirror `lrr_shaders::cpu::smooth_vertices` sum in f32).
//!
//! Built by [`GpuLightmap`](super::GpuLightmap) and (feature `trace`) the `GpuTracer` from a
//! checked file: SMOOTH's offsets, positions and weights and the file's order (the tracer
//! uploads its own per display face records, what `trace.wgsl` reads at a hit). Every index the
//! pass follows was checked by `Reconstruction::from_parts` when its maker checked the file.

use lrr_formats::Smooth;
use lrr_shaders::{SMOOTH_ENTRY, SMOOTH_LANES, SMOOTH_VERTICES, SmoothParams, workgroups};

use super::buffers::storage;
use super::device::Gpu;

/// The pass and its buffers.
pub(super) struct SmoothPass {
    vertex_count: u32,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    offsets: wgpu::Buffer,
    /// Per weight, its element's original id (SMOOTH's position mapped through the order).
    elements: wgpu::Buffer,
    weights: wgpu::Buffer,
    /// This frame's smooth-vertex values, 3 f32 each (binding `vertex_values` of the tracer and
    /// of the lightmap fill).
    pub values: wgpu::Buffer,
}

impl SmoothPass {
    /// Uploads the reconstruction of a checked file: `smooth` as `Reconstruction::from_parts`
    /// accepted it, `element_id` the file's order.
    pub(super) fn new(gpu: &Gpu, smooth: &Smooth, element_id: &[u32]) -> Self {
        let none = wgpu::BufferUsages::empty();
        let vertex_count = smooth.vertex_count() as u32;
        // One load fewer per weight in the pass: the element's original id, not its position.
        let elements: Vec<u32> = (smooth.positions.iter())
            .map(|&p| element_id[p as usize])
            .collect();
        let device = &gpu.device;
        let (pipeline, layout) = super::common::compute_pipeline(
            device,
            SMOOTH_ENTRY,
            &shader_module(gpu),
            lrr_shaders::SMOOTH_BINDINGS,
        );
        let params = SmoothParams {
            vertex_count,
            ..SmoothParams::default()
        };
        let params = {
            use wgpu::util::DeviceExt;
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("smooth params"),
                contents: &params.to_bytes(),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        SmoothPass {
            vertex_count,
            pipeline,
            params,
            offsets: storage(gpu, "smooth offsets", &smooth.offsets, none),
            elements: storage(gpu, "smooth elements", &elements, none),
            weights: storage(gpu, "smooth weights", &smooth.weights, none),
            values: storage(
                gpu,
                "smooth vertex values",
                &vec![0.0f32; 3 * vertex_count as usize],
                none,
            ),
            layout,
        }
    }

    /// Records the pass that fills [`values`](Self::values) from `radiosity` (3 f32 per element,
    /// original ids; its size checked by the caller) into `encoder` (the tracer's frame).
    #[cfg(feature = "trace")]
    pub(super) fn encode(
        &self,
        gpu: &Gpu,
        radiosity: &wgpu::Buffer,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        if self.vertex_count == 0 {
            return;
        }
        let bind_group = self.bind_group(gpu, radiosity);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(SMOOTH_ENTRY),
            timestamp_writes: None,
        });
        self.dispatch(&mut pass, &bind_group);
    }

    /// The pass's bindings with `radiosity` (3 f32 per element, original ids; its size checked
    /// by the caller): made once by a caller that keeps it (the lightmap fill).
    pub(super) fn bind_group(&self, gpu: &Gpu, radiosity: &wgpu::Buffer) -> wgpu::BindGroup {
        let buffers = [
            &self.params,
            &self.offsets,
            &self.elements,
            &self.weights,
            radiosity,
            &self.values,
        ];
        let entries = super::common::buffer_entries(&buffers);
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(SMOOTH_ENTRY),
            layout: &self.layout,
            entries: &entries,
        })
    }

    /// Records the dispatch that fills [`values`](Self::values) into `pass`, with a
    /// [`bind_group`](Self::bind_group) of this pass (nothing without smooth vertices).
    pub(super) fn dispatch(&self, pass: &mut wgpu::ComputePass<'_>, bind_group: &wgpu::BindGroup) {
        if self.vertex_count == 0 {
            return;
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        let [x, y, z] = workgroups(self.vertex_count.div_ceil(SMOOTH_LANES));
        pass.dispatch_workgroups(x, y, z);
    }
}

fn shader_module(gpu: &Gpu) -> wgpu::ShaderModule {
    #[allow(unsafe_code)]
    // SAFETY: every index smooth.wgsl follows was checked by `Reconstruction::from_parts` when
    // the tracer's scene was made (offsets non-decreasing from 0 to the number of positions and
    // weights, positions below n) and by the buffers made here (the element ids mapped through
    // the order by checked indexing in `SmoothPass::new`, so below n; 3 f32 per smooth vertex)
    // and in `GpuTracer::frame` (the radiosity buffer's size); the argument is in the header
    // of smooth.wgsl. Its loop ends: j steps by 4 up to offsets[v + 1], and the entries of a
    // step past the row read its last index, offsets[v + 1] - 1.
    unsafe {
        super::common::shader_module(
            &gpu.device,
            SMOOTH_ENTRY,
            SMOOTH_VERTICES,
            gpu.options.bounds_checks,
        )
    }
}
