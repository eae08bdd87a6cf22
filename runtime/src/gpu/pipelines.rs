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
    pub read: wgpu::ComputePipeline,
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
        let mut constants = GatherConstants {
            row_lanes: GatherConstants::row_lanes_for(kp, max_lanes),
            ..GatherConstants::new(kp, factored, per_block)
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
            read: build(Pass::Read, &kp_only),
            constants,
            gather_pass,
        }
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
