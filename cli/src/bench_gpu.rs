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
    /// Frames per second from the caller's emission to the caller's radiosity.
    pub end_to_end_fps: f64,
    /// Read kernel time / frame GPU time (1: the frame runs as fast as reading its bytes).
    pub read_fraction: Option<f64>,
    /// Bytes read per second of GPU time.
    pub gb_per_s: Option<f64>,
    /// The CPU evaluator (every core) in the same run.
    pub cpu_fps: f64,
    /// CPU frame time / GPU frame time (GPU time; end to end without timestamps).
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
    let gpu = match Gpu::new(&options) {
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
        let options = GpuOptions {
            bounds_checks: true,
            ..options
        };
        Some(Gpu::new(&options).map_err(|e| anyhow::anyhow!("{}", one_line(&e)))?)
    } else {
        None
    };
    let mut rows = Vec::new();
    let mut measure = |scene: &str, p: Precision, op: &Operator| -> Result<()> {
        let bench = bench_operator(&gpu, op, args.frames)?;
        let mut row = GpuRow::new(scene, p, &gpu, &bench);
        if let Some(checked) = &checked {
            row.bounds_check_cost = Some(bounds_check_cost(&gpu, checked, op, args.frames)?);
        }
        eprintln!(
            "lrr bench: GPU {scene} {}×{} {} done ({:.1} fps end to end)",
            row.n, row.k, row.precision, row.end_to_end_fps
        );
        rows.push(row);
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
        "| scene | n | k | prec | MB/frame | fps (GPU time) | fps (end to end) | read / frame | \
         GB/s | CPU fps | × CPU (GPU time) | × CPU (end to end) | pipelined fps | hybrid \
         pipelined fps | hybrid gain | bounds checks cost |"
    )?;
    writeln!(out, "|{}", "---|".repeat(16))?;
    for r in rows {
        writeln!(
            out,
            "| {} | {} | {} | {} | {:.1} | {} | {:.1} | {} | {} | {:.1} | {:.2} | {:.2} | {:.1} | \
             {:.1} | {:.2} | {} |",
            r.scene,
            r.n,
            r.k,
            r.precision,
            r.matrix_bytes as f64 / 1e6,
            opt(r.gpu_fps, 1),
            r.end_to_end_fps,
            opt(r.read_fraction, 2),
            opt(r.gb_per_s, 1),
            r.cpu_fps,
            r.speedup,
            r.speedup_end_to_end,
            r.pipelined_fps,
            r.hybrid_pipelined_fps,
            r.hybrid_gain,
            opt(r.bounds_check_cost, 2),
        )?;
    }
    let mut kernels: Vec<&str> = rows.iter().map(|r| r.kernels.as_str()).collect();
    kernels.dedup();
    for k in kernels {
        writeln!(out, "kernels: {k}")?;
    }
    Ok(())
}
