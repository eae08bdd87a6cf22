//! What the GPU module's files share: the error type, a minimal executor for wgpu's futures,
//! and byte views of the plain numbers uploaded to the GPU.

use std::fmt;
use std::future::Future;
use std::pin::pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use crate::error::RuntimeError;

/// An error of the GPU path.
#[derive(Debug, Clone, PartialEq)]
pub enum GpuError {
    /// No usable adapter; the message lists the adapters found and how to install a driver.
    NoAdapter(String),
    /// The adapter or device cannot do what is asked (a limit, a failed request, a lost device).
    Device(String),
    /// The call or the file, as on the CPU path.
    Runtime(RuntimeError),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(m) | GpuError::Device(m) => f.write_str(m),
            GpuError::Runtime(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for GpuError {}

impl From<RuntimeError> for GpuError {
    fn from(e: RuntimeError) -> Self {
        GpuError::Runtime(e)
    }
}

/// Runs a future to completion on this thread. wgpu's native futures are ready at once or
/// woken by `Device::poll`; this parks until woken, without an executor crate.
pub(super) fn block_on<F: Future>(future: F) -> F::Output {
    struct Unpark(std::thread::Thread);
    impl Wake for Unpark {
        fn wake(self: Arc<Self>) {
            self.0.unpark();
        }
    }
    let waker = Waker::from(Arc::new(Unpark(std::thread::current())));
    let mut cx = Context::from_waker(&waker);
    let mut future = pin!(future);
    loop {
        match future.as_mut().poll(&mut cx) {
            Poll::Ready(v) => return v,
            Poll::Pending => std::thread::park(),
        }
    }
}

/// Plain numbers whose bytes the GPU reads as they are.
pub(super) trait Pod: Copy {}
impl Pod for f32 {}
impl Pod for u32 {}
impl Pod for u16 {}

/// The bytes of `v` (little-endian on every wgpu target).
#[allow(unsafe_code)]
pub(super) fn bytes_of<T: Pod>(v: &[T]) -> &[u8] {
    // SAFETY: f32, u32 and u16 have no padding and no invalid bit patterns; u8 has alignment 1;
    // the length is the slice's size in bytes.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), size_of_val(v)) }
}

/// The bytes of `v`, writable: any bytes are a valid f32.
#[allow(unsafe_code)]
pub(super) fn bytes_of_mut(v: &mut [f32]) -> &mut [u8] {
    // SAFETY: as in `bytes_of`; every bit pattern is a valid f32, so any write is sound.
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast::<u8>(), size_of_val(v)) }
}

/// A compute binding of a buffer, as `b` declares it.
pub(super) fn layout_entry(b: &lrr_shaders::Binding) -> wgpu::BindGroupLayoutEntry {
    if b.access == lrr_shaders::Access::WriteTexture {
        return wgpu::BindGroupLayoutEntry {
            binding: b.binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: wgpu::TextureFormat::Rgba16Float,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            count: None,
        };
    }
    wgpu::BindGroupLayoutEntry {
        binding: b.binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: match b.access {
                lrr_shaders::Access::Uniform => wgpu::BufferBindingType::Uniform,
                lrr_shaders::Access::Read => wgpu::BufferBindingType::Storage { read_only: true },
                lrr_shaders::Access::ReadWrite => {
                    wgpu::BufferBindingType::Storage { read_only: false }
                }
                lrr_shaders::Access::WriteTexture => unreachable!("returned above"),
            },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Bind group entries of `buffers`, each bound whole at the binding of its index (what every
/// pass's bindings are: buffers numbered from 0 in their declared order).
pub(super) fn buffer_entries<'a>(buffers: &[&'a wgpu::Buffer]) -> Vec<wgpu::BindGroupEntry<'a>> {
    buffers
        .iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
}

/// The bind group layout of a pass's `bindings` (its `lrr_shaders::*_BINDINGS`), explicit so
/// that every specialisation of the pass (whatever its overrides leave unused) shares it.
pub(super) fn bind_group_layout(
    device: &wgpu::Device,
    label: &str,
    bindings: &[lrr_shaders::Binding],
) -> wgpu::BindGroupLayout {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings.iter().map(layout_entry).collect();
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    })
}

/// The compute pipeline of `module`'s entry point `entry` over the explicit `bindings` (its
/// `lrr_shaders::*_BINDINGS`, in group 0), and their layout.
pub(super) fn compute_pipeline(
    device: &wgpu::Device,
    entry: &'static str,
    module: &wgpu::ShaderModule,
    bindings: &[lrr_shaders::Binding],
) -> (wgpu::ComputePipeline, wgpu::BindGroupLayout) {
    let layout = bind_group_layout(device, entry, bindings);
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(entry),
        // Workgroup memory is not zeroed before each workgroup (wgpu's default): of the passes
        // built here only lightmap_tiles.wgsl has any, and it reads no entry it has not
        // written (its header).
        compilation_options: wgpu::PipelineCompilationOptions {
            zero_initialize_workgroup_memory: false,
            ..Default::default()
        },
        cache: None,
    });
    (pipeline, layout)
}

/// The module of a pass's WGSL: with naga's bounds checks when `checked`, else without.
///
/// # Safety
/// Unless `checked`, every index `wgsl` follows must be proven in bounds for the buffers its
/// host binds, and its loops must end; each caller states its argument.
#[allow(unsafe_code)]
pub(super) unsafe fn shader_module(
    device: &wgpu::Device,
    label: &str,
    wgsl: &'static str,
    checked: bool,
) -> wgpu::ShaderModule {
    let descriptor = wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    };
    if checked {
        return device.create_shader_module(descriptor);
    }
    // SAFETY: the caller's promise (this function's contract).
    unsafe {
        device.create_shader_module_trusted(descriptor, wgpu::ShaderRuntimeChecks::unchecked())
    }
}
