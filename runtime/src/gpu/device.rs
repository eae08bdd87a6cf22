//! Adapters and the device: which GPUs wgpu finds, which one is used, what it can do.

use super::common::{GpuError, block_on};
use crate::error::input;
use lrr_shaders::{Reduce, Storage};

/// What to ask of the GPU. `Default`: the best adapter, every fast path the adapter allows.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GpuOptions {
    /// Use only an adapter whose name contains this (case-insensitive), e.g. `"llvmpipe"`.
    pub adapter: Option<String>,
    /// Build every pass with naga's bounds checks (default: off where proven, see the module
    /// docs). For measuring what they cost.
    pub bounds_checks: bool,
    /// The binary16 loader; `None`: `unpack2x16float` when the adapter has
    /// `SHADER_F16_IN_F32`, else native `f16` when it has `SHADER_F16`, else integer widening.
    pub f16_loader: Option<Storage>,
    /// The gather's row reduction; `None`: subgroup shuffles when the adapter has `SUBGROUP`,
    /// else workgroup memory.
    pub reduce: Option<Reduce>,
    /// Cap on a chunk of the stored matrix, below the adapter's limits (tests use it to
    /// chunk small operators).
    pub max_chunk_bytes: Option<u64>,
    /// Cap on one table of a lightmap fill (`GpuLightmap`), below the adapter's binding limit
    /// (tests use it to reach the fill's fallbacks on a small lightmap).
    pub max_table_bytes: Option<u64>,
    /// Lanes per row of the gather (a power of two, 1 to 32; with subgroup row sums a larger
    /// value is lowered to the adapter's smallest subgroup); `None`: about four octets per lane
    /// (`GatherConstants::row_lanes_for`). For tuning (`lrr bench runtime --row-lanes`).
    pub row_lanes: Option<u32>,
    /// Most workgroups of one gather dispatch, 1 to 65535 (rows beyond them are walked by the
    /// grid-stride loop); `None`: 4096. For tuning (`lrr bench runtime --gather-groups`).
    pub gather_groups: Option<u32>,
    /// Rows each gather lane takes per iteration, 1 to 4; `None`: the default
    /// (`GatherConstants::rows`). For tuning (`lrr bench runtime --gather-rows`).
    pub gather_rows: Option<u32>,
}

/// One adapter wgpu found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    /// The adapter's name (`llvmpipe (LLVM 15.0.6, 256 bits)`, `NVIDIA H100 80GB HBM3`).
    pub name: String,
    /// Vulkan, Metal, Dx12, Gl.
    pub backend: String,
    /// DiscreteGpu, IntegratedGpu, VirtualGpu, Cpu, Other.
    pub device_type: String,
    /// Driver name and version.
    pub driver: String,
    /// Whether it runs compute shaders (what this module needs).
    pub usable: bool,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({}, {}, driver {}{})",
            self.name,
            self.backend,
            self.device_type,
            self.driver,
            if self.usable {
                ""
            } else {
                ", no compute shaders"
            }
        )
    }
}

/// The wgpu instance [`Gpu::new`] opens adapters from (backends from `WGPU_BACKEND`): a caller
/// that presents to a window makes its surface with it, then opens [`Gpu::with_surface`].
pub fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

fn summary(adapter: &wgpu::Adapter) -> AdapterSummary {
    let info = adapter.get_info();
    let flags = adapter.get_downlevel_capabilities().flags;
    AdapterSummary {
        name: info.name,
        backend: format!("{:?}", info.backend),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_owned(),
        usable: flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS),
    }
}

/// Every adapter wgpu finds (backends from `WGPU_BACKEND`, default all), usable or not.
pub fn adapters() -> Vec<AdapterSummary> {
    block_on(instance().enumerate_adapters(wgpu::Backends::all().with_env()))
        .iter()
        .map(summary)
        .collect()
}

/// A GPU device and its queue, with what the adapter allows. Cheap to clone (shared handles);
/// evaluators keep a clone.
#[derive(Debug, Clone)]
pub struct Gpu {
    pub(super) adapter: wgpu::Adapter,
    pub(super) device: wgpu::Device,
    pub(super) queue: wgpu::Queue,
    pub(super) info: wgpu::AdapterInfo,
    pub(super) limits: wgpu::Limits,
    pub(super) downlevel: wgpu::DownlevelFlags,
    pub(super) options: GpuOptions,
}

impl Gpu {
    /// Opens the best usable adapter (discrete, then integrated, virtual, CPU), or the first
    /// whose name contains `options.adapter`, with the adapter's own limits and the optional
    /// features the passes use (timestamps, f16, subgroups) where present.
    ///
    /// With none usable: [`GpuError::NoAdapter`], naming every adapter found and how to install
    /// a driver.
    pub fn new(options: &GpuOptions) -> Result<Gpu, GpuError> {
        Self::open(options, &instance(), None)
    }

    /// [`Gpu::new`] on an adapter of `instance` ([`instance`]) that can present to `surface`.
    pub fn with_surface(
        options: &GpuOptions,
        instance: &wgpu::Instance,
        surface: &wgpu::Surface<'_>,
    ) -> Result<Gpu, GpuError> {
        Self::open(options, instance, Some(surface))
    }

    fn open(
        options: &GpuOptions,
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Gpu, GpuError> {
        if let Some(lanes) = options.row_lanes
            && !(lanes.is_power_of_two() && lanes <= 32)
        {
            return Err(input(format!(
                "GPU: {lanes} lanes per row: give a power of two from 1 to 32"
            ))
            .into());
        }
        if let Some(rows) = options.gather_rows
            && !(1..=lrr_shaders::MAX_GATHER_ROWS).contains(&rows)
        {
            return Err(input(format!(
                "GPU: {rows} gather rows per lane: give 1 to {}",
                lrr_shaders::MAX_GATHER_ROWS
            ))
            .into());
        }
        if let Some(groups) = options.gather_groups
            && !(1..=lrr_shaders::MAX_WORKGROUPS_PER_DIMENSION).contains(&groups)
        {
            return Err(input(format!(
                "GPU: {groups} gather workgroups: give 1 to {}",
                lrr_shaders::MAX_WORKGROUPS_PER_DIMENSION
            ))
            .into());
        }
        let found = block_on(instance.enumerate_adapters(wgpu::Backends::all().with_env()));
        let wanted = options.adapter.as_deref().map(str::to_lowercase);
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        let adapter = found
            .iter()
            .filter(|a| summary(a).usable)
            .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
            .filter(|a| {
                let name = a.get_info().name.to_lowercase();
                wanted.as_ref().is_none_or(|w| name.contains(w))
            })
            .min_by_key(|a| rank(a.get_info().device_type))
            .ok_or_else(|| no_adapter(&found, options.adapter.as_deref()))?;
        let wanted_features =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SHADER_F16 | wgpu::Features::SUBGROUP;
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("lrr"),
            required_features: adapter.features() & wanted_features,
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = block_on(adapter.request_device(&descriptor)).map_err(|e| {
            GpuError::Device(format!(
                "GPU: could not open {}: {e}",
                summary(adapter).name
            ))
        })?;
        Ok(Gpu {
            adapter: adapter.clone(),
            limits: device.limits(),
            device,
            queue,
            info: adapter.get_info(),
            downlevel: adapter.get_downlevel_capabilities().flags,
            options: options.clone(),
        })
    }

    /// The options this device was opened with.
    pub fn options(&self) -> &GpuOptions {
        &self.options
    }

    /// The adapter the device was opened on (e.g. for a surface's capabilities).
    pub fn adapter(&self) -> &wgpu::Adapter {
        &self.adapter
    }

    /// The adapter's name.
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// Whether the adapter runs on the CPU (lavapipe, SwiftShader): its timings say nothing
    /// about a GPU.
    pub fn is_cpu(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The adapter in one line: name, backend, type, driver, and the features in use.
    pub fn describe(&self) -> String {
        let has = |f: wgpu::Features| self.device.features().contains(f);
        format!(
            "{} ({:?}, {:?}, driver {} {}); timestamps {}, f16 {}, subgroups {} (sizes {}..{}); \
             {} MiB per binding",
            self.info.name,
            self.info.backend,
            self.info.device_type,
            self.info.driver,
            self.info.driver_info,
            has(wgpu::Features::TIMESTAMP_QUERY),
            has(wgpu::Features::SHADER_F16),
            has(wgpu::Features::SUBGROUP),
            self.info.subgroup_min_size,
            self.info.subgroup_max_size,
            self.limits.max_storage_buffer_binding_size >> 20,
        )
    }

    /// The wgpu device (for a renderer that binds [`GpuEvaluator::radiosity_buffer`](super::GpuEvaluator::radiosity_buffer)).
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The wgpu queue the evaluators submit to.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    pub(super) fn has(&self, feature: wgpu::Features) -> bool {
        self.device.features().contains(feature)
    }

    /// The binary16 loader: the option, or the best the adapter allows: `unpack2x16float` on
    /// 16-byte word loads where the adapter has it (on an H100, at the default 8 lanes and 2
    /// rows, 1.03–1.07× the native f16 loader's frame rate; 0.98–1.10× across the sweep,
    /// docs/PERFORMANCE.md), else native `f16`, else integer widening.
    pub(super) fn f16_loader(&self) -> Storage {
        self.options.f16_loader.unwrap_or(
            if self
                .downlevel
                .contains(wgpu::DownlevelFlags::SHADER_F16_IN_F32)
            {
                Storage::F16Unpack
            } else if self.has(wgpu::Features::SHADER_F16) {
                Storage::F16
            } else {
                Storage::F16Bits
            },
        )
    }

    /// The row reduction: the option, or subgroups when present.
    pub(super) fn reduce(&self) -> Reduce {
        self.options
            .reduce
            .unwrap_or(if self.has(wgpu::Features::SUBGROUP) {
                Reduce::Subgroup
            } else {
                Reduce::Workgroup
            })
    }

    /// The largest chunk of the stored matrix one buffer and binding may hold, in bytes.
    /// The largest buffer that can be bound whole: the adapter's binding and buffer limits.
    pub(super) fn max_binding_bytes(&self) -> u64 {
        let binding = self.limits.max_storage_buffer_binding_size;
        binding.min(self.limits.max_buffer_size)
    }

    pub(super) fn max_chunk_bytes(&self) -> u64 {
        let binding = self.limits.max_storage_buffer_binding_size;
        let limit = binding.min(self.limits.max_buffer_size);
        self.options.max_chunk_bytes.map_or(limit, |m| m.min(limit)) & !3
    }

    /// Waits for all work submitted to the device (frames, fills, draws).
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Device(format!("GPU: waiting for a frame: {e}")))
    }
}

fn no_adapter(found: &[wgpu::Adapter], wanted: Option<&str>) -> GpuError {
    let list: Vec<String> = found.iter().map(|a| format!("  {}", summary(a))).collect();
    let found = if list.is_empty() {
        "no adapter at all".to_owned()
    } else {
        format!("these adapters:\n{}", list.join("\n"))
    };
    let what = match wanted {
        Some(name) => format!("no usable GPU adapter named like {name:?}"),
        None => "no usable GPU adapter".to_owned(),
    };
    GpuError::NoAdapter(format!(
        "GPU: {what}; wgpu found {found}\n(backends from WGPU_BACKEND, default all). Install a \
         Vulkan driver: `apt-get install mesa-vulkan-drivers libvulkan1` gives the CPU adapter \
         llvmpipe (lavapipe); on NVIDIA, the proprietary driver's Vulkan ICD"
    ))
}
