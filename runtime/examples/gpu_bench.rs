//! GPU frame rates per size and precision: by GPU time (timestamp queries) and end to end
//! (upload + frame + readback), the gather's time as a fraction of a plain read kernel over the
//! same bytes in the same run, and the speed-up over the CPU evaluator (every core).
//!
//! ```text
//! cargo run --release -p lrr-runtime --features gpu --example gpu_bench -- \
//!     [--sizes 221184x216,…] [--precision f32,f16] [--frames 10] [--adapter NAME]
//! cargo run --release -p lrr-runtime --features gpu --example gpu_bench -- --adapters
//! ```
//!
//! On lavapipe (Mesa's CPU Vulkan adapter) the figures say nothing about a GPU: correctness
//! only. Operators are synthetic (factored, RGB).

use lrr_runtime::gpu::{self, Gpu, GpuOptions, bench_operator};
use lrr_runtime::testkit::synthetic;
use lrr_runtime::{Layout, Precision};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).cloned()
    };
    let options = GpuOptions {
        adapter: value("--adapter"),
        ..GpuOptions::default()
    };
    if args.iter().any(|a| a == "--adapters") {
        for a in gpu::adapters() {
            println!("found: {a}");
        }
        println!("using: {}", Gpu::new(&options)?.describe());
        return Ok(());
    }
    let sizes = value("--sizes").unwrap_or_else(|| "20000x216,221184x216".into());
    let precisions = value("--precision").unwrap_or_else(|| "f32,f16".into());
    let frames: usize = value("--frames").map_or(Ok(10), |f| f.parse())?;
    let gpu = Gpu::new(&options)?;
    println!("{}", gpu.describe());
    println!(
        "{:>8} {:>5} {:>9} {:>10} {:>10} {:>9} {:>9} {:>9} {:>8} {:>8}",
        "n",
        "k",
        "precision",
        "MB/frame",
        "gpu fps",
        "e2e fps",
        "read/frm",
        "cpu fps",
        "x gpu",
        "x e2e"
    );
    for size in sizes.split(',') {
        let (n, k) = size.split_once('x').ok_or("sizes look like 221184x216")?;
        let (n, k): (usize, usize) = (n.parse()?, k.parse()?);
        for p in precisions.split(',') {
            let precision = if p == "f16" {
                Precision::F16
            } else {
                Precision::F32
            };
            let op = synthetic::operator(n, k, 3, precision, Layout::Factored, 1)?;
            let b = bench_operator(&gpu, &op, frames)?;
            let opt = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.2}"));
            println!(
                "{n:>8} {k:>5} {p:>9} {:>10.1} {:>10} {:>9.2} {:>9} {:>9.2} {:>8.2} {:>8.2}",
                b.matrix_bytes as f64 / 1e6,
                opt(b.gpu_fps()),
                b.end_to_end_fps(),
                opt(b.read_fraction()),
                1.0 / b.cpu_frame.as_secs_f64(),
                b.speedup(),
                b.speedup_end_to_end(),
            );
            eprintln!("  {}", b.kernels);
        }
    }
    Ok(())
}
