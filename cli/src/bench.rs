//! `lrr bench runtime`: frames per second of the runtime's layouts against the papers'
//! dense baseline and a plain memory read, measured side by side in one run.

use std::io::Write;
use std::time::Instant;

use anyhow::Result;
use clap::{Args, Subcommand};
use lrr_runtime::testkit::baseline::DenseV;
use lrr_runtime::{Evaluator, Layout, Operator, Precision, Rgb, RgbMut};
use serde::Serialize;

use crate::bench_operators::{Operators, cornell_operator, parse_size, precisions, recast};

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchKind,
}

#[derive(Debug, Subcommand)]
pub enum BenchKind {
    /// Runtime frame rates: (a) factored RGB, (b) plain per-channel Y_k, (c) dense V_k per
    /// channel (the papers' baseline, same threads and kernels), (d) a plain read of the bytes
    /// (a) reads (the roofline), (e) the factored frame from light-group intensities (no O(n)
    /// emission pass), (f) a plain read of the bytes (c) reads (the baseline's roofline).
    Runtime(RuntimeBench),
    /// Occlusion rays/s of the visibility backends (Embree, obvhs, the default path) on the
    /// form-factor rays of the Cornell box and a cluttered room, one thread and all cores.
    Visibility(crate::bench_visibility::VisibilityBench),
    /// Ray tracer rays/s by kind (primary, shadow, secondary) at 1920x1080 against Embree's
    /// single-ray queries on the same rays, one thread; whole frames with the decided effects
    /// against all forced on.
    Render(crate::bench_render::RenderBench),
    /// Relit frames per second with moving point lights: the direct pass (shadow rays per
    /// second) and the operator's frame, each timed, against the same lights standing still.
    Lights(crate::bench_lights::LightsBench),
    /// The runtime's lightmap fill (samples and dilation) against a plain pass over the bytes
    /// it moves, on the same threads.
    Lightmap(crate::bench_lightmap::LightmapBench),
}

#[derive(Debug, Args)]
pub struct RuntimeBench {
    /// Synthetic operator sizes n×k, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "3456x216,13824x864,55296x864,221184x216"
    )]
    pub sizes: Vec<String>,
    /// Precisions of F_k to measure.
    #[arg(long, value_delimiter = ',', default_value = "f32,f16")]
    pub precisions: Vec<String>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seconds of frames per variant and round.
    #[arg(long, default_value_t = 0.3)]
    pub seconds: f64,
    /// Rounds; each round times (a), (d), (e), (d), (a), (c), (f), (c), (a), (b) back to back;
    /// ratios are medians of per-round ratios between the measurements around each other.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Skip the Cornell box row (which bakes the bundled scene first).
    #[arg(long)]
    pub no_cornell: bool,
    /// Print JSON rows instead of a table.
    #[arg(long)]
    pub json: bool,
    /// `cpu`: the table above. `gpu`: the wgpu evaluator on the best adapter (GPU time and end
    /// to end, a plain read kernel over the same bytes, the CPU path, the papers' hybrid), an
    /// error naming the adapters found when none is usable. `auto`: the GPU when usable.
    #[arg(long, value_enum, default_value_t = crate::emission::Device::Cpu)]
    pub device: crate::emission::Device,
    #[command(flatten)]
    pub gpu: crate::bench_gpu::GpuBenchArgs,
}

/// One measured size.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub scene: String,
    pub n: usize,
    pub k: usize,
    pub precision: &'static str,
    pub threads: usize,
    /// Frames per second of (a).
    pub fps: f64,
    pub fps_plain: f64,
    pub fps_dense: f64,
    pub fps_read: f64,
    /// time(d) / time(a): how close (a) is to reading its bytes.
    pub roofline_ratio: f64,
    /// time(c) / time(a).
    pub speedup_vs_dense: f64,
    /// Bytes of `V_k` and `Y_k` a frame of (c) reads (same precision as (a)), and
    /// `dense_bytes_per_frame / bytes_per_frame`: the speed-up a layout alone would give if
    /// both frames ran at their read rate.
    pub dense_bytes_per_frame: usize,
    pub byte_ratio: f64,
    /// (f) a plain read of the bytes (c) reads; time(f) / time(c): how close the baseline is
    /// to its own roofline (how well it is engineered).
    pub fps_dense_read: f64,
    pub dense_roofline_ratio: f64,
    /// (e) the factored frame from light-group intensities (`Vᵀ E` from the stored groups, no
    /// O(n) pass over an emission on the calling thread), when the operator has light groups.
    pub fps_groups: Option<f64>,
    /// time(d) / time(e).
    pub roofline_ratio_groups: Option<f64>,
    /// Bytes of the matrix a frame of (a) reads, and the rate it reads them at.
    pub bytes_per_frame: usize,
    pub gb_per_s: f64,
}

pub fn run(a: &BenchArgs, out: &mut dyn Write) -> Result<()> {
    let b = match &a.what {
        BenchKind::Runtime(b) => b,
        BenchKind::Visibility(v) => return crate::bench_visibility::run(v, out),
        BenchKind::Render(r) => return crate::bench_render::run(r, out),
        BenchKind::Lights(l) => return crate::bench_lights::run(l, out),
        BenchKind::Lightmap(l) => return crate::bench_lightmap::run(l, out),
    };
    if b.device != crate::emission::Device::Cpu {
        let operators = Operators {
            sizes: &b.sizes,
            precisions: &b.precisions,
            cornell: !b.no_cornell,
        };
        if crate::bench_gpu::run(&b.gpu, b.device, &operators, b.json, out)? {
            return Ok(());
        }
    }
    let threads = b
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let mut rows = Vec::new();
    if !b.no_cornell {
        let op = cornell_operator()?;
        for p in precisions(&b.precisions)? {
            let op = if p == Precision::F32 {
                op.clone()
            } else {
                recast(&op, p)?
            };
            rows.push(measure("cornell-box", &op, threads, b)?);
            report_progress(rows.last().expect("just pushed"));
        }
    }
    for size in &b.sizes {
        let (n, k) = parse_size(size)?;
        for p in precisions(&b.precisions)? {
            let op = lrr_runtime::testkit::synthetic::operator(n, k, 3, p, Layout::Factored, 7)?;
            rows.push(measure("synthetic", &op, threads, b)?);
            report_progress(rows.last().expect("just pushed"));
        }
    }
    if b.json {
        writeln!(out, "{}", serde_json::to_string_pretty(&rows)?)?;
    } else {
        print_table(&rows, out)?;
    }
    Ok(())
}

fn report_progress(r: &Row) {
    eprintln!(
        "lrr bench: {} {}×{} {} done ({:.1} fps)",
        r.scene, r.n, r.k, r.precision, r.fps
    );
}

/// Times `frame` repeatedly for about `seconds`; returns seconds per frame.
fn time_frames(seconds: f64, mut frame: impl FnMut() -> Result<()>) -> Result<f64> {
    frame()?; // warm caches and pages
    let start = Instant::now();
    let mut frames = 0u32;
    while frames < 3 || start.elapsed().as_secs_f64() < seconds {
        frame()?;
        frames += 1;
    }
    Ok(start.elapsed().as_secs_f64() / f64::from(frames))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Measures the four variants on one operator, interleaved over rounds.
fn measure(scene: &str, op: &Operator, threads: usize, b: &RuntimeBench) -> Result<Row> {
    let n = op.n();
    let emission: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            if i % 97 == 0 {
                [1.0, 0.8, 0.6]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    let mut radiosity = vec![[0.0f32; 3]; n];
    let mut factored = op.evaluator(threads)?;
    let plain_op = Operator::from_file(op.file().to_plain_yk(threads)?)?;
    let mut plain = plain_op.evaluator(threads)?;
    let mut dense = DenseV::new(op, threads)?;
    let mut sink = 0u64;
    let (mut ta, mut tb, mut tc, mut td) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut tf, mut dense_roof) = (Vec::new(), Vec::new());
    // Ratios are taken per round between neighbouring measurements and their median reported:
    // on a shared machine (other tenants, a last-level cache that may or may not hold the
    // operator) the regime changes between rounds, and a ratio of medians would mix regimes.
    let (mut roof, mut speedup) = (Vec::new(), Vec::new());
    let groups = vec![1.0f32; op.light_groups().len()];
    let (mut te, mut roof_groups) = (Vec::new(), Vec::new());
    for _ in 0..b.rounds.max(1) {
        let frame = |factored: &mut Evaluator, radiosity: &mut [[f32; 3]]| {
            time_frames(b.seconds, || {
                Ok(factored.evaluate(Rgb::triples(&emission), RgbMut::triples(radiosity))?)
            })
        };
        let mut read = |factored: &mut Evaluator| {
            time_frames(b.seconds, || {
                sink = sink.wrapping_add(factored.read_pass()?);
                Ok(())
            })
        };
        // (a) (d) [(e)] (d) (a): symmetric, so whatever drifts within a round (and what the
        // variant before did to the cache) weighs on (a) and (d) alike.
        let a = frame(&mut factored, &mut radiosity)?;
        let d = read(&mut factored)?;
        let e = if groups.is_empty() {
            None
        } else {
            Some(time_frames(b.seconds, || {
                Ok(factored.evaluate_groups(&groups, RgbMut::triples(&mut radiosity))?)
            })?)
        };
        let d2 = read(&mut factored)?;
        let a2 = frame(&mut factored, &mut radiosity)?;
        if let Some(e) = e {
            te.push(e);
            roof_groups.push((d + d2) / (2.0 * e));
        }
        // (c) (f) (c) between two (a), likewise.
        let baseline = |dense: &mut DenseV, radiosity: &mut [[f32; 3]]| {
            time_frames(b.seconds, || {
                Ok(dense.evaluate(Rgb::triples(&emission), RgbMut::triples(radiosity))?)
            })
        };
        let c = baseline(&mut dense, &mut radiosity)?;
        let f = time_frames(b.seconds, || {
            sink = sink.wrapping_add(dense.read_pass()?);
            Ok(())
        })?;
        let c2 = baseline(&mut dense, &mut radiosity)?;
        let a3 = frame(&mut factored, &mut radiosity)?;
        tb.push(time_frames(b.seconds, || {
            Ok(plain.evaluate(Rgb::triples(&emission), RgbMut::triples(&mut radiosity))?)
        })?);
        roof.push((d + d2) / (a + a2));
        speedup.push((c + c2) / (a2 + a3));
        dense_roof.push(2.0 * f / (c + c2));
        ta.extend([a, a2, a3]);
        tc.extend([c, c2]);
        tf.push(f);
        td.extend([d, d2]);
    }
    std::hint::black_box(sink);
    let (a, pb, c, d) = (median(ta), median(tb), median(tc), median(td));
    let bytes = op.matrix_bytes();
    let dense_bytes = dense.bytes_per_frame();
    Ok(Row {
        scene: scene.to_string(),
        n,
        k: op.k(),
        precision: if op.precision() == Precision::F16 {
            "f16"
        } else {
            "f32"
        },
        threads,
        fps: 1.0 / a,
        fps_plain: 1.0 / pb,
        fps_dense: 1.0 / c,
        fps_read: 1.0 / d,
        roofline_ratio: median(roof),
        fps_groups: (!te.is_empty()).then(|| 1.0 / median(te)),
        roofline_ratio_groups: (!roof_groups.is_empty()).then(|| median(roof_groups)),
        speedup_vs_dense: median(speedup),
        dense_bytes_per_frame: dense_bytes,
        byte_ratio: dense_bytes as f64 / bytes as f64,
        fps_dense_read: 1.0 / median(tf),
        dense_roofline_ratio: median(dense_roof),
        bytes_per_frame: bytes,
        gb_per_s: bytes as f64 / a / 1e9,
    })
}

fn print_table(rows: &[Row], out: &mut dyn Write) -> Result<()> {
    writeln!(
        out,
        "{:<12} {:>9} {:>5} {:>4} {:>3} {:>9} {:>9} {:>9} {:>9} {:>6} {:>7} {:>8} {:>8} {:>6} {:>6} {:>6} {:>9} {:>6}",
        "scene",
        "n",
        "k",
        "prec",
        "thr",
        "(a) fps",
        "(b) fps",
        "(c) fps",
        "(d) fps",
        "a/roof",
        "a/dense",
        "(a) MB",
        "(c) MB",
        "bytes",
        "c/roof",
        "GB/s",
        "(e) fps",
        "e/roof"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<12} {:>9} {:>5} {:>4} {:>3} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>6.2} {:>7.2} {:>8.1} {:>8.1} {:>6.2} {:>6.2} {:>6.2} {:>9} {:>6}",
            r.scene,
            r.n,
            r.k,
            r.precision,
            r.threads,
            r.fps,
            r.fps_plain,
            r.fps_dense,
            r.fps_read,
            r.roofline_ratio,
            r.speedup_vs_dense,
            r.bytes_per_frame as f64 / 1e6,
            r.dense_bytes_per_frame as f64 / 1e6,
            r.byte_ratio,
            r.dense_roofline_ratio,
            r.gb_per_s,
            r.fps_groups.map_or("-".into(), |f| format!("{f:.1}")),
            r.roofline_ratio_groups
                .map_or("-".into(), |f| format!("{f:.2}")),
        )?;
    }
    writeln!(
        out,
        "a/dense: the baseline's frame time over (a)'s; bytes: its bytes per frame over (a)'s \
         (what the layout alone would give at equal read rates); c/roof: (f) read of the \
         baseline's bytes over its frame time"
    )?;
    Ok(())
}
