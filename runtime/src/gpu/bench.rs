//! Frame rates of the GPU path against a plain read of the same bytes and the CPU path, all
//! measured in one run (for `lrr bench runtime --device gpu`).

use std::time::{Duration, Instant};

use super::common::GpuError;
use super::device::Gpu;
use super::evaluator::{FrameTiming, GpuEvaluator};
use crate::operator::Operator;
use crate::rgb::{Rgb, RgbMut};

/// One operator's measurements: medians over the frames.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuBench {
    /// Elements and patches.
    pub n: usize,
    /// Patches.
    pub k: usize,
    /// Bytes of the stored matrix a frame reads on the GPU (rows padded to whole octets).
    pub matrix_bytes: u64,
    /// A frame by timestamp queries (`None` without `TIMESTAMP_QUERY`).
    pub gpu_frame: Option<Duration>,
    /// A frame from the caller's emission to the caller's radiosity: upload, passes, readback.
    pub end_to_end: Duration,
    /// The read kernel over the same bytes, by timestamp queries.
    pub gpu_read: Option<Duration>,
    /// A frame of the CPU [`Evaluator`](crate::Evaluator) with every core.
    pub cpu_frame: Duration,
    /// Wall time per frame of `frames` frames submitted back to back with no readback and
    /// waited for once (a renderer's steady state: uploads overlap the previous frames).
    pub pipelined: Duration,
    /// The papers' hybrid ([`GpuEvaluator::evaluate_hybrid`]): sums and cores on the CPU, the
    /// gather on the GPU; a frame end to end.
    pub hybrid_end_to_end: Duration,
    /// The hybrid's GPU time (the gather alone) by timestamp queries.
    pub hybrid_gpu: Option<Duration>,
    /// [`pipelined`](Self::pipelined) for the hybrid: the CPU computes the next frame's `Z`
    /// while the GPU gathers the previous one.
    pub hybrid_pipelined: Duration,
    /// A frame by timestamp queries, frames run back to back ([`GpuEvaluator::burst`]: the
    /// GPU busy, as in a renderer's steady state); `None` without `TIMESTAMP_QUERY`.
    pub gpu_frame_busy: Option<Duration>,
    /// The read kernel likewise, back to back.
    pub gpu_read_busy: Option<Duration>,
    /// How the gather loads the matrix ([`GpuEvaluator::storage`]).
    pub storage: lrr_shaders::Storage,
    /// The gather's lanes per row.
    pub row_lanes: u32,
    /// The gather's rows per lane and iteration.
    pub gather_rows: u32,
    /// The gather's most workgroups per dispatch.
    pub gather_groups: u32,
    /// The kernels in use ([`GpuEvaluator::describe`]).
    pub kernels: String,
}

impl GpuBench {
    /// Frames per second by GPU time.
    pub fn gpu_fps(&self) -> Option<f64> {
        self.gpu_frame.map(|t| 1.0 / t.as_secs_f64())
    }

    /// Frames per second end to end.
    pub fn end_to_end_fps(&self) -> f64 {
        1.0 / self.end_to_end.as_secs_f64()
    }

    /// Read kernel time / frame time on the GPU: 1 is a frame as fast as reading its bytes.
    pub fn read_fraction(&self) -> Option<f64> {
        Some(self.gpu_read?.as_secs_f64() / self.gpu_frame?.as_secs_f64())
    }

    /// Frames per second by GPU time, back to back.
    pub fn busy_fps(&self) -> Option<f64> {
        self.gpu_frame_busy.map(|t| 1.0 / t.as_secs_f64())
    }

    /// Read kernel time / frame time, both back to back.
    pub fn busy_read_fraction(&self) -> Option<f64> {
        Some(self.gpu_read_busy?.as_secs_f64() / self.gpu_frame_busy?.as_secs_f64())
    }

    /// CPU frame time / GPU frame time (GPU time of frames back to back; end to end if there
    /// are no timestamps).
    pub fn speedup(&self) -> f64 {
        let gpu = self
            .gpu_frame_busy
            .or(self.gpu_frame)
            .unwrap_or(self.end_to_end);
        self.cpu_frame.as_secs_f64() / gpu.as_secs_f64()
    }

    /// Full-GPU pipelined frame time / hybrid pipelined frame time: above 1, the hybrid wins.
    pub fn hybrid_gain(&self) -> f64 {
        self.pipelined.as_secs_f64() / self.hybrid_pipelined.as_secs_f64()
    }

    /// CPU frame time / GPU end-to-end time.
    pub fn speedup_end_to_end(&self) -> f64 {
        self.cpu_frame.as_secs_f64() / self.end_to_end.as_secs_f64()
    }
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// Measures `frames` (at least 1) frames of `op` with its baked emission: GPU frames, read
/// passes, hybrid frames and CPU frames alternate, so all see the same machine; one warm-up of
/// each first. Then `frames` pipelined frames of the full GPU path and of the hybrid, twice
/// each, alternated (the faster of the two runs of each). Last, a
/// [`burst`](GpuEvaluator::burst): 0.3 s of warm-up, then `frames` frames and read passes
/// back to back, each timed (the busy GPU's figures).
pub fn bench_operator(gpu: &Gpu, op: &Operator, frames: usize) -> Result<GpuBench, GpuError> {
    let mut eval = GpuEvaluator::new(gpu, op)?;
    let mut cpu = op.evaluator(0)?;
    let e = op.baked_emission();
    let mut out = vec![[0.0f32; 3]; op.n()];
    let mut frame = |eval: &mut GpuEvaluator| -> Result<FrameTiming, GpuError> {
        eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))?;
        Ok(eval.last_timing().expect("set by evaluate"))
    };
    let hybrid = |eval: &mut GpuEvaluator, out: &mut [[f32; 3]]| {
        eval.evaluate_hybrid(Rgb::triples(&e), RgbMut::triples(out))?;
        Ok::<_, GpuError>(eval.last_timing().expect("set by evaluate_hybrid"))
    };
    let mut cpu_out = vec![[0.0f32; 3]; op.n()];
    frame(&mut eval)?;
    eval.read_pass()?;
    hybrid(&mut eval, &mut cpu_out)?;
    let (mut gpu_t, mut e2e, mut read, mut cpu_t) = (vec![], vec![], vec![], vec![]);
    let (mut hybrid_gpu, mut hybrid_e2e) = (vec![], vec![]);
    for _ in 0..frames.max(1) {
        let t = frame(&mut eval)?;
        gpu_t.extend(t.gpu);
        e2e.push(t.end_to_end);
        read.extend(eval.read_pass()?.gpu);
        let t = hybrid(&mut eval, &mut cpu_out)?;
        hybrid_gpu.extend(t.gpu);
        hybrid_e2e.push(t.end_to_end);
        let start = Instant::now();
        cpu.evaluate(Rgb::triples(&e), RgbMut::triples(&mut cpu_out))?;
        cpu_t.push(start.elapsed());
    }
    let (mut pipelined, mut hybrid_pipelined) = (Duration::MAX, Duration::MAX);
    for _ in 0..2 {
        pipelined = pipelined.min(per_frame(&mut eval, frames, |ev| {
            ev.submit(Rgb::triples(&e))
        })?);
        hybrid_pipelined = hybrid_pipelined.min(per_frame(&mut eval, frames, |ev| {
            ev.submit_hybrid(Rgb::triples(&e))
        })?);
    }
    let burst = eval.burst(Rgb::triples(&e), frames)?;
    let some = |v: Vec<Duration>| (!v.is_empty()).then(|| median(v));
    Ok(GpuBench {
        n: op.n(),
        k: op.k(),
        matrix_bytes: eval.matrix_bytes(),
        gpu_frame: some(gpu_t),
        end_to_end: median(e2e),
        gpu_read: some(read),
        cpu_frame: median(cpu_t),
        pipelined,
        hybrid_end_to_end: median(hybrid_e2e),
        hybrid_gpu: some(hybrid_gpu),
        hybrid_pipelined,
        gpu_frame_busy: burst.as_ref().map(|b| median(b.frames.clone())),
        gpu_read_busy: burst.map(|b| median(b.reads)),
        storage: eval.storage(),
        row_lanes: eval.row_lanes(),
        gather_rows: eval.gather_rows(),
        gather_groups: eval.gather_groups(),
        kernels: eval.describe(),
    })
}

/// Frame time with naga's bounds checks on every pass (`checked`, a device opened with
/// [`GpuOptions::bounds_checks`](super::GpuOptions::bounds_checks)) over the time without
/// (`gpu`): `frames` (at least 1) frames of each, alternated after one warm-up each, medians
/// of GPU time (of end-to-end time when either adapter has no timestamps).
pub fn bounds_check_cost(
    gpu: &Gpu,
    checked: &Gpu,
    op: &Operator,
    frames: usize,
) -> Result<f64, GpuError> {
    let mut evals = [GpuEvaluator::new(gpu, op)?, GpuEvaluator::new(checked, op)?];
    let e = op.baked_emission();
    let mut out = vec![[0.0f32; 3]; op.n()];
    let mut times: [Vec<FrameTiming>; 2] = [Vec::new(), Vec::new()];
    for round in 0..=frames.max(1) {
        for (eval, t) in evals.iter_mut().zip(&mut times) {
            eval.evaluate(Rgb::triples(&e), RgbMut::triples(&mut out))?;
            if round > 0 {
                t.push(eval.last_timing().expect("set by evaluate"));
            }
        }
    }
    let gpu_time = times.iter().all(|t| t.iter().all(|f| f.gpu.is_some()));
    let [without, with] = times.map(|t| {
        median(
            t.iter()
                .map(|f| {
                    if gpu_time {
                        f.gpu.unwrap_or_default()
                    } else {
                        f.end_to_end
                    }
                })
                .collect(),
        )
    });
    Ok(with.as_secs_f64() / without.as_secs_f64())
}

/// Wall time per frame of `frames` (at least 1) frames submitted by `submit` back to back and
/// waited for once.
fn per_frame(
    eval: &mut GpuEvaluator,
    frames: usize,
    mut submit: impl FnMut(&mut GpuEvaluator) -> Result<(), GpuError>,
) -> Result<Duration, GpuError> {
    eval.wait()?;
    let frames = frames.max(1);
    let start = Instant::now();
    for _ in 0..frames {
        submit(eval)?;
    }
    eval.wait()?;
    Ok(start.elapsed() / frames as u32)
}
