//! GPU evaluation through wgpu (cargo feature `gpu`): the same frames as the CPU
//! [`Evaluator`](crate::Evaluator), computed by the WGSL passes of `lrr-shaders`.
//!
//! ```no_run
//! use lrr_runtime::gpu::{Gpu, GpuEvaluator, GpuOptions};
//! use lrr_runtime::{Operator, Rgb, RgbMut};
//!
//! let op = Operator::load("cornell.lrr".as_ref())?;
//! let gpu = Gpu::new(&GpuOptions::default())?; // the best adapter, or an error listing them
//! let mut eval = GpuEvaluator::new(&gpu, &op)?; // uploads the operator once
//! let mut b = vec![[0.0f32; 3]; op.n()];
//! eval.evaluate(Rgb::triples(&op.baked_emission()), RgbMut::triples(&mut b))?;
//! let timing = eval.last_timing(); // GPU time (timestamp queries) and end-to-end time
//!
//! // For a renderer: no readback, the radiosity stays in a storage buffer.
//! eval.submit(Rgb::triples(&op.baked_emission()))?;
//! let radiosity: &wgpu::Buffer = eval.radiosity_buffer(); // 3 f32 per element, original ids
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # A frame on the GPU
//!
//! 1. The emission (original id order, interleaved as the caller's `[[f32; 3]]`; planar input is
//!    interleaved on the host) is written into one of two upload buffers, alternately, so a
//!    frame's upload never waits for the previous frame's passes to release its buffer.
//! 2. `segment_sums` (`X = Vᵀ E` through the element order), or for light groups `group_sums` +
//!    `group_emission` (stored `Vᵀ E_g`, no O(n) pass over an emission).
//! 3. `core_product` (`Z_c = M_c X_c`; the plain layout skips it).
//! 4. `gather` over the stored matrix, one dispatch per chunk of rows: `B = E + ρ ⊙ F_k Z`.
//! 5. For [`GpuEvaluator::evaluate`]: `B` copied into a mapped buffer and read back.
//!
//! All four passes run in one compute pass whose timestamps (when the adapter has
//! `TIMESTAMP_QUERY`) give [`FrameTiming::gpu`].
//!
//! # The gather's shape
//!
//! `ROW_LANES` lanes share a row (8 for k = 216), each lane takes `ROWS` rows per iteration of
//! its grid-stride loop (1 for f32, 2 for binary16) with a constant trip count per row, so all
//! of its loads are in flight before the first is used; binary16 is loaded as 16-byte words
//! and widened with `unpack2x16float`. These defaults are the best of sweeps on an H100
//! (`lrr bench runtime --device gpu --row-lanes … --gather-rows … --f16-loader …`,
//! docs/PERFORMANCE.md); [`GpuOptions`] overrides each.
//!
//! # Measuring a GPU
//!
//! A datacenter GPU idles at low clocks (an H100: 345 MHz against 1980 MHz busy) and a burst of
//! a few milliseconds does not raise them reliably: [`GpuEvaluator::burst`] runs 0.3 s of
//! untimed frames back to back before it times frames, and the benchmark reports those.
//!
//! # Chunks
//!
//! The stored matrix is uploaded as rows of `KP` entries (`k` rounded up to a multiple of 8,
//! zero padding) in chunks of whole rows, each its own buffer no larger than the adapter's
//! `max_storage_buffer_binding_size` and `max_buffer_size` (lavapipe: 128 MiB per binding;
//! an H100 under Vulkan: 2 GiB − 4 per binding, 4 GiB per buffer), or
//! [`GpuOptions::max_chunk_bytes`].
//!
//! # Bounds checks
//!
//! naga inserts a bounds check on every storage access unless told otherwise, which costs
//! 17–40% in tight loops. The gather, segment sums and core product are built with
//! `create_shader_module_trusted` and `ShaderRuntimeChecks::unchecked()` (the one `unsafe` of
//! this module): every index they compute is proven by the file's validation (the index vector
//! is non-decreasing and ends at `n`, `order` is a permutation) and by the buffer sizes this
//! module allocates (each WGSL file lists its argument). The light-group passes index through
//! tables built here and stay checked. [`GpuOptions::bounds_checks`] builds everything checked,
//! to measure the difference.

mod bench;
mod buffers;
mod common;
mod device;
mod direct;
mod evaluator;
mod lightmap;
mod pipelines;
mod smooth;
#[cfg(feature = "trace")]
mod trace;

pub use bench::{GpuBench, bench_operator, bounds_check_cost};
pub use device::{AdapterSummary, Gpu, GpuOptions, adapters, instance};
pub use direct::{DEFAULT_CHUNK_RAYS, GpuDirect, GpuDirectReport};
pub use evaluator::{BurstTiming, FrameTiming, GpuEvaluator};
pub use lightmap::{GpuFill, GpuLightmap, LIGHTMAP_FORMAT, TileCounts};
pub use lrr_shaders::{Reduce, Storage};
#[cfg(feature = "trace")]
pub use trace::{DEFAULT_TILE_PIXELS, GpuRenderReport, GpuTracer};
/// The wgpu this module was built with, for a renderer binding [`GpuEvaluator::radiosity_buffer`].
pub use wgpu;

pub use common::GpuError;
