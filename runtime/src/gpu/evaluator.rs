//! [`GpuEvaluator`]: frames of one operator on the GPU, with the CPU evaluator's inputs and
//! outputs, or left on the GPU for a renderer.

use std::sync::Arc;
use std::time::{Duration, Instant};

use lrr_formats::{OperatorFile, StoredMatrix};
use lrr_shaders::{LANES, Pass, Storage, workgroups};

use super::buffers::{OperatorBuffers, storage, zeros};
use super::common::{GpuError, bytes_of, bytes_of_mut};
use super::device::Gpu;
use super::pipelines::Pipelines;
use crate::error::input;
use crate::frame::Frame;
use crate::kernel::SimdLevel;
use crate::operator::Operator;
use crate::rgb::{Rgb, RgbMut};

/// The most workgroups of one gather dispatch: 4096 × 256 invocations keep every SM of a
/// large GPU busy several times over; more rows are walked by each workgroup's grid-stride
/// loop, which amortises its copy of `Z`.
const GATHER_MAX_GROUPS: u32 = 4096;

/// How long a frame took.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameTiming {
    /// From the first pass's start to the last one's end, by timestamp queries; `None` when the
    /// adapter has no `TIMESTAMP_QUERY`.
    pub gpu: Option<Duration>,
    /// Wall time of the call: validation, upload, the passes, readback.
    pub end_to_end: Duration,
}

/// GPU times of a [`GpuEvaluator::burst`]: each frame's, and each read pass's of the faster
/// read kernel.
#[derive(Debug, Clone, PartialEq)]
pub struct BurstTiming {
    /// The timed frames, in order.
    pub frames: Vec<Duration>,
    /// The read passes of the faster kernel (by median), sorted.
    pub reads: Vec<Duration>,
}

/// Where a frame's emission comes from.
#[derive(Clone, Copy)]
enum Source {
    /// The caller's emission, in upload slot `i`.
    Slot(usize),
    /// Light-group intensities, in upload slot `i`.
    Groups(usize),
    /// The caller's emission in upload slot `i`, and `Z` computed on the CPU (the hybrid).
    Hybrid(usize),
}

/// The CPU half of the papers' hybrid frame: `X = Vᵀ E` and `Z_c = M_c X_c` on the calling
/// thread, the O(nk) gather on the GPU. Built on the first hybrid frame.
struct Hybrid {
    frame: Frame,
    x: Vec<[f64; 3]>,
    z: Vec<f32>,
    simd: SimdLevel,
}

/// One of the two upload slots: its buffers and the bind groups that read them.
struct Slot {
    emission: wgpu::Buffer,
    intensities: wgpu::Buffer,
    segment_sums: wgpu::BindGroup,
    group_sums: wgpu::BindGroup,
    group_emission: wgpu::BindGroup,
    /// One per chunk, reading this slot's emission.
    gather: Vec<wgpu::BindGroup>,
    /// One per chunk, reading the light groups' emission.
    gather_groups: Vec<wgpu::BindGroup>,
}

pub(super) struct Timestamps {
    /// [`BURST_PAIRS`] pairs of queries: pair 0 for a frame or read pass, all of them for
    /// [`GpuEvaluator::burst`].
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f32,
    /// The pair the next pass writes (0 outside a burst).
    pair: u32,
}

/// Query pairs of the timestamp set: a burst times at most a third as many frames (and twice
/// as many read passes, the two read kernels alternated).
pub(super) const BURST_PAIRS: u32 = 128;

/// How long [`GpuEvaluator::burst`] keeps the GPU busy before it times frames.
pub(super) const WARM_UP: Duration = Duration::from_millis(300);

/// Evaluates frames of one operator on a GPU: the same inputs and outputs as
/// [`Evaluator`](crate::Evaluator) (emission and radiosity per element in original id order,
/// interleaved or planar; light-group intensities; albedo edits), the same errors for bad
/// input. See the [module docs](super) for what a frame does.
///
/// Everything is allocated and uploaded by [`new`](Self::new); a frame writes the emission (or
/// the intensities) into the next of two upload slots, submits one command buffer and, for
/// [`evaluate`](Self::evaluate), reads `B` back.
pub struct GpuEvaluator {
    gpu: Gpu,
    file: Arc<OperatorFile>,
    buffers: OperatorBuffers,
    pipelines: Pipelines,
    slots: [Slot; 2],
    next: usize,
    core_product: wgpu::BindGroup,
    /// Per chunk, for the narrow and the wide read kernel.
    read: [Vec<wgpu::BindGroup>; 2],
    readback: wgpu::Buffer,
    timestamps: Option<Timestamps>,
    /// Planar emission interleaved for upload.
    scratch: Vec<f32>,
    timing: Option<FrameTiming>,
    hybrid: Option<Hybrid>,
    /// The last albedo edit, for a hybrid frame built after it.
    edited: Option<(crate::albedo::Albedo, Vec<[f32; 3]>)>,
}

impl std::fmt::Debug for GpuEvaluator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}

fn bind(
    gpu: &Gpu,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, &wgpu::Buffer)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = entries
        .iter()
        .map(|&(binding, buffer)| wgpu::BindGroupEntry {
            binding,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

impl GpuEvaluator {
    /// Uploads `op` (its current albedo) to `gpu` and builds the pipelines. Errors when a row
    /// of the stored matrix exceeds the adapter's binding limit.
    pub fn new(gpu: &Gpu, op: &Operator) -> Result<Self, GpuError> {
        let file = Arc::clone(op.shared());
        let buffers = OperatorBuffers::new(gpu, &file)?;
        let storage = match file.operator.matrix() {
            StoredMatrix::F32(_) => Storage::F32,
            StoredMatrix::F16(_) => gpu.f16_loader(),
        };
        let pipelines = Pipelines::new(
            gpu,
            buffers.kp,
            storage,
            buffers.factored,
            buffers.per_block,
        );
        let slots = [0, 1].map(|_| Self::slot(gpu, &buffers, &pipelines));
        let b = &buffers;
        let core_product = bind(
            gpu,
            &pipelines.core_product,
            &[
                (0, &b.params),
                (1, &b.cores[0]),
                (2, &b.cores[1]),
                (3, &b.cores[2]),
                (4, &b.x),
                (5, &b.z),
            ],
        );
        // Each read pipeline has its own (derived) layout, so its own bind groups.
        let read = [&pipelines.read, &pipelines.read_wide].map(|p| {
            (b.chunks.iter())
                .map(|c| bind(gpu, p, &[(1, &c.buffer), (2, &b.sink)]))
                .collect()
        });
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("radiosity readback"),
            size: 12 * u64::from(b.n),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let timestamps = gpu
            .has(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| timestamps(gpu));
        Ok(GpuEvaluator {
            gpu: gpu.clone(),
            file,
            buffers,
            pipelines,
            slots,
            next: 0,
            core_product,
            read,
            readback,
            timestamps,
            scratch: Vec::new(),
            timing: None,
            hybrid: None,
            edited: None,
        })
    }

    fn slot(gpu: &Gpu, b: &OperatorBuffers, p: &Pipelines) -> Slot {
        let none = wgpu::BufferUsages::empty();
        let emission = zeros(
            gpu,
            "emission",
            3 * b.n as usize,
            wgpu::BufferUsages::COPY_DST,
        );
        let intensities = storage(
            gpu,
            "intensities",
            &vec![0.0f32; b.groups.count],
            wgpu::BufferUsages::COPY_DST,
        );
        let _ = none;
        let g = &b.groups;
        // Plain: the gather reads X (there is no Z) and no reflectance.
        let z = if b.factored { &b.z } else { &b.x };
        let gather = |e: &wgpu::Buffer| -> Vec<wgpu::BindGroup> {
            (b.chunks.iter())
                .map(|c| {
                    bind(
                        gpu,
                        &p.gather,
                        &[
                            (0, &c.params),
                            (1, &c.buffer),
                            (2, z),
                            (3, e),
                            (4, &b.reflectance),
                            (5, &b.order),
                            (6, &b.radiosity),
                        ],
                    )
                })
                .collect()
        };
        Slot {
            segment_sums: bind(
                gpu,
                &p.segment_sums,
                &[
                    (0, &b.params),
                    (1, &b.index),
                    (2, &b.weights),
                    (3, &b.order),
                    (4, &emission),
                    (5, &b.x),
                ],
            ),
            group_sums: bind(
                gpu,
                &p.group_sums,
                &[
                    (0, &b.params),
                    (1, &intensities),
                    (2, &g.group_x),
                    (8, &b.x),
                ],
            ),
            group_emission: bind(
                gpu,
                &p.group_emission,
                &[
                    (0, &b.params),
                    (1, &intensities),
                    (3, &g.position),
                    (4, &g.starts),
                    (5, &g.members),
                    (6, &g.member_emission),
                    (7, &b.order),
                    (9, &g.emission),
                ],
            ),
            gather: gather(&emission),
            gather_groups: gather(&g.emission),
            emission,
            intensities,
        }
    }

    /// Radiosity `out` for the per-element `emission` (original id order, interleaved or
    /// planar), as [`Evaluator::evaluate`](crate::Evaluator::evaluate): emission must be finite
    /// and non-negative, and on an error nothing is written.
    pub fn evaluate(&mut self, emission: Rgb<'_>, mut out: RgbMut<'_>) -> Result<(), GpuError> {
        self.frame_into(&mut out, |ev| ev.upload(&emission))
    }

    /// Radiosity for light-group intensities (one per [`Operator::light_groups`] entry, finite
    /// and non-negative), as [`Evaluator::evaluate_groups`](crate::Evaluator::evaluate_groups):
    /// `X = Σ_g a_g x_g` and the groups' emission on the GPU, no O(n) pass over an emission.
    pub fn evaluate_groups(
        &mut self,
        intensities: &[f32],
        mut out: RgbMut<'_>,
    ) -> Result<(), GpuError> {
        self.frame_into(&mut out, |ev| ev.upload_groups(intensities))
    }

    /// Computes a frame into [`radiosity_buffer`](Self::radiosity_buffer) without reading it
    /// back and without waiting for it: the call returns once the work is submitted. Frames
    /// alternate between two upload buffers, so the next frame's upload does not wait for
    /// this one's passes.
    pub fn submit(&mut self, emission: Rgb<'_>) -> Result<(), GpuError> {
        let source = self.upload(&emission)?;
        self.run(source, false);
        Ok(())
    }

    /// [`submit`](Self::submit) for light-group intensities.
    pub fn submit_groups(&mut self, intensities: &[f32]) -> Result<(), GpuError> {
        let source = self.upload_groups(intensities)?;
        self.run(source, false);
        Ok(())
    }

    /// [`evaluate`](Self::evaluate) as the papers' hybrid: the segment sums and the core
    /// product on the calling thread (f64, as the CPU [`Evaluator`](crate::Evaluator)), `Z`
    /// uploaded beside the emission, the gather on the GPU. The result equals
    /// [`evaluate`](Self::evaluate)'s to f32 rounding.
    pub fn evaluate_hybrid(
        &mut self,
        emission: Rgb<'_>,
        mut out: RgbMut<'_>,
    ) -> Result<(), GpuError> {
        self.frame_into(&mut out, |ev| ev.upload_hybrid(&emission))
    }

    /// [`submit`](Self::submit) as the hybrid: returns once the gather is submitted, so the
    /// caller's thread computes the next frame's sums while the GPU runs this one's gather.
    pub fn submit_hybrid(&mut self, emission: Rgb<'_>) -> Result<(), GpuError> {
        let source = self.upload_hybrid(&emission)?;
        self.run(source, false);
        Ok(())
    }

    /// Waits until every submitted frame is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.gpu.wait()
    }

    /// The radiosity of the last frame: `3 n` f32, element `i` (original id) at `3i..3i + 3`,
    /// usage `STORAGE | COPY_SRC`. Bind it read-only in a renderer on the same device
    /// ([`Gpu::device`]); work submitted after a frame sees that frame's values.
    pub fn radiosity_buffer(&self) -> &wgpu::Buffer {
        &self.buffers.radiosity
    }

    /// Timing of the last [`evaluate`](Self::evaluate) or
    /// [`evaluate_groups`](Self::evaluate_groups).
    pub fn last_timing(&self) -> Option<FrameTiming> {
        self.timing
    }

    /// Changes the reflectance (one RGB value per element, original ids, in [0, 1)) and
    /// uploads new cores, as [`Evaluator::set_reflectance`](crate::Evaluator::set_reflectance);
    /// the operator and other evaluators are not affected.
    pub fn set_reflectance(&mut self, rho: &[[f32; 3]]) -> Result<(), GpuError> {
        let edit = crate::albedo::rebuild(&self.file, rho)?;
        self.buffers.set_albedo(
            &self.gpu,
            &edit.cores,
            edit.channels as u32,
            &edit.reflectance,
        );
        if let Some(h) = &mut self.hybrid {
            h.frame.set_albedo(edit.clone(), rho);
        }
        self.edited = Some((edit, rho.to_vec()));
        Ok(())
    }

    /// The read roofline: reads every byte of the stored matrix a frame reads (a plain read
    /// kernel, one dispatch per chunk, in the same run of the device) and waits. For
    /// benchmarks: compare its [`FrameTiming::gpu`] with a frame's.
    /// Two read kernels are timed, one and four loads in flight per thread, one submission
    /// each; the faster is returned (the more demanding roofline).
    pub fn read_pass(&mut self) -> Result<FrameTiming, GpuError> {
        let mut best: Option<FrameTiming> = None;
        for wide in [false, true] {
            let start = Instant::now();
            let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
            self.encode_read(&mut encoder, wide);
            self.resolve_timestamps(&mut encoder);
            self.gpu.queue.submit([encoder.finish()]);
            let gpu = self.read_timestamps()?;
            let t = FrameTiming {
                gpu,
                end_to_end: start.elapsed(),
            };
            let key = |t: &FrameTiming| t.gpu.unwrap_or(t.end_to_end);
            if best.as_ref().is_none_or(|b| key(&t) < key(b)) {
                best = Some(t);
            }
        }
        Ok(best.expect("two timings"))
    }

    /// GPU times of `frames` frames (at most 42) run back to back on one uploaded `emission`,
    /// after 0.3 s of untimed frames back to back (a GPU idling at low clocks raises them under
    /// sustained load), then of as many read passes of each read kernel back to back (the
    /// faster kernel's are returned): the GPU never waits for the host between
    /// them, so they run at the clocks of a busy GPU (a frame read back and waited for, as
    /// [`read_pass`](Self::read_pass) and [`last_timing`](Self::last_timing) time it, leaves
    /// the GPU idle in between). Each frame's passes are timed by their own timestamps.
    /// `None` without `TIMESTAMP_QUERY`. For benchmarks.
    pub fn burst(
        &mut self,
        emission: Rgb<'_>,
        frames: usize,
    ) -> Result<Option<BurstTiming>, GpuError> {
        if self.timestamps.is_none() {
            return Ok(None);
        }
        let frames = frames.clamp(1, BURST_PAIRS as usize / 3) as u32;
        let source = self.upload(&emission)?;
        // Warm-up: frames back to back for at least WARM_UP of wall time (batches of 32,
        // waited for), so that the GPU leaves its idle clocks before the timed frames; the
        // timed frames follow the last batch with no wait.
        let warm = Instant::now();
        while warm.elapsed() < WARM_UP {
            for _ in 0..32 {
                self.run_untimed(source);
            }
            self.wait()?;
        }
        for _ in 0..32 {
            self.run_untimed(source);
        }
        for i in 0..frames {
            self.set_pair(i);
            self.run(source, false);
        }
        // Read passes, the narrow and the wide kernel alternated, each with its own pair.
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        for i in 0..2 * frames {
            self.set_pair(frames + i);
            self.encode_read(&mut encoder, i % 2 == 1);
        }
        self.set_pair(0);
        let t = self.timestamps.as_ref().expect("checked above");
        t.resolve(&mut encoder, 3 * frames);
        self.gpu.queue.submit([encoder.finish()]);
        let times = t.read_pairs(&self.gpu, 3 * frames as usize)?;
        let (f, r) = times.split_at(frames as usize);
        // The faster kernel's reads (by median), as read_pass takes the faster.
        let pick = |wide: usize| {
            let mut v: Vec<Duration> = r.iter().skip(wide).step_by(2).copied().collect();
            v.sort();
            v
        };
        let (narrow, wide) = (pick(0), pick(1));
        let reads = if wide[wide.len() / 2] < narrow[narrow.len() / 2] {
            wide
        } else {
            narrow
        };
        Ok(Some(BurstTiming {
            frames: f.to_vec(),
            reads,
        }))
    }

    /// A frame's passes with no timestamps (the burst's warm-up).
    fn run_untimed(&mut self, source: Source) {
        let timestamps = self.timestamps.take();
        self.run(source, false);
        self.timestamps = timestamps;
    }

    fn set_pair(&mut self, pair: u32) {
        if let Some(t) = &mut self.timestamps {
            t.pair = pair;
        }
    }

    /// The read kernel's pass over every chunk (`wide`: four loads in flight per thread),
    /// timed by the current query pair.
    fn encode_read(&self, encoder: &mut wgpu::CommandEncoder, wide: bool) {
        let mut pass = encoder.begin_compute_pass(&self.pass_descriptor("read"));
        pass.set_pipeline(if wide {
            &self.pipelines.read_wide
        } else {
            &self.pipelines.read
        });
        for (bind, chunk) in self.read[usize::from(wide)]
            .iter()
            .zip(&self.buffers.chunks)
        {
            let quads = chunk.buffer.size() / 16;
            let groups = quads
                .div_ceil(u64::from(LANES))
                .min(u64::from(GATHER_MAX_GROUPS * 4));
            pass.set_bind_group(0, bind, &[]);
            pass.dispatch_workgroups(groups as u32, 1, 1);
        }
    }

    /// The gather's lanes per row.
    pub fn row_lanes(&self) -> u32 {
        self.pipelines.constants.row_lanes
    }

    /// How the gather loads the stored matrix (f32, or one of the binary16 loaders).
    pub fn storage(&self) -> Storage {
        match self.pipelines.gather_pass {
            Pass::Gather(s, _) => s,
            _ => unreachable!("the gather pipeline is a gather"),
        }
    }

    /// Rows each gather lane takes per iteration.
    pub fn gather_rows(&self) -> u32 {
        self.pipelines.constants.rows
    }

    /// The most workgroups of one gather dispatch.
    pub fn gather_groups(&self) -> u32 {
        self.gpu.options.gather_groups.unwrap_or(GATHER_MAX_GROUPS)
    }

    /// Bytes of the stored matrix on the GPU (rows padded to whole octets).
    pub fn matrix_bytes(&self) -> u64 {
        self.buffers.matrix_bytes
    }

    /// Chunks the stored matrix is split into.
    pub fn chunks(&self) -> usize {
        self.buffers.chunks.len()
    }

    /// The adapter and the kernels in use, in one line.
    pub fn describe(&self) -> String {
        let c = &self.pipelines.constants;
        let (storage, reduce) = match self.pipelines.gather_pass {
            Pass::Gather(s, r) => (s, r),
            _ => unreachable!("the gather pipeline is a gather"),
        };
        format!(
            "{}: n = {}, k = {} (rows of {}), {:?} storage, {:?} row sums, {} lanes per row, {} \
             row(s) per lane and iteration, at most {} workgroups, Z in {} memory, {} chunk(s) of \
             at most {} MiB, bounds checks {}",
            self.gpu.adapter_name(),
            self.buffers.n,
            self.buffers.k,
            c.kp,
            storage,
            reduce,
            c.row_lanes,
            c.rows,
            self.gather_groups(),
            if c.z_shared { "workgroup" } else { "storage" },
            self.buffers.chunks.len(),
            self.gpu.max_chunk_bytes() >> 20,
            if self.gpu.options.bounds_checks {
                "on"
            } else {
                "off where proven"
            },
        )
    }

    /// A frame read back into `out`: checks `out`, uploads through `upload`, runs the passes,
    /// waits and copies `B` into `out`, recording the timing.
    fn frame_into(
        &mut self,
        out: &mut RgbMut<'_>,
        upload: impl FnOnce(&mut Self) -> Result<Source, GpuError>,
    ) -> Result<(), GpuError> {
        let start = Instant::now();
        out.check(self.buffers.n as usize, "output")?;
        let source = upload(self)?;
        self.run(source, true);
        self.read_back(out, start)
    }

    /// Validates the emission and writes it into the next upload slot.
    fn upload(&mut self, emission: &Rgb<'_>) -> Result<Source, GpuError> {
        Ok(Source::Slot(self.write_emission(emission, true)?))
    }

    /// Writes the emission into the next upload slot and returns it; with `scan`, first refuses
    /// non-finite or negative values (the hybrid's segment sums have already refused them).
    fn write_emission(&mut self, emission: &Rgb<'_>, scan: bool) -> Result<usize, GpuError> {
        let n = self.buffers.n as usize;
        emission.check(n, "emission")?;
        let values: &[f32] = match *emission {
            Rgb::Interleaved(v) => v,
            Rgb::Planar(_) => {
                self.scratch.clear();
                self.scratch.extend((0..n).flat_map(|i| emission.at(i)));
                &self.scratch
            }
        };
        let bad = scan.then(|| crate::kernel::first_bad_emission(values));
        if let Some(Some(bad)) = bad {
            let id = bad / 3;
            return Err(input(format!(
                "emission of element {id} is {:?}: emission must be finite and non-negative",
                emission.at(id)
            ))
            .into());
        }
        let slot = self.next;
        self.gpu
            .queue
            .write_buffer(&self.slots[slot].emission, 0, bytes_of(values));
        self.next = 1 - slot;
        Ok(slot)
    }

    /// Computes `Z` on this thread (the segment sums refuse bad emission before anything is
    /// written), uploads it where the gather reads it (`Z`, or `X` for the plain layout), then
    /// the emission.
    fn upload_hybrid(&mut self, emission: &Rgb<'_>) -> Result<Source, GpuError> {
        let (n, k, kp) = (
            self.buffers.n as usize,
            self.buffers.k as usize,
            self.buffers.kp as usize,
        );
        emission.check(n, "emission")?;
        let h = self.hybrid.get_or_insert_with(|| {
            let mut frame = Frame::new(Arc::clone(&self.file), &[0, n]);
            if let Some((edit, rho)) = &self.edited {
                frame.set_albedo(edit.clone(), rho);
            }
            Hybrid {
                frame,
                x: vec![[0.0; 3]; k],
                z: vec![0.0; 3 * kp],
                simd: SimdLevel::detect(),
            }
        });
        h.frame.segment_sums(emission, &mut h.x, h.simd)?;
        h.frame.core_product(&h.x, &mut h.z, kp);
        let target = if self.buffers.factored {
            &self.buffers.z
        } else {
            &self.buffers.x
        };
        self.gpu.queue.write_buffer(target, 0, bytes_of(&h.z));
        Ok(Source::Hybrid(self.write_emission(emission, false)?))
    }

    fn upload_groups(&mut self, intensities: &[f32]) -> Result<Source, GpuError> {
        Ok(Source::Groups(self.write_groups(intensities)?))
    }

    /// Checks the intensities and writes them into the next upload slot, which it returns.
    fn write_groups(&mut self, intensities: &[f32]) -> Result<usize, GpuError> {
        crate::frame::check_intensities(&self.file, intensities)?;
        let slot = self.take_slot();
        if !intensities.is_empty() {
            self.gpu
                .queue
                .write_buffer(&self.slots[slot].intensities, 0, bytes_of(intensities));
        }
        Ok(slot)
    }

    fn take_slot(&mut self) -> usize {
        let slot = self.next;
        self.next = 1 - slot;
        slot
    }

    fn pass_descriptor(&self, label: &'static str) -> wgpu::ComputePassDescriptor<'_> {
        wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: self.timestamps.as_ref().map(|t| t.writes(t.pair)),
        }
    }

    /// Encodes and submits the passes of a frame; with `readback`, also the copy of `B` into
    /// the mappable buffer and the timestamps.
    fn run(&mut self, source: Source, readback: bool) {
        let b = &self.buffers;
        let p = &self.pipelines;
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&self.pass_descriptor("frame"));
            let dispatch = |pass: &mut wgpu::ComputePass, count: u32| {
                let [x, y, z] = workgroups(count);
                pass.dispatch_workgroups(x, y, z);
            };
            let slot = match source {
                Source::Slot(i) => {
                    let slot = &self.slots[i];
                    pass.set_pipeline(&p.segment_sums);
                    pass.set_bind_group(0, &slot.segment_sums, &[]);
                    dispatch(&mut pass, b.k);
                    &slot.gather
                }
                Source::Hybrid(i) => &self.slots[i].gather,
                Source::Groups(i) => {
                    let slot = &self.slots[i];
                    pass.set_pipeline(&p.group_sums);
                    pass.set_bind_group(0, &slot.group_sums, &[]);
                    dispatch(&mut pass, (3 * b.kp).div_ceil(LANES));
                    if b.groups.positions > 0 {
                        pass.set_pipeline(&p.group_emission);
                        pass.set_bind_group(0, &slot.group_emission, &[]);
                        dispatch(&mut pass, b.groups.positions.div_ceil(LANES));
                    }
                    &slot.gather_groups
                }
            };
            if b.factored && !matches!(source, Source::Hybrid(_)) {
                pass.set_pipeline(&p.core_product);
                pass.set_bind_group(0, &self.core_product, &[]);
                dispatch(&mut pass, b.k);
            }
            pass.set_pipeline(&p.gather);
            let rows_per_group = p.constants.rows_per_iteration();
            let most = self.gather_groups();
            for (bind, chunk) in slot.iter().zip(&b.chunks) {
                pass.set_bind_group(0, bind, &[]);
                let groups = chunk.rows.div_ceil(rows_per_group).min(most);
                pass.dispatch_workgroups(groups, 1, 1);
            }
        }
        if readback {
            encoder.copy_buffer_to_buffer(&b.radiosity, 0, &self.readback, 0, 12 * u64::from(b.n));
            self.resolve_timestamps(&mut encoder);
        }
        self.gpu.queue.submit([encoder.finish()]);
    }

    fn resolve_timestamps(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(t) = &self.timestamps {
            t.resolve(encoder, 1);
        }
    }

    /// Waits for the frame, copies `B` into `out`, records the timing.
    fn read_back(&mut self, out: &mut RgbMut<'_>, start: Instant) -> Result<(), GpuError> {
        map(&self.gpu, &self.readback)?;
        {
            let view = self.readback.get_mapped_range(..).map_err(mapping)?;
            match out {
                RgbMut::Interleaved(v) => bytes_of_mut(v).copy_from_slice(&view),
                RgbMut::Planar(_) => {
                    for (i, rgb) in view.chunks_exact(12).enumerate() {
                        let c = |j: usize| {
                            f32::from_le_bytes(rgb[4 * j..4 * j + 4].try_into().unwrap_or_default())
                        };
                        out.set(i, [c(0), c(1), c(2)]);
                    }
                }
            }
        }
        self.readback.unmap();
        let gpu = self.read_timestamps()?;
        self.timing = Some(FrameTiming {
            gpu,
            end_to_end: start.elapsed(),
        });
        Ok(())
    }

    fn read_timestamps(&self) -> Result<Option<Duration>, GpuError> {
        let Some(t) = &self.timestamps else {
            self.gpu.wait()?;
            return Ok(None);
        };
        Ok(t.read_pairs(&self.gpu, 1)?.first().copied())
    }
}

// What the direct pass (`super::direct::GpuDirect`) needs of an evaluator: a frame's base
// emission staged in an upload slot, that slot's emission buffer (which the pass rewrites as
// `E = base + ρ ⊙ H`), and the frame run from it.
impl GpuEvaluator {
    /// The device the evaluator's buffers live on.
    pub(super) fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// Elements.
    pub(super) fn n(&self) -> u32 {
        self.buffers.n
    }

    /// Checks `emission` (as [`submit`](Self::submit)) and writes it into the next upload slot,
    /// which it returns.
    pub(super) fn stage_emission(&mut self, emission: &Rgb<'_>) -> Result<usize, GpuError> {
        self.write_emission(emission, true)
    }

    /// Checks `intensities` (as [`submit_groups`](Self::submit_groups)), writes them into the
    /// next upload slot and records into `encoder` the groups' emission on the GPU
    /// (`group_emission`) and its copy into that slot's emission buffer, so that the slot holds
    /// the whole frame's base emission; returns the slot.
    pub(super) fn stage_groups(
        &mut self,
        intensities: &[f32],
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<usize, GpuError> {
        let slot = self.write_groups(intensities)?;
        let b = &self.buffers;
        if b.groups.positions > 0 {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("group emission"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipelines.group_emission);
            pass.set_bind_group(0, &self.slots[slot].group_emission, &[]);
            let [x, y, z] = workgroups(b.groups.positions.div_ceil(LANES));
            pass.dispatch_workgroups(x, y, z);
        }
        encoder.copy_buffer_to_buffer(
            &b.groups.emission,
            0,
            &self.slots[slot].emission,
            0,
            12 * u64::from(b.n),
        );
        Ok(slot)
    }

    /// The emission buffer of upload slot `slot` (3 f32 per element, original ids).
    pub(super) fn slot_emission(&self, slot: usize) -> &wgpu::Buffer {
        &self.slots[slot].emission
    }

    /// Submits the frame from the emission in upload slot `slot` (segment sums, core product,
    /// gather); with `readback`, also the copy of `B` that [`finish`](Self::finish) reads.
    pub(super) fn run_slot(&mut self, slot: usize, readback: bool) {
        self.run(Source::Slot(slot), readback);
    }

    /// Waits for a frame submitted by [`run_slot`](Self::run_slot) with `readback`, copies `B`
    /// into `out` (checked by the caller) and records its timing from `start`.
    pub(super) fn finish(&mut self, out: &mut RgbMut<'_>, start: Instant) -> Result<(), GpuError> {
        self.read_back(out, start)
    }
}

impl Timestamps {
    /// The writes of query pair `pair` at the start and end of a compute pass.
    pub(super) fn writes(&self, pair: u32) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(2 * pair),
            end_of_pass_write_index: Some(2 * pair + 1),
        }
    }

    /// Records the resolution of the first `pairs` query pairs into the mappable buffer, for
    /// [`read_pairs`](Self::read_pairs) once `encoder` is submitted.
    pub(super) fn resolve(&self, encoder: &mut wgpu::CommandEncoder, pairs: u32) {
        encoder.resolve_query_set(&self.set, 0..2 * pairs, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 16 * u64::from(pairs));
    }

    /// Waits for the resolved queries in `readback` and returns the first `pairs` pairs'
    /// durations (end − start of each pair, in the device's timestamp period).
    pub(super) fn read_pairs(&self, gpu: &Gpu, pairs: usize) -> Result<Vec<Duration>, GpuError> {
        map(gpu, &self.readback)?;
        let ticks: Vec<u64> = {
            let view = self.readback.get_mapped_range(..).map_err(mapping)?;
            view.chunks_exact(8)
                .take(2 * pairs)
                .map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
                .collect()
        };
        self.readback.unmap();
        let period = f64::from(self.period_ns);
        Ok(ticks
            .chunks_exact(2)
            .map(|p| Duration::from_nanos((p[1].saturating_sub(p[0]) as f64 * period) as u64))
            .collect())
    }
}

pub(super) fn timestamps(gpu: &Gpu) -> Timestamps {
    let buffer = |label, usage| {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: 16 * u64::from(BURST_PAIRS),
            usage,
            mapped_at_creation: false,
        })
    };
    use wgpu::BufferUsages as U;
    Timestamps {
        set: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("frame timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * BURST_PAIRS,
        }),
        resolve: buffer("timestamps", U::QUERY_RESOLVE | U::COPY_SRC),
        readback: buffer("timestamps readback", U::MAP_READ | U::COPY_DST),
        period_ns: gpu.queue.get_timestamp_period(),
        pair: 0,
    }
}

fn mapping(e: wgpu::MapRangeError) -> GpuError {
    GpuError::Device(format!("GPU: reading back a frame: {e}"))
}

/// Maps `buffer` for reading and waits for the mapping (and so for the work before it).
pub(super) fn map(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<(), GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    match rx.recv() {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(GpuError::Device(format!("GPU: reading back a frame: {e}"))),
        Err(_) => Err(GpuError::Device(
            "GPU: a frame's readback never completed".into(),
        )),
    }
}
