//! `lrr bench runtime --device gpu`: the wgpu evaluator per size and precision, by GPU time
//! (timestamp queries) and end to end (upload + frame + readback), against a plain read kernel
//! over the same bytes, the CPU evaluator and the papers' hybrid, all in one run.

use std::io::Write;

use anyhow::{Result, bail};
use clap::Args;
use lrr_runtime::gpu::{Gpu, GpuBench, GpuOptions, bench_operator, bounds_check_cost};
use lrr_runtime::{Layout, Operator, Precision};
use serde::Serialize;

use crate::bench_operators::{Operators, cornell_operator, parse_size, precisions, recast};
use crate::emission::{Device, one_line};

/// Flags of the GPU benchmark.
#[derive(Debug, Args)]
pub struct GpuBenchArgs {
    /// GPU: frames per measurement (medians; the pipelined runs submit this many back to back).
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// GPU: use only an adapter whose name contains this (case-insensitive).
    #[arg(long)]
    pub adapter: Option<String>,
    /// GPU: also measure every pass built with naga's bounds checks, and report the frame time
    /// with checks over the frame time without.
    #[arg(long)]
    pub bounds_checks: bool,
    /// GPU: measure the gather with each of these lanes per row (powers of two up to 32), a
    /// row each [default: about four octets per lane].
    #[arg(long, value_delimiter = ',')]
    pub row_lanes: Vec<u32>,
    /// GPU: measure the gather with at most each of these workgroups per dispatch, a row each
    /// [default: 4096].
    #[arg(long, value_delimiter = ',')]
    pub gather_groups: Vec<u32>,
    /// GPU: measure the gather with each of these rows per lane and iteration (1 to 4), a row
    /// each [default: the runtime's default].
    #[arg(long, value_delimiter = ',')]
    pub gather_rows: Vec<u32>,
    /// GPU: measure binary16 operators with each of these loaders (`f16`: native f16 with
    /// SHADER_F16, `unpack`: unpack2x16float, `bits`: integer widening), a row each [default:
    /// the best the adapter has]. f32 operators get one row.
    #[arg(long, value_delimiter = ',')]
    pub f16_loader: Vec<F16Loader>,
}

/// `--f16-loader` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum F16Loader {
    F16,
    Unpack,
    Bits,
}

impl F16Loader {
    fn storage(self) -> lrr_runtime::gpu::Storage {
        match self {
            F16Loader::F16 => lrr_runtime::gpu::Storage::F16,
            F16Loader::Unpack => lrr_runtime::gpu::Storage::F16Unpack,
            F16Loader::Bits => lrr_runtime::gpu::Storage::F16Bits,
        }
    }
}

/// One measured operator on the GPU.
#[derive(Debug, Clone, Serialize)]
pub struct GpuRow {
    pub scene: String,
    pub n: usize,
    pub k: usize,
    pub precision: &'static str,
    pub adapter: String,
    /// Whether the adapter runs on the CPU (lavapipe): its figures are correctness-only.
    pub cpu_adapter: bool,
    pub matrix_bytes: u64,
    /// Frames per second by GPU time (timestamp queries); `None` without them.
    pub gpu_fps: Option<f64>,
    /// Frames per second by GPU time, frames run back to back (the GPU busy).
    pub gpu_fps_busy: Option<f64>,
    /// Read kernel time / frame time, both back to back.
    pub read_fraction_busy: Option<f64>,
    /// Bytes read per second of GPU time, back to back.
    pub gb_per_s_busy: Option<f64>,
    /// Frames per second from the caller's emission to the caller's radiosity.
    pub end_to_end_fps: f64,
    /// Read kernel time / frame GPU time (1: the frame runs as fast as reading its bytes).
    pub read_fraction: Option<f64>,
    /// Bytes read per second of GPU time.
    pub gb_per_s: Option<f64>,
    /// The CPU evaluator (every core) in the same run.
    pub cpu_fps: f64,
    /// CPU frame time / GPU frame time (GPU time of frames back to back; end to end without
    /// timestamps).
    pub speedup: f64,
    /// CPU frame time / GPU end-to-end time.
    pub speedup_end_to_end: f64,
    /// Frames per second submitted back to back with no readback (a renderer's steady state).
    pub pipelined_fps: f64,
    /// The hybrid (sums and cores on the CPU, gather on the GPU), end to end and pipelined.
    pub hybrid_end_to_end_fps: f64,
    pub hybrid_pipelined_fps: f64,
    /// Pipelined full-GPU frame time / pipelined hybrid frame time: above 1, the hybrid wins.
    pub hybrid_gain: f64,
    /// GPU frame time with naga's bounds checks / without (`--bounds-checks`).
    pub bounds_check_cost: Option<f64>,
    /// How the gather loads the matrix: F32, F16 (native), F16Unpack, F16Bits.
    pub loader: String,
    /// The gather's lanes per row.
    pub row_lanes: u32,
    /// The gather's rows per lane and iteration.
    pub gather_rows: u32,
    /// The gather's most workgroups per dispatch.
    pub gather_groups: u32,
    pub kernels: String,
}

impl GpuRow {
    fn new(scene: &str, precision: Precision, gpu: &Gpu, b: &GpuBench) -> Self {
        let secs = |d: std::time::Duration| d.as_secs_f64();
        GpuRow {
            scene: scene.to_owned(),
            n: b.n,
            k: b.k,
            precision: precision_name(precision),
            adapter: gpu.adapter_name().to_owned(),
            cpu_adapter: gpu.is_cpu(),
            matrix_bytes: b.matrix_bytes,
            gpu_fps: b.gpu_fps(),
            gpu_fps_busy: b.busy_fps(),
            read_fraction_busy: b.busy_read_fraction(),
            gb_per_s_busy: b
                .gpu_frame_busy
                .map(|t| b.matrix_bytes as f64 / secs(t) / 1e9),
            end_to_end_fps: b.end_to_end_fps(),
            read_fraction: b.read_fraction(),
            gb_per_s: b.gpu_frame.map(|t| b.matrix_bytes as f64 / secs(t) / 1e9),
            cpu_fps: 1.0 / secs(b.cpu_frame),
            speedup: b.speedup(),
            speedup_end_to_end: b.speedup_end_to_end(),
            pipelined_fps: 1.0 / secs(b.pipelined),
            hybrid_end_to_end_fps: 1.0 / secs(b.hybrid_end_to_end),
            hybrid_pipelined_fps: 1.0 / secs(b.hybrid_pipelined),
            hybrid_gain: b.hybrid_gain(),
            bounds_check_cost: None,
            loader: format!("{:?}", b.storage),
            row_lanes: b.row_lanes,
            gather_rows: b.gather_rows,
            gather_groups: b.gather_groups,
            kernels: b.kernels.clone(),
        }
    }
}

fn precision_name(p: Precision) -> &'static str {
    match p {
        Precision::F32 => "f32",
        Precision::F16 => "f16",
    }
}

/// Runs the GPU benchmark. `Ok(false)`: `--device auto` found no usable adapter and said so;
/// the caller benchmarks the CPU instead.
pub fn run(
    args: &GpuBenchArgs,
    device: Device,
    operators: &Operators<'_>,
    json: bool,
    out: &mut dyn Write,
) -> Result<bool> {
    let options = GpuOptions {
        adapter: args.adapter.clone(),
        ..GpuOptions::default()
    };
    let loaders: Vec<_> = args.f16_loader.iter().map(|l| l.storage()).collect();
    let mut variants = Vec::new();
    for f16_loader in each(&loaders) {
        for row_lanes in each(&args.row_lanes) {
            for gather_rows in each(&args.gather_rows) {
                for gather_groups in each(&args.gather_groups) {
                    variants.push(GpuOptions {
                        row_lanes,
                        gather_rows,
                        gather_groups,
                        f16_loader,
                        ..options.clone()
                    });
                }
            }
        }
    }
    let gpu = match Gpu::new(&variants[0]) {
        Ok(gpu) => gpu,
        Err(e) if device == Device::Auto => {
            eprintln!(
                "lrr: note: --device auto: benchmarking the CPU ({})",
                one_line(&e)
            );
            return Ok(false);
        }
        Err(e) => bail!("--device gpu: {}", one_line(&e)),
    };
    eprintln!("lrr bench: GPU {}", gpu.describe());
    let checked = if args.bounds_checks {
        // The first variant's gather shape, checked: compared with that variant's frames.
        let options = GpuOptions {
            bounds_checks: true,
            ..variants[0].clone()
        };
        Some(Gpu::new(&options).map_err(|e| anyhow::anyhow!("{}", one_line(&e)))?)
    } else {
        None
    };
    // The other variants' devices (the first is `gpu`).
    let mut tuned = Vec::new();
    for v in &variants[1..] {
        tuned.push(Gpu::new(v).map_err(|e| anyhow::anyhow!("{}", one_line(&e)))?);
    }
    let mut rows = Vec::new();
    let mut measure = |scene: &str, p: Precision, op: &Operator| -> Result<()> {
        for (i, gpu) in std::iter::once(&gpu).chain(&tuned).enumerate() {
            // An f32 operator is measured once per lanes/rows/groups variant, not once per
            // binary16 loader.
            if p == Precision::F32 && gpu.options().f16_loader != variants[0].f16_loader {
                continue;
            }
            let bench = bench_operator(gpu, op, args.frames)?;
            let mut row = GpuRow::new(scene, p, gpu, &bench);
            if i == 0
                && let Some(checked) = &checked
            {
                row.bounds_check_cost = Some(bounds_check_cost(gpu, checked, op, args.frames)?);
            }
            eprintln!(
                "lrr bench: GPU {scene} {}×{} {} ({} lanes per row, {} rows per lane, at most {} \
                 workgroups) done ({:.1} fps end to end, {} fps GPU time back to back)",
                row.n,
                row.k,
                row.precision,
                row.row_lanes,
                row.gather_rows,
                row.gather_groups,
                row.end_to_end_fps,
                row.gpu_fps_busy
                    .map_or("-".to_owned(), |f| format!("{f:.1}"))
            );
            rows.push(row);
        }
        Ok(())
    };
    if operators.cornell {
        let op = cornell_operator()?;
        for p in precisions(operators.precisions)? {
            let op = if p == Precision::F32 {
                op.clone()
            } else {
                recast(&op, p)?
            };
            measure("cornell-box", p, &op)?;
        }
    }
    for size in operators.sizes {
        let (n, k) = parse_size(size)?;
        for p in precisions(operators.precisions)? {
            let op = lrr_runtime::testkit::synthetic::operator(n, k, 3, p, Layout::Factored, 7)?;
            measure("synthetic", p, &op)?;
        }
    }
    if json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
    } else {
        print_table(&rows, out)?;
    }
    Ok(true)
}

/// A swept flag's values as options, or the runtime's default alone when none was given.
fn each<T: Copy>(values: &[T]) -> Vec<Option<T>> {
    if values.is_empty() {
        vec![None]
    } else {
        values.iter().copied().map(Some).collect()
    }
}

fn print_table(rows: &[GpuRow], out: &mut dyn Write) -> Result<()> {
    let opt = |v: Option<f64>, digits: usize| v.map_or("-".to_owned(), |v| format!("{v:.digits$}"));
    if let Some(r) = rows.first() {
        writeln!(out, "adapter: {}", r.adapter)?;
        if r.cpu_adapter {
            writeln!(
                out,
                "note: a CPU adapter (lavapipe): its \"GPU time\" is CPU time; figures are \
                 correctness-only"
            )?;
        }
    }
    writeln!(
        out,
        "GPU time by timestamps: \"busy\" of frames run back to back (then read passes back to \
         back), \"waited\" of frames each read back and waited for (the GPU idles in between)"
    )?;
    writeln!(
        out,
        "| scene | n | k | prec | MB/frame | fps (GPU, busy) | read / frame (busy) | GB/s (busy) \
         | fps (GPU, waited) | read / frame (waited) | fps (end to end) | CPU fps | × CPU (GPU \
         time) | × CPU (end to end) | pipelined fps | hybrid pipelined fps | hybrid gain | \
         bounds checks cost | loader | lanes/row | rows/lane | groups |"
    )?;
    writeln!(out, "|{}", "---|".repeat(22))?;
    for r in rows {
        writeln!(
            out,
            "| {} | {} | {} | {} | {:.1} | {} | {} | {} | {} | {} | {:.1} | {:.1} | {:.2} | {:.2} \
             | {:.1} | {:.1} | {:.2} | {} | {} | {} | {} | {} |",
            r.scene,
            r.n,
            r.k,
            r.precision,
            r.matrix_bytes as f64 / 1e6,
            opt(r.gpu_fps_busy, 1),
            opt(r.read_fraction_busy, 2),
            opt(r.gb_per_s_busy, 1),
            opt(r.gpu_fps, 1),
            opt(r.read_fraction, 2),
            r.end_to_end_fps,
            r.cpu_fps,
            r.speedup,
            r.speedup_end_to_end,
            r.pipelined_fps,
            r.hybrid_pipelined_fps,
            r.hybrid_gain,
            opt(r.bounds_check_cost, 2),
            r.loader,
            r.row_lanes,
            r.gather_rows,
            r.gather_groups,
        )?;
    }
    let mut kernels: Vec<&str> = rows.iter().map(|r| r.kernels.as_str()).collect();
    kernels.dedup();
    for k in kernels {
        writeln!(out, "kernels: {k}")?;
    }
    Ok(())
}
