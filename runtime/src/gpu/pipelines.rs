//! The compute pipelines of one operator: the passes of `lrr-shaders`, specialised by their
//! `override` constants (`KP`, the gather's [`GatherConstants`]).

use lrr_shaders::{GatherConstants, Pass, Storage, source};

use super::device::Gpu;

/// Every pipeline a frame of this operator uses, built once.
pub(super) struct Pipelines {
    pub segment_sums: wgpu::ComputePipeline,
    pub group_sums: wgpu::ComputePipeline,
    pub group_emission: wgpu::ComputePipeline,
    pub core_product: wgpu::ComputePipeline,
    pub gather: wgpu::ComputePipeline,
    /// The read kernel with one load per thread and iteration, and with four.
    pub read: wgpu::ComputePipeline,
    pub read_wide: wgpu::ComputePipeline,
    /// The gather's constants and variant, for reports.
    pub constants: GatherConstants,
    pub gather_pass: Pass,
}

impl Pipelines {
    pub fn new(gpu: &Gpu, kp: u32, storage: Storage, factored: bool, per_block: bool) -> Self {
        let reduce = gpu.reduce();
        let max_lanes = match reduce {
            lrr_shaders::Reduce::Subgroup => gpu.info.subgroup_min_size,
            lrr_shaders::Reduce::Workgroup => 32,
        };
        let row_lanes = match gpu.options.row_lanes {
            Some(lanes) => lanes.min(max_lanes.clamp(1, 32)),
            None => GatherConstants::row_lanes_for(kp, max_lanes),
        };
        let defaults = GatherConstants::new(kp, factored, per_block);
        let mut constants = GatherConstants {
            row_lanes,
            rows: gpu.options.gather_rows.unwrap_or(default_rows(storage)),
            ..defaults
        };
        constants.z_shared =
            constants.workgroup_bytes() <= gpu.limits.max_compute_workgroup_storage_size;
        let gather_pass = Pass::Gather(storage, reduce);
        let kp_only = [("KP", f64::from(kp))];
        let build = |pass: Pass, constants: &[(&str, f64)]| pipeline(gpu, pass, constants);
        Pipelines {
            segment_sums: build(Pass::SegmentSums, &kp_only),
            group_sums: build(Pass::GroupSums, &kp_only),
            group_emission: build(Pass::GroupEmission, &kp_only),
            core_product: build(Pass::CoreProduct, &kp_only),
            gather: build(gather_pass, &constants.constants()),
            read: build(Pass::Read, &[("KP", f64::from(kp)), ("READ_UNROLL", 1.0)]),
            read_wide: build(Pass::Read, &[("KP", f64::from(kp)), ("READ_UNROLL", 4.0)]),
            constants,
            gather_pass,
        }
    }
}

/// Rows per gather lane and iteration by default: 2 for binary16 (half the bytes per load, so
/// twice the rows to keep as many bytes in flight), 1 for f32. Measured on an H100
/// (docs/PERFORMANCE.md, "GPU"): at 1769472 × 216 with 8 lanes per row, binary16
/// (`unpack2x16float`) 2840 fps with 2 rows against 2820 with 4, and f32 1582 fps with 1 row
/// against 1566 with 2 and 1570 with 4 (at 221184 × 216: 10768, 10444, 10455).
fn default_rows(storage: Storage) -> u32 {
    match storage {
        Storage::F32 => 1,
        Storage::F16 | Storage::F16Unpack | Storage::F16Bits => 2,
    }
}

/// Whether `pass` may run without bounds checks: its indices are proven by the file's
/// validation and the sizes of the buffers this module allocates (see each WGSL file).
fn proven(pass: Pass) -> bool {
    matches!(
        pass,
        Pass::SegmentSums | Pass::CoreProduct | Pass::Gather(..) | Pass::Read
    )
}

fn module(gpu: &Gpu, label: &str, wgsl: String, unchecked: bool) -> wgpu::ShaderModule {
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    };
    if !unchecked {
        return gpu.device.create_shader_module(descriptor);
    }
    #[allow(unsafe_code)]
    // SAFETY: only for the passes `proven` lists, whose every storage index stays inside the
    // buffers bound to it (the argument is in each WGSL file's header: the file's validated
    // index vector and permutation, and the sizes `buffers.rs` allocates); their loops are
    // bounded by constants and uniforms, so dropping loop bounding cannot hang.
    unsafe {
        gpu.device
            .create_shader_module_trusted(descriptor, wgpu::ShaderRuntimeChecks::unchecked())
    }
}

fn pipeline(gpu: &Gpu, pass: Pass, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
    let unchecked = proven(pass) && !gpu.options.bounds_checks;
    let label = pass.entry_point();
    let module = module(gpu, label, source(pass), unchecked);
    compute(gpu, &module, label, constants)
}

fn compute(
    gpu: &Gpu,
    module: &wgpu::ShaderModule,
    entry: &str,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    gpu.device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: None,
            module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        })
}
