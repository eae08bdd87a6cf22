//! Frame time of the factored evaluator against a plain read of the same bytes.
//!
//! `cargo run --release -p lrr-runtime --example roofline -- [n] [k] [threads] [f32|f16] [frames]`
//! (defaults: 221184 216 2 f32 20). Reads and frames alternate, so both see the same machine;
//! prints the best of each and the median of the per-pair ratios (read time / frame time: 1 is
//! a frame as fast as reading its bytes).

use std::time::{Duration, Instant};

use lrr_runtime::testkit::synthetic;
use lrr_runtime::{Evaluator, Layout, Precision, Rgb, RgbMut, SimdLevel};

fn time(f: impl FnOnce()) -> Duration {
    let t = Instant::now();
    f();
    t.elapsed()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg =
        |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (n, k, threads, frames) = (arg(0, 221_184), arg(1, 216), arg(2, 2), arg(4, 20));
    let precision = match args.get(3).map(String::as_str) {
        Some("f16") => Precision::F16,
        _ => Precision::F32,
    };
    let op = synthetic::operator(n, k, 3, precision, Layout::Factored, 1)?;
    let e = op.baked_emission();
    let mut out = vec![[0.0f32; 3]; n];
    let gb = op.matrix_bytes() as f64 / 1e9;
    println!(
        "n = {n}, k = {k}, {precision:?}, {threads} threads, {:.1} MB per frame",
        gb * 1e3
    );
    let levels = [SimdLevel::Avx2, SimdLevel::Scalar];
    for simd in levels.into_iter().filter(|b| b.supported()) {
        let mut eval = Evaluator::with_simd(&op, threads, simd)?;
        let mut sum = 0u64;
        let (mut reads, mut frames_t, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..frames {
            let read = time(|| sum = sum.wrapping_add(eval.read_pass().unwrap_or(0)));
            let frame = time(|| {
                let out = RgbMut::triples(&mut out);
                eval.evaluate(Rgb::triples(&e), out).unwrap_or(());
            });
            reads.push(read.as_secs_f64());
            frames_t.push(frame.as_secs_f64());
            ratios.push(read.as_secs_f64() / frame.as_secs_f64());
        }
        ratios.sort_by(f64::total_cmp);
        let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let (frame, read) = (best(&frames_t), best(&reads));
        println!(
            "{:14} frame {:7.2} ms ({:5.1} GB/s, {:6.1} fps) | read {:7.2} ms ({:5.1} GB/s) | \
             best read / best frame = {:.2}, median of pairs = {:.2}   [{sum:x}]",
            simd.name(),
            frame * 1e3,
            gb / frame,
            1.0 / frame,
            read * 1e3,
            gb / read,
            read / frame,
            ratios[ratios.len() / 2],
        );
    }
    Ok(())
}
